#include "hardware/codecs/hi219_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

const Time kT0 = TimeFromSeconds(42.0);

Bytes ReadTestdata(const std::string& name) {
  std::ifstream in(std::string(SWEEPSCAN_SHARED_TESTDATA) + "/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << "missing test vector " << name;
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void ExpectAccounting(const Hi219Decoder& d) {
  const DecoderStats& s = d.stats();
  EXPECT_EQ(s.bytes_in, s.bytes_in_frames + s.bytes_skipped + d.BufferedBytes()) << s.ToString();
}

// Bitwise comparison of everything a frame carries.
bool SameSample(const ImuSample& a, const ImuSample& b) {
  return a.receive_time == b.receive_time && a.fields == b.fields && a.user_id == b.user_id &&
         a.main_status == b.main_status && a.temperature_c == b.temperature_c &&
         std::memcmp(&a.pressure_pa, &b.pressure_pa, sizeof(float)) == 0 &&
         a.system_time_ms == b.system_time_ms &&
         std::memcmp(a.acc_g.data(), b.acc_g.data(), sizeof(a.acc_g)) == 0 &&
         std::memcmp(a.gyro_dps.data(), b.gyro_dps.data(), sizeof(a.gyro_dps)) == 0 &&
         std::memcmp(a.mag_ut.data(), b.mag_ut.data(), sizeof(a.mag_ut)) == 0 &&
         a.roll_deg == b.roll_deg && a.pitch_deg == b.pitch_deg && a.yaw_deg == b.yaw_deg &&
         std::memcmp(a.quat_wxyz.data(), b.quat_wxyz.data(), sizeof(a.quat_wxyz)) == 0;
}

TEST(Hi219CrcTest, XmodemCheckValue) {
  // The catalogue check value of CRC-16/XMODEM over "123456789" is 0x31C3.
  const char* s = "123456789";
  EXPECT_EQ(Crc16Xmodem(reinterpret_cast<const uint8_t*>(s), 9), 0x31C3);
  // Continuation equals one pass.
  EXPECT_EQ(Crc16Xmodem(reinterpret_cast<const uint8_t*>(s) + 4, 5,
                        Crc16Xmodem(reinterpret_cast<const uint8_t*>(s), 4)),
            0x31C3);
}

// Bitwise reference: poly 0x1021, init 0, MSB first.
uint16_t BitwiseCrc(const Bytes& data) {
  uint16_t crc = 0;
  for (uint8_t byte : data) {
    crc ^= static_cast<uint16_t>(byte) << 8;
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 0x8000) ? static_cast<uint16_t>((crc << 1) ^ 0x1021)
                           : static_cast<uint16_t>(crc << 1);
    }
  }
  return crc;
}

TEST(Hi219CrcTest, TableMatchesBitwiseReference) {
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> byte(0, 255);
  for (size_t n = 0; n < 300; ++n) {
    Bytes data(n);
    for (auto& b : data) b = static_cast<uint8_t>(byte(rng));
    EXPECT_EQ(Crc16Xmodem(data.data(), data.size()), BitwiseCrc(data)) << n;
  }
}

