#include "hardware/codecs/motor_board_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

const Time kT0 = TimeFromSeconds(7.0);

template <typename Decoder>
void ExpectAccounting(const Decoder& d) {
  const DecoderStats& s = d.stats();
  EXPECT_EQ(s.bytes_in, s.bytes_in_frames + s.bytes_skipped + d.BufferedBytes()) << s.ToString();
}

bool SameCommand(const MotorCommand& a, const MotorCommand& b) {
  return a.flag == b.flag && a.vx_mps == b.vx_mps && a.vy_mps == b.vy_mps &&
         a.wz_radps == b.wz_radps && a.receive_time == b.receive_time;
}

bool SameFeedback(const MotorFeedback& a, const MotorFeedback& b) {
  return a.stop_flag == b.stop_flag && a.vx_mps == b.vx_mps && a.vy_mps == b.vy_mps &&
         a.wz_radps == b.wz_radps && a.acc_mps2 == b.acc_mps2 && a.gyro_radps == b.gyro_radps &&
         a.voltage_v == b.voltage_v && a.receive_time == b.receive_time;
}

// vx 0.5 m/s -> 500 = 01F4, vy 0, wz -1 rad/s -> -1000 = FC18.
// XOR: 7B ^ 00 ^ 00 ^ 01 ^ F4 ^ 00 ^ 00 ^ FC ^ 18: 7B^01 = 7A, ^F4 = 8E, ^FC = 72, ^18 = 6A.
const Bytes kHandCommand = {0x7B, 0x00, 0x00, 0x01, 0xF4, 0x00, 0x00, 0xFC, 0x18, 0x6A, 0x7D};

// stop 0, vx 0.2 m/s -> 00C8, vy 0, wz 0.1 rad/s -> 0064, acc z 9.81 m/s^2 * 1671.84 =
// 16400.75 -> 16401 = 4011, gyro z 0.01 rad/s / 0.00026644 = 37.53 -> 38 = 0026,
// 12.3 V -> 12300 mV = 300C. XOR of bytes 0..21 = 9C.
const Bytes kHandFeedback = {0x7B, 0x00, 0x00, 0xC8, 0x00, 0x00, 0x00, 0x64,
                             0x00, 0x00, 0x00, 0x00, 0x40, 0x11, 0x00, 0x00,
                             0x00, 0x00, 0x00, 0x26, 0x30, 0x0C, 0x9C, 0x7D};

TEST(MotorCommandTest, HandEncoding) {
  MotorCommand c;
  c.vx_mps = 0.5;
  c.wz_radps = -1.0;
  EXPECT_EQ(EncodeMotorCommand(c), kHandCommand);
  MotorCommandDecoder d;
  d.Feed(kHandCommand, kT0);
  const auto out = d.TakeRecords();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].vx_mps, 0.5);
  EXPECT_DOUBLE_EQ(out[0].vy_mps, 0.0);
  EXPECT_DOUBLE_EQ(out[0].wz_radps, -1.0);
  EXPECT_EQ(out[0].receive_time, kT0);
  ExpectAccounting(d);
}

TEST(MotorCommandTest, SaturatesInsteadOfWrapping) {
  MotorCommand c;
  c.vx_mps = 100.0;   // 100000 mm/s -> 32767 = 7FFF.
  c.vy_mps = -100.0;  // -> -32768 = 8000.
  c.wz_radps = NAN;   // -> 0.
  const Bytes b = EncodeMotorCommand(c);
  EXPECT_EQ(b[3], 0x7F);
  EXPECT_EQ(b[4], 0xFF);
  EXPECT_EQ(b[5], 0x80);
  EXPECT_EQ(b[6], 0x00);
  EXPECT_EQ(b[7], 0x00);
  EXPECT_EQ(b[8], 0x00);
  c = MotorCommand();
  c.vx_mps = 0.0004;     // Rounds to 0 mm/s.
  c.wz_radps = -0.0005;  // Half away from zero: -1.
  const Bytes r = EncodeMotorCommand(c);
  EXPECT_EQ(ReadI16Be(r.data() + 3), 0);
  EXPECT_EQ(ReadI16Be(r.data() + 7), -1);
}