TEST(Hi219DecoderTest, VendorExampleFrame) {
  const Bytes vec = ReadTestdata("hipnuc_hi91_example_frame.bin");
  ASSERT_EQ(vec.size(), 82u);
  EXPECT_EQ(ReadU16Le(vec.data() + 2), 76);
  EXPECT_EQ(ReadU16Le(vec.data() + 4), 0xBB14);
  // The CRC skips its own field: bytes 0..3, then the payload.
  EXPECT_EQ(Crc16Xmodem(vec.data() + 6, 76, Crc16Xmodem(vec.data(), 4)), 0xBB14);

  Hi219Decoder d;
  d.Feed(vec, kT0);
  const auto samples = d.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  const ImuSample& s = samples[0];
  EXPECT_EQ(s.receive_time, kT0);
  EXPECT_TRUE(s.Has(kImuAcc) && s.Has(kImuGyro) && s.Has(kImuMag) && s.Has(kImuEuler) &&
              s.Has(kImuQuat) && s.Has(kImuSystemTime) && s.Has(kImuTemperature) &&
              s.Has(kImuPressure) && s.Has(kImuMainStatus));
  EXPECT_FALSE(s.Has(kImuUserId));
  EXPECT_EQ(s.system_time_ms, 1840392u);
  EXPECT_NEAR(s.roll_deg, 13.0519, 5e-5);
  EXPECT_NEAR(s.pitch_deg, 12.1885, 5e-5);
  EXPECT_NEAR(s.yaw_deg, -122.4771, 5e-5);
  EXPECT_NEAR(s.acc_g[0], -0.2206, 5e-5);
  EXPECT_NEAR(s.acc_g[1], 0.2092, 5e-5);
  EXPECT_NEAR(s.acc_g[2], 0.9489, 5e-5);
  // Bytes 1..3 of the payload: main_status 0x1508, temperature 0x23 = 35 C.
  EXPECT_EQ(s.main_status, 0x1508);
  EXPECT_EQ(s.temperature_c, 35);
  // Derived SI values.
  EXPECT_NEAR(s.acc_mps2[2], 0.9489 * 9.80665, 1e-3);
  EXPECT_NEAR(s.yaw_rad, -122.4771 * M_PI / 180, 1e-6);
  EXPECT_NEAR(s.gyro_radps[0], s.gyro_dps[0] * M_PI / 180, 1e-9);
  // A unit quaternion.
  double norm2 = 0;
  for (float q : s.quat_wxyz) norm2 += q * q;
  EXPECT_NEAR(norm2, 1.0, 1e-4);
  EXPECT_EQ(d.stats().frames_ok, 1u);
  ExpectAccounting(d);
}

TEST(Hi219EncoderTest, VendorFrameReEncodesByteExact) {
  const Bytes vec = ReadTestdata("hipnuc_hi91_example_frame.bin");
  Hi219Decoder d;
  d.Feed(vec, kT0);
  const auto samples = d.TakeSamples();
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(EncodeHi219Packet91Frame(samples[0]), vec);
}

TEST(Hi219EncoderTest, LegacyFrameByHand) {
  // Payload: A0 (1000, -500, 250) -> A0 E8 03 0C FE FA 00;
  //          D0 pitch 12.34 -> 1234 = 04D2, roll -5.67 -> -567 = FDC9, yaw 123.4 -> 1234.
  // LEN = 14; CRC-16/XMODEM over 5A A5 0E 00 + payload = 0x7F8A (computed independently).
  ImuSample s;
  s.fields = kImuAcc | kImuEuler;
  s.acc_g = {1.0f, -0.5f, 0.25f};
  s.pitch_deg = 12.34f;
  s.roll_deg = -5.67f;
  s.yaw_deg = 123.4f;
  const Bytes expected = {0x5A, 0xA5, 0x0E, 0x00, 0x8A, 0x7F, 0xA0, 0xE8, 0x03, 0x0C,
                          0xFE, 0xFA, 0x00, 0xD0, 0xD2, 0x04, 0xC9, 0xFD, 0xD2, 0x04};
  EXPECT_EQ(EncodeHi219LegacyFrame(s), expected);

  Hi219Decoder d;
  d.Feed(expected, kT0);
  const auto out = d.TakeSamples();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].fields, kImuAcc | kImuEuler);
  EXPECT_FLOAT_EQ(out[0].acc_g[1], -0.5f);
  EXPECT_FLOAT_EQ(out[0].pitch_deg, 12.34f);
  EXPECT_FLOAT_EQ(out[0].roll_deg, -5.67f);
  EXPECT_FLOAT_EQ(out[0].yaw_deg, 123.4f);
}

TEST(Hi219EncoderTest, LegacySaturatesAndRejectsEmpty) {
  ImuSample s;
  EXPECT_TRUE(EncodeHi219LegacyFrame(s).empty());  // Nothing to send.
  s.fields = kImuGyro;
  s.gyro_dps = {5000.0f, -5000.0f, NAN};  // x 10 exceeds i16.
  const Bytes f = EncodeHi219LegacyFrame(s);
  ASSERT_EQ(f.size(), 6u + 7);
  EXPECT_EQ(ReadI16Le(f.data() + 7), 32767);
  EXPECT_EQ(ReadI16Le(f.data() + 9), -32768);
  EXPECT_EQ(ReadI16Le(f.data() + 11), 0);
  Bytes out;
  EXPECT_FALSE(EncodeHi219Frame(Bytes(257, 0x90), &out));
  EXPECT_FALSE(EncodeHi219Frame(Bytes(), &out));
  EXPECT_TRUE(out.empty());
}

ImuSample RandomSample91(std::mt19937* rng) {
  std::uniform_real_distribution<float> u(-1000, 1000);
  std::uniform_int_distribution<uint32_t> u32;
  ImuSample s;
  s.fields = kImuMainStatus | kImuTemperature | kImuPressure | kImuSystemTime | kImuAcc | kImuGyro |
             kImuMag | kImuEuler | kImuQuat;
  s.main_status = static_cast<uint16_t>(u32(*rng));
  s.temperature_c = static_cast<int8_t>(u32(*rng));
  s.pressure_pa = u(*rng) * 100;
  s.system_time_ms = u32(*rng);
  for (int i = 0; i < 3; ++i) {
    s.acc_g[i] = u(*rng) / 100;
    s.gyro_dps[i] = u(*rng);
    s.mag_ut[i] = u(*rng) / 10;
  }
  s.roll_deg = u(*rng) / 6;
  s.pitch_deg = u(*rng) / 12;
  s.yaw_deg = u(*rng) / 6;
  for (int i = 0; i < 4; ++i) s.quat_wxyz[i] = u(*rng) / 1000;
  return s;
}

TEST(Hi219RoundTripTest, Random91FramesAreExact) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 300; ++trial) {
    ImuSample s = RandomSample91(&rng);
    s.receive_time = kT0;
    const Bytes f = EncodeHi219Packet91Frame(s);
    ASSERT_EQ(f.size(), 82u);
    Hi219Decoder d;
    d.Feed(f, kT0);
    const auto out = d.TakeSamples();
    ASSERT_EQ(out.size(), 1u);
    EXPECT_TRUE(SameSample(out[0], s)) << "trial " << trial;
    EXPECT_EQ(EncodeHi219Packet91Frame(out[0]), f);
  }
}