TEST(MotorFeedbackTest, HandEncoding) {
  MotorFeedback f;
  f.vx_mps = 0.2;
  f.wz_radps = 0.1;
  f.acc_mps2 = {0, 0, 9.81};
  f.gyro_radps = {0, 0, 0.01};
  f.voltage_v = 12.3;
  EXPECT_EQ(EncodeMotorFeedback(f), kHandFeedback);
  MotorFeedbackDecoder d;
  d.Feed(kHandFeedback, kT0);
  const auto out = d.TakeRecords();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].vx_mps, 0.2);
  EXPECT_DOUBLE_EQ(out[0].wz_radps, 0.1);
  EXPECT_DOUBLE_EQ(out[0].acc_mps2[2], 16401 / 1671.84);
  EXPECT_DOUBLE_EQ(out[0].gyro_radps[2], 38 * 0.00026644);
  EXPECT_DOUBLE_EQ(out[0].voltage_v, 12.3);
}

TEST(MotorFeedbackTest, VoltageSaturates) {
  MotorFeedback f;
  f.voltage_v = 70.0;
  Bytes b = EncodeMotorFeedback(f);
  EXPECT_EQ(ReadU16Be(b.data() + 20), 65535);
  f.voltage_v = -1.0;
  b = EncodeMotorFeedback(f);
  EXPECT_EQ(ReadU16Be(b.data() + 20), 0);
}

TEST(MotorRoundTripTest, RandomFramesReEncodeExactly) {
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> i16(-32768, 32767);
  std::uniform_int_distribution<int> u8(0, 255);
  for (int trial = 0; trial < 1000; ++trial) {
    // Build from raw integers so every wire value, including the extremes, is covered.
    MotorCommand c;
    c.flag = static_cast<uint8_t>(u8(rng));
    c.vx_mps = i16(rng) / 1000.0;
    c.vy_mps = i16(rng) / 1000.0;
    c.wz_radps = i16(rng) / 1000.0;
    const Bytes cb = EncodeMotorCommand(c);
    ASSERT_EQ(cb.size(), kMotorCommandSize);
    MotorCommandDecoder cd;
    cd.Feed(cb, kT0);
    auto cs = cd.TakeRecords();
    ASSERT_EQ(cs.size(), 1u);
    c.receive_time = kT0;
    EXPECT_TRUE(SameCommand(cs[0], c));
    EXPECT_EQ(EncodeMotorCommand(cs[0]), cb);

    MotorFeedback f;
    f.stop_flag = static_cast<uint8_t>(u8(rng));
    f.vx_mps = i16(rng) / 1000.0;
    f.vy_mps = i16(rng) / 1000.0;
    f.wz_radps = i16(rng) / 1000.0;
    for (int i = 0; i < 3; ++i) {
      f.acc_mps2[i] = i16(rng) / kMotorAccRawPerMps2;
      f.gyro_radps[i] = i16(rng) * kMotorGyroRadpsPerRaw;
    }
    f.voltage_v = (i16(rng) + 32768) / 1000.0;
    const Bytes fb = EncodeMotorFeedback(f);
    ASSERT_EQ(fb.size(), kMotorFeedbackSize);
    MotorFeedbackDecoder fd;
    fd.Feed(fb, kT0);
    auto fs = fd.TakeRecords();
    ASSERT_EQ(fs.size(), 1u);
    f.receive_time = kT0;
    EXPECT_TRUE(SameFeedback(fs[0], f)) << "trial " << trial;
    EXPECT_EQ(EncodeMotorFeedback(fs[0]), fb);
  }
}