TEST(Hi219RoundTripTest, RandomLegacyFramesQuantizeToTheScale) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1, 1);
  std::uniform_int_distribution<uint32_t> mask(1, (1u << 7) - 1);
  for (int trial = 0; trial < 300; ++trial) {
    ImuSample s;
    const uint32_t m = mask(rng);
    const ImuField kBits[] = {kImuUserId, kImuAcc,  kImuGyro,    kImuMag,
                              kImuEuler,  kImuQuat, kImuPressure};
    for (int b = 0; b < 7; ++b) {
      if (m & (1u << b)) s.fields |= kBits[b];
    }
    s.user_id = static_cast<uint8_t>(trial);
    for (int i = 0; i < 3; ++i) {
      s.acc_g[i] = 16 * u(rng);
      s.gyro_dps[i] = 2000 * u(rng);
      s.mag_ut[i] = 1000 * u(rng);
    }
    s.pitch_deg = 90 * u(rng);
    s.roll_deg = 180 * u(rng);
    s.yaw_deg = 180 * u(rng);
    for (int i = 0; i < 4; ++i) s.quat_wxyz[i] = u(rng);
    s.pressure_pa = 101325 * (1 + 0.1f * u(rng));

    Hi219Decoder d;
    d.Feed(EncodeHi219LegacyFrame(s), kT0);
    const auto out = d.TakeSamples();
    ASSERT_EQ(out.size(), 1u);
    const ImuSample& r = out[0];
    EXPECT_EQ(r.fields, s.fields);
    if (s.Has(kImuUserId)) {
      EXPECT_EQ(r.user_id, s.user_id);
    }
    for (int i = 0; i < 3; ++i) {
      if (s.Has(kImuAcc)) {
        EXPECT_NEAR(r.acc_g[i], s.acc_g[i], 0.0005 + 1e-6);
      }
      if (s.Has(kImuGyro)) {
        EXPECT_NEAR(r.gyro_dps[i], s.gyro_dps[i], 0.05 + 1e-4);
      }
      if (s.Has(kImuMag)) {
        EXPECT_NEAR(r.mag_ut[i], s.mag_ut[i], 0.05 + 1e-4);
      }
    }
    if (s.Has(kImuEuler)) {
      EXPECT_NEAR(r.pitch_deg, s.pitch_deg, 0.005 + 1e-5);
      EXPECT_NEAR(r.roll_deg, s.roll_deg, 0.005 + 1e-5);
      EXPECT_NEAR(r.yaw_deg, s.yaw_deg, 0.05 + 1e-4);
    }
    if (s.Has(kImuQuat)) {
      EXPECT_EQ(r.quat_wxyz, s.quat_wxyz);
    }
    if (s.Has(kImuPressure)) {
      EXPECT_EQ(r.pressure_pa, s.pressure_pa);
    }
  }
}

Bytes MakeStream(std::mt19937* rng, std::vector<ImuSample>* sent) {
  Bytes stream = ReadTestdata("hipnuc_hi91_example_frame.bin");
  for (int i = 0; i < 4; ++i) {
    ImuSample s = RandomSample91(rng);
    const Bytes f = i % 2 ? EncodeHi219Packet91Frame(s) : EncodeHi219LegacyFrame(s);
    stream.insert(stream.end(), f.begin(), f.end());
    if (sent != nullptr) sent->push_back(s);
  }
  return stream;
}

TEST(Hi219RoundTripTest, EverySplitAndByteByByteGiveTheSameSamples) {
  std::mt19937 rng(3);
  const Bytes stream = MakeStream(&rng, nullptr);
  Hi219Decoder whole;
  whole.Feed(stream, kT0);
  const auto ref = whole.TakeSamples();
  ASSERT_EQ(ref.size(), 5u);
  auto check = [&](Hi219Decoder* d, const std::string& what) {
    const auto out = d->TakeSamples();
    ASSERT_EQ(out.size(), ref.size()) << what;
    for (size_t i = 0; i < out.size(); ++i) EXPECT_TRUE(SameSample(out[i], ref[i])) << what;
    EXPECT_EQ(d->stats().bytes_skipped, 0u) << what;
    EXPECT_EQ(d->BufferedBytes(), 0u) << what;
    ExpectAccounting(*d);
  };
  for (size_t split = 0; split <= stream.size(); ++split) {
    Hi219Decoder d;
    d.Feed(stream.data(), split, kT0);
    d.Feed(stream.data() + split, stream.size() - split, kT0);
    check(&d, "split " + std::to_string(split));
  }
  Hi219Decoder one;
  for (uint8_t b : stream) one.Feed(&b, 1, kT0);
  check(&one, "byte by byte");
}

TEST(Hi219RobustnessTest, GarbageAndCorruptFramesAreCountedGoodOnesKept) {
  std::mt19937 rng(4);
  std::vector<ImuSample> sent;
  std::vector<Bytes> good;
  for (int i = 0; i < 5; ++i) {
    sent.push_back(RandomSample91(&rng));
    good.push_back(EncodeHi219Packet91Frame(sent.back()));
  }
  Bytes stream;
  auto add = [&stream](const Bytes& b) { stream.insert(stream.end(), b.begin(), b.end()); };
  size_t good_bytes = 0;
  auto add_good = [&](int i) {
    add(good[i]);
    good_bytes += good[i].size();
  };
  add({0x01, 0x02, 0x5A, 0x00});  // Garbage, including a lone first sync byte.
  add_good(0);
  Bytes flipped = good[1];
  flipped[40] ^= 0x80;  // Payload byte: CRC error.
  add(flipped);
  add_good(1);
  Bytes wrong_len = good[2];
  wrong_len[2] = 0x2C;  // LEN 300 > 256: length error.
  wrong_len[3] = 0x01;
  add(Bytes(wrong_len.begin(), wrong_len.begin() + 6));
  add_good(2);
  add(Bytes(good[3].begin(), good[3].begin() + 30));      // Truncated; the next frame starts inside
  add_good(3);                                            // its announced 82-byte extent.
  Bytes zero_len = {0x5A, 0xA5, 0x00, 0x00, 0x00, 0x00};  // LEN 0: length error.
  add(zero_len);
  add_good(4);

  for (size_t chunk : {size_t{1}, size_t{5}, size_t{50}, stream.size()}) {
    Hi219Decoder d;
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), kT0);
    }
    const auto out = d.TakeSamples();
    ASSERT_EQ(out.size(), 5u) << "chunk " << chunk;
    for (size_t i = 0; i < 5; ++i) {
      ImuSample expected = sent[i];
      expected.receive_time = kT0;
      EXPECT_TRUE(SameSample(out[i], expected)) << "chunk " << chunk << " sample " << i;
    }
    const DecoderStats& s = d.stats();
    EXPECT_EQ(s.frames_ok, 5u);
    EXPECT_GE(s.checksum_errors, 2u);  // Flipped and truncated.
    EXPECT_GE(s.length_errors, 2u);
    EXPECT_EQ(s.bytes_in_frames, good_bytes);
    EXPECT_EQ(s.bytes_skipped, stream.size() - good_bytes);
    ExpectAccounting(d);
  }
}

TEST(Hi219RobustnessTest, UnknownTagIsAPayloadError) {
  // Valid CRC; items A0 (acc), then unknown tag 0x77: acc is kept, the walk stops.
  Bytes payload = {0xA0, 0xE8, 0x03, 0x00, 0x00, 0x00, 0x00, 0x77, 0x01};
  Bytes frame;
  ASSERT_TRUE(EncodeHi219Frame(payload, &frame));
  // A frame that is only an unknown tag yields no sample at all.
  ASSERT_TRUE(EncodeHi219Frame({0x77}, &frame));
  // Truncated item: a 0xD1 quaternion needs 17 bytes.
  ASSERT_TRUE(EncodeHi219Frame({0xD1, 0, 0, 0}, &frame));
  Hi219Decoder d;
  d.Feed(frame, kT0);
  const auto out = d.TakeSamples();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].fields, kImuAcc);
  EXPECT_FLOAT_EQ(out[0].acc_g[0], 1.0f);
  EXPECT_EQ(d.stats().frames_ok, 3u);
  EXPECT_EQ(d.stats().payload_errors, 3u);
  ExpectAccounting(d);
}

TEST(Hi219RobustnessTest, RandomBytesNeverCrashAndAreAccounted) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255);
  Hi219Decoder d;
  for (int i = 0; i < 200; ++i) {
    Bytes chunk(static_cast<size_t>(byte(rng)));
    for (auto& b : chunk) b = static_cast<uint8_t>(byte(rng) < 30 ? 0x5A : byte(rng));
    d.Feed(chunk, kT0);
  }
  ExpectAccounting(d);
  EXPECT_LE(d.BufferedBytes(), kHi219HeaderSize + kHi219MaxPayload);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