TEST(MotorRoundTripTest, EverySplitAndByteByByte) {
  std::mt19937 rng(22);
  std::uniform_real_distribution<double> v(-2, 2);
  Bytes cmd_stream, fb_stream;
  for (int i = 0; i < 6; ++i) {
    MotorCommand c;
    c.vx_mps = v(rng);
    c.wz_radps = v(rng);
    const Bytes cb = EncodeMotorCommand(c);
    cmd_stream.insert(cmd_stream.end(), cb.begin(), cb.end());
    MotorFeedback f;
    f.vx_mps = v(rng);
    f.acc_mps2 = {v(rng), v(rng), 9.8 + v(rng)};
    f.voltage_v = 12 + v(rng);
    const Bytes fb = EncodeMotorFeedback(f);
    fb_stream.insert(fb_stream.end(), fb.begin(), fb.end());
  }
  MotorCommandDecoder cref;
  cref.Feed(cmd_stream, kT0);
  const auto cmds = cref.TakeRecords();
  MotorFeedbackDecoder fref;
  fref.Feed(fb_stream, kT0);
  const auto fbs = fref.TakeRecords();
  ASSERT_EQ(cmds.size(), 6u);
  ASSERT_EQ(fbs.size(), 6u);

  for (size_t split = 0; split <= cmd_stream.size(); ++split) {
    MotorCommandDecoder d;
    d.Feed(cmd_stream.data(), split, kT0);
    d.Feed(cmd_stream.data() + split, cmd_stream.size() - split, kT0);
    const auto out = d.TakeRecords();
    ASSERT_EQ(out.size(), cmds.size()) << split;
    for (size_t i = 0; i < out.size(); ++i) EXPECT_TRUE(SameCommand(out[i], cmds[i]));
    EXPECT_EQ(d.stats().bytes_skipped, 0u);
  }
  for (size_t split = 0; split <= fb_stream.size(); ++split) {
    MotorFeedbackDecoder d;
    d.Feed(fb_stream.data(), split, kT0);
    d.Feed(fb_stream.data() + split, fb_stream.size() - split, kT0);
    const auto out = d.TakeRecords();
    ASSERT_EQ(out.size(), fbs.size()) << split;
    for (size_t i = 0; i < out.size(); ++i) EXPECT_TRUE(SameFeedback(out[i], fbs[i]));
    EXPECT_EQ(d.stats().bytes_skipped, 0u);
  }
  MotorFeedbackDecoder one;
  for (uint8_t b : fb_stream) one.Feed(&b, 1, kT0);
  const auto out = one.TakeRecords();
  ASSERT_EQ(out.size(), fbs.size());
  for (size_t i = 0; i < out.size(); ++i) EXPECT_TRUE(SameFeedback(out[i], fbs[i]));
  ExpectAccounting(one);
}

TEST(MotorRobustnessTest, GarbageAndCorruptFramesAreCountedGoodOnesKept) {
  Bytes stream;
  auto add = [&stream](const Bytes& b) { stream.insert(stream.end(), b.begin(), b.end()); };
  add({0x00, 0x7D, 0x11});  // Garbage: 3 bytes.
  add(kHandFeedback);
  Bytes flipped = kHandFeedback;
  flipped[9] ^= 0x04;  // XOR no longer matches: checksum error.
  add(flipped);
  add(kHandFeedback);
  Bytes bad_tail = kHandFeedback;
  bad_tail[23] = 0x7C;  // Framing error.
  add(bad_tail);
  add(kHandFeedback);
  add(Bytes(kHandFeedback.begin(), kHandFeedback.begin() + 10));  // Truncated; the next frame
  add(kHandFeedback);                                             // starts inside its extent.
  add(kHandCommand);  // A command frame in the feedback stream is garbage here.
  add(kHandFeedback);

  for (size_t chunk : {size_t{1}, size_t{3}, size_t{25}, stream.size()}) {
    MotorFeedbackDecoder d;
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), kT0);
    }
    const auto out = d.TakeRecords();
    ASSERT_EQ(out.size(), 5u) << "chunk " << chunk;
    for (const auto& f : out) EXPECT_DOUBLE_EQ(f.voltage_v, 12.3);
    const DecoderStats& s = d.stats();
    EXPECT_EQ(s.frames_ok, 5u);
    EXPECT_EQ(s.checksum_errors, 1u);
    // Bad tail, truncated frame (its byte 23 is not 7D) and the command (wrong length).
    EXPECT_EQ(s.framing_errors, 3u);
    EXPECT_EQ(s.bytes_in_frames, 5 * kMotorFeedbackSize);
    EXPECT_EQ(s.bytes_skipped, stream.size() - 5 * kMotorFeedbackSize);
    EXPECT_EQ(d.BufferedBytes(), 0u);
    ExpectAccounting(d);
  }
}

TEST(MotorRobustnessTest, CommandDecoderResyncs) {
  Bytes stream = {0x7B, 0x7B};  // Two false starts.
  stream.insert(stream.end(), kHandCommand.begin(), kHandCommand.end());
  Bytes bad = kHandCommand;
  bad[4] ^= 0xFF;
  stream.insert(stream.end(), bad.begin(), bad.end());
  stream.insert(stream.end(), kHandCommand.begin(), kHandCommand.end());
  MotorCommandDecoder d;
  d.Feed(stream, kT0);
  EXPECT_EQ(d.TakeRecords().size(), 2u);
  EXPECT_EQ(d.stats().checksum_errors, 1u);
  EXPECT_EQ(d.stats().bytes_skipped, 2u + kMotorCommandSize);
  ExpectAccounting(d);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
