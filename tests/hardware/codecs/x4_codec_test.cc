#include "hardware/codecs/x4_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

Bytes ReadTestdata(const std::string& name) {
  std::ifstream in(std::string(SWEEPSCAN_SHARED_TESTDATA) + "/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << "missing test vector " << name;
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Smallest signed difference a - b on the circle, in degrees.
double AngleDiffDeg(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d > 180) d -= 360;
  if (d < -180) d += 360;
  return d;
}

void ExpectAccounting(const X4Decoder& d) {
  const DecoderStats& s = d.stats();
  EXPECT_EQ(s.bytes_in, s.bytes_in_frames + s.bytes_skipped + d.BufferedBytes()) << s.ToString();
}

bool SameSample(const X4Sample& a, const X4Sample& b) {
  return a.angle_deg == b.angle_deg && a.distance_mm == b.distance_mm && a.raw == b.raw &&
         a.interference == b.interference && a.valid == b.valid && a.time == b.time;
}

bool SamePacket(const X4Packet& a, const X4Packet& b) {
  if (a.ct != b.ct || a.fsa != b.fsa || a.lsa != b.lsa || a.receive_time != b.receive_time ||
      a.samples.size() != b.samples.size()) {
    return false;
  }
  for (size_t i = 0; i < a.samples.size(); ++i) {
    if (!SameSample(a.samples[i], b.samples[i])) return false;
  }
  return true;
}

const Time kT0 = TimeFromSeconds(100.0);

// ---------------------------------------------------------------------------
// Commands.

TEST(X4CommandTest, PlainCommands) {
  EXPECT_EQ(EncodeX4Command(kX4CmdScan), (Bytes{0xA5, 0x60}));
  EXPECT_EQ(EncodeX4Command(kX4CmdForceScan), (Bytes{0xA5, 0x61}));
  EXPECT_EQ(EncodeX4Command(kX4CmdStop), (Bytes{0xA5, 0x65}));
  EXPECT_EQ(EncodeX4Command(kX4CmdReset), (Bytes{0xA5, 0x80}));
  EXPECT_EQ(EncodeX4Command(kX4CmdDeviceInfo), (Bytes{0xA5, 0x90}));
  EXPECT_EQ(EncodeX4Command(kX4CmdHealth), (Bytes{0xA5, 0x92}));
}

TEST(X4CommandTest, CommandWithPayloadByHand) {
  // A5 ^ 90 = 35, ^ 02 = 37, ^ 01 = 36, ^ 02 = 34.
  EXPECT_EQ(EncodeX4CommandWithPayload(0x10, {0x01, 0x02}),
            (Bytes{0xA5, 0x90, 0x02, 0x01, 0x02, 0x34}));
  // Empty payload: A5 ^ E0 ^ 00 = 45.
  EXPECT_EQ(EncodeX4CommandWithPayload(0x60, {}), (Bytes{0xA5, 0xE0, 0x00, 0x45}));
}

// ---------------------------------------------------------------------------
// Angle math.

TEST(X4AngleTest, SecondLevelCorrectionHandComputed) {
  // atan(21.8 * (155.3 - 1000) / (155.3 * 1000)) = atan(-0.1185731) = -6.762186 deg.
  EXPECT_NEAR(X4AngleCorrectionDeg(1000.0), -6.762186, 1e-6);
  // atan(21.8 * (155.3 - 100) / (155.3 * 100)) = atan(0.0776278) = 4.438771 deg.
  EXPECT_NEAR(X4AngleCorrectionDeg(100.0), 4.438771, 1e-6);
  EXPECT_DOUBLE_EQ(X4AngleCorrectionDeg(155.3), 0.0);
  EXPECT_EQ(X4AngleCorrectionDeg(0.0), 0.0);
  EXPECT_EQ(X4AngleCorrectionDeg(-5.0), 0.0);
}

TEST(X4AngleTest, FieldConversion) {
  // 0xAE53 >> 1 = 0x5729 = 22313; 22313 / 64 = 348.640625 deg.
  EXPECT_DOUBLE_EQ(X4FieldToDegrees(0xAE53), 348.640625);
  EXPECT_EQ(X4DegreesToField(348.640625), 0xAE53);
  EXPECT_EQ(X4DegreesToField(80.0), 0x2801);     // 5120 << 1 | 1.
  EXPECT_EQ(X4DegreesToField(-1.0), 0xB381);     // 359 deg: 22976 << 1 | 1.
  EXPECT_EQ(X4DegreesToField(359.999), 0x0001);  // Rounds to 360 = 0.
  EXPECT_EQ(X4DegreesToField(720.0 + 1.0 / 64), 0x0003);
  EXPECT_DOUBLE_EQ(WrapDegrees360(-30.0), 330.0);
  EXPECT_DOUBLE_EQ(WrapDegrees360(725.0), 5.0);
  EXPECT_DOUBLE_EQ(WrapDegrees360(-1e-17), 0.0);
}

// ---------------------------------------------------------------------------
// Vendor vector and hand-made packets.

TEST(X4DecoderTest, DocZeroPacketVector) {
  const Bytes vec = ReadTestdata("ydlidar_doc_zero_packet.bin");
  ASSERT_EQ(vec, (Bytes{0xAA, 0x55, 0x01, 0x01, 0x53, 0xAE, 0x53, 0xAE, 0xAB, 0x54, 0x00, 0x00}));
  X4Decoder d;
  d.Feed(vec, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  const X4Packet& p = packets[0];
  EXPECT_TRUE(p.ring_start);
  EXPECT_EQ(p.fsa, 0xAE53);
  EXPECT_EQ(p.lsa, 0xAE53);
  EXPECT_EQ(p.scan_frequency_hz, 0.0);
  ASSERT_EQ(p.samples.size(), 1u);
  EXPECT_FALSE(p.samples[0].valid);
  EXPECT_EQ(p.samples[0].distance_mm, 0.0);
  // Invalid samples get no second-level correction.
  EXPECT_DOUBLE_EQ(p.samples[0].angle_deg, 348.640625);
  EXPECT_EQ(d.stats().frames_ok, 1u);
  EXPECT_EQ(d.stats().checksum_errors, 0u);
  ExpectAccounting(d);
  // X4CheckCode: 0x55AA ^ 0xAE53 ^ 0xAE53 ^ 0x0101 ^ 0 = 0x54AB.
  EXPECT_EQ(X4CheckCode(0x01, 1, 0xAE53, 0xAE53, vec.data() + 10, 1), 0x54AB);
}

TEST(X4EncoderTest, ReproducesDocZeroPacket) {
  X4PacketToEncode e;
  e.ring_start = true;
  e.scan_frequency_hz = 0;
  e.first_angle_deg = 348.640625;
  e.last_angle_deg = 348.640625;
  e.distances_mm = {0};
  Bytes out;
  ASSERT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(out, ReadTestdata("ydlidar_doc_zero_packet.bin"));
}

// CT 00, LSN 3, FSA 0x2801 (80 deg), LSA 0x2A81 (5440 / 64 = 85 deg),
// S = 0x0FA0 (1000 mm, flags 0), 0x0000 (invalid), 0x0271 (156 mm, flags 1).
// CS = 55AA ^ 2801 ^ 2A81 ^ 0300 ^ 0FA0 ^ 0000 ^ 0271:
//   2801 ^ 2A81 = 0280; 55AA ^ 0280 = 572A; ^ 0300 = 542A; ^ 0FA0 = 5B8A; ^ 0271 = 59FB.
const Bytes kHandPacket = {0xAA, 0x55, 0x00, 0x03, 0x01, 0x28, 0x81, 0x2A,
                           0xFB, 0x59, 0xA0, 0x0F, 0x00, 0x00, 0x71, 0x02};

TEST(X4DecoderTest, HandPacketAnglesAndDistances) {
  X4Decoder d;
  d.Feed(kHandPacket, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  const auto& s = packets[0].samples;
  ASSERT_EQ(s.size(), 3u);
  EXPECT_FALSE(packets[0].ring_start);
  // i = 0: 80 + atan(21.8 * (155.3 - 1000) / (155.3 * 1000)) = 80 - 6.762186 = 73.237814.
  EXPECT_NEAR(s[0].angle_deg, 73.237814, 1e-6);
  EXPECT_EQ(s[0].distance_mm, 1000.0);
  EXPECT_EQ(s[0].interference, 0);
  EXPECT_TRUE(s[0].valid);
  // i = 1: 80 + 5 * 1 / 2 = 82.5, invalid: no correction.
  EXPECT_DOUBLE_EQ(s[1].angle_deg, 82.5);
  EXPECT_FALSE(s[1].valid);
  // i = 2: 85 + atan(21.8 * (155.3 - 156) / (155.3 * 156)) = 85 - 0.036090 = 84.963910.
  EXPECT_NEAR(s[2].angle_deg, 84.963910, 1e-6);
  EXPECT_EQ(s[2].distance_mm, 156.0);
  EXPECT_EQ(s[2].interference, 1);
  EXPECT_EQ(s[2].raw, 0x0271);
}

TEST(X4EncoderTest, HandPacketIsReproduced) {
  X4PacketToEncode e;
  e.first_angle_deg = 80.0 + X4AngleCorrectionDeg(1000);
  e.last_angle_deg = 85.0 + X4AngleCorrectionDeg(156);
  e.distances_mm = {1000, 0, 156};
  e.interference = {0, 0, 1};
  Bytes out;
  ASSERT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(out, kHandPacket);
}

TEST(X4DecoderTest, AngleWrapsAcrossZero) {
  // FSA 359 deg (0xB381), LSA 1 deg (0x0081): diff = 1 - 359 + 360 = 2, three invalid
  // samples at 359, 360 -> 0, 1.
  Bytes pkt = {0xAA, 0x55, 0x00, 0x03, 0x81, 0xB3, 0x81, 0x00, 0, 0, 0, 0, 0, 0, 0, 0};
  const uint16_t cs = X4CheckCode(0, 3, 0xB381, 0x0081, pkt.data() + 10, 3);
  pkt[8] = cs & 0xFF;
  pkt[9] = cs >> 8;
  X4Decoder d;
  d.Feed(pkt, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_DOUBLE_EQ(packets[0].samples[0].angle_deg, 359.0);
  EXPECT_DOUBLE_EQ(packets[0].samples[1].angle_deg, 0.0);
  EXPECT_DOUBLE_EQ(packets[0].samples[2].angle_deg, 1.0);
}

TEST(X4DecoderTest, RingStartCarriesScanFrequency) {
  X4PacketToEncode e;
  e.ring_start = true;
  e.scan_frequency_hz = 7.0;  // CT = 70 << 1 | 1 = 0x8D.
  e.distances_mm = {0};
  Bytes out;
  ASSERT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(out[2], 0x8D);
  X4Decoder d;
  d.Feed(out, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_TRUE(packets[0].ring_start);
  EXPECT_NEAR(packets[0].scan_frequency_hz, 7.0, 1e-12);
  // Saturation: 20 Hz does not fit 7 bits, it becomes 12.7 Hz.
  e.scan_frequency_hz = 20.0;
  out.clear();
  ASSERT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(out[2], 0xFF);
}

TEST(X4EncoderTest, RejectsEmptyAndOversizedPackets) {
  X4PacketToEncode e;
  Bytes out;
  EXPECT_FALSE(EncodeX4ScanPacket(e, &out));
  e.distances_mm.assign(256, 500.0);
  EXPECT_FALSE(EncodeX4ScanPacket(e, &out));
  EXPECT_TRUE(out.empty());
  e.distances_mm.assign(255, 500.0);
  EXPECT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(out.size(), 10u + 2 * 255);
}

TEST(X4EncoderTest, DistanceSaturatesAndRounds) {
  X4PacketToEncode e;
  e.distances_mm = {20000.0, -3.0, 999.5, 999.4};
  Bytes out;
  ASSERT_TRUE(EncodeX4ScanPacket(e, &out));
  EXPECT_EQ(ReadU16Le(out.data() + 10), 0xFFFC);  // 16383 << 2.
  EXPECT_EQ(ReadU16Le(out.data() + 12), 0x0000);
  EXPECT_EQ(ReadU16Le(out.data() + 14), 1000 << 2);
  EXPECT_EQ(ReadU16Le(out.data() + 16), 999 << 2);
}

// ---------------------------------------------------------------------------
// Responses.

TEST(X4DecoderTest, DeviceInfoHealthAndScanStart) {
  X4DeviceInfo info;
  info.model = kX4ModelCode;
  info.firmware = 0x0105;
  info.hardware = 1;
  for (int i = 0; i < 16; ++i) info.serial[i] = static_cast<uint8_t>(i % 10);
  const Bytes info_bytes = EncodeX4DeviceInfo(info);
  ASSERT_EQ(info_bytes.size(), 27u);
  EXPECT_EQ(Bytes(info_bytes.begin(), info_bytes.begin() + 10),
            (Bytes{0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x04, 0x06, 0x05, 0x01}));
  X4Health health;
  health.status = 2;
  health.error_code = 0x1234;
  EXPECT_EQ(EncodeX4Health(health),
            (Bytes{0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x06, 0x02, 0x34, 0x12}));
  EXPECT_EQ(EncodeX4ScanStartHeader(), (Bytes{0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81}));

  Bytes stream = info_bytes;
  const Bytes h = EncodeX4Health(health);
  stream.insert(stream.end(), h.begin(), h.end());
  const Bytes s = EncodeX4ScanStartHeader();
  stream.insert(stream.end(), s.begin(), s.end());
  stream.insert(stream.end(), kHandPacket.begin(), kHandPacket.end());

  X4Decoder d;
  d.Feed(stream, kT0);
  const auto infos = d.TakeDeviceInfos();
  ASSERT_EQ(infos.size(), 1u);
  EXPECT_EQ(infos[0].model, 6);
  EXPECT_EQ(infos[0].firmware, 0x0105);
  EXPECT_EQ(infos[0].hardware, 1);
  EXPECT_EQ(infos[0].serial, info.serial);
  EXPECT_EQ(infos[0].SerialString(), "0123456789012345");
  const auto healths = d.TakeHealth();
  ASSERT_EQ(healths.size(), 1u);
  EXPECT_EQ(healths[0].status, 2);
  EXPECT_EQ(healths[0].error_code, 0x1234);
  EXPECT_EQ(d.scan_start_headers(), 1u);
  EXPECT_EQ(d.TakePackets().size(), 1u);
  EXPECT_EQ(d.stats().frames_ok, 4u);
  EXPECT_EQ(d.stats().bytes_skipped, 0u);
  ExpectAccounting(d);
}

TEST(X4DecoderTest, UnknownResponseHeaderIsAFramingError) {
  // Type 0x07 is not one the X4 sends; size 20 with type 0x06 is not a health reply either.
  Bytes stream = {0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, 0x07,
                  0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, 0x06};
  stream.insert(stream.end(), kHandPacket.begin(), kHandPacket.end());
  X4Decoder d;
  d.Feed(stream, kT0);
  EXPECT_EQ(d.stats().framing_errors, 2u);
  EXPECT_EQ(d.TakePackets().size(), 1u);
  EXPECT_EQ(d.stats().bytes_skipped, 14u);
  ExpectAccounting(d);
}

// ---------------------------------------------------------------------------
// Stream helpers.

struct Revolution {
  double frequency_hz;
  std::vector<X4PacketToEncode> packets;
};

// A realistic stream: scan-start header, then revolutions of a ring-start
// packet (1 invalid sample) and 40-sample packets with random distances.
Bytes MakeScanStream(int revolutions, int packets_per_rev, std::mt19937* rng) {
  std::uniform_real_distribution<double> dist_mm(0, 9000);
  std::bernoulli_distribution invalid(0.2);
  Bytes out = EncodeX4ScanStartHeader();
  const double step = 360.0 / (packets_per_rev * 40);
  for (int r = 0; r < revolutions; ++r) {
    X4PacketToEncode ring;
    ring.ring_start = true;
    ring.scan_frequency_hz = 6.0 + 0.1 * r;
    ring.distances_mm = {0};
    ring.first_angle_deg = ring.last_angle_deg = 359.5;
    EncodeX4ScanPacket(ring, &out);
    for (int k = 0; k < packets_per_rev; ++k) {
      X4PacketToEncode p;
      for (int i = 0; i < 40; ++i) p.distances_mm.push_back(invalid(*rng) ? 0 : dist_mm(*rng));
      // Invalid end samples get no correction, valid ones are inverted by the encoder.
      p.first_angle_deg = k * 40 * step;
      p.last_angle_deg = (k * 40 + 39) * step;
      EncodeX4ScanPacket(p, &out);
    }
  }
  return out;
}

// ---------------------------------------------------------------------------
// Round trip and splits.

TEST(X4RoundTripTest, RandomPacketsDecodeToRequestedValues) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> angle(-720, 720);
  std::uniform_real_distribution<double> span(0.1, 30);
  std::uniform_real_distribution<double> dist_mm(1, 16000);
  std::uniform_int_distribution<int> lsn(1, 128);
  std::uniform_int_distribution<int> flags(0, 3);
  std::bernoulli_distribution invalid(0.25);
  for (int trial = 0; trial < 500; ++trial) {
    X4PacketToEncode e;
    const int n = lsn(rng);
    for (int i = 0; i < n; ++i) {
      e.distances_mm.push_back(invalid(rng) ? 0.0 : dist_mm(rng));
      e.interference.push_back(static_cast<uint8_t>(flags(rng)));
    }
    e.first_angle_deg = angle(rng);
    e.last_angle_deg = n == 1 ? e.first_angle_deg : e.first_angle_deg + span(rng);
    Bytes bytes;
    ASSERT_TRUE(EncodeX4ScanPacket(e, &bytes));
    X4Decoder d;
    d.Feed(bytes, kT0);
    const auto packets = d.TakePackets();
    ASSERT_EQ(packets.size(), 1u) << "trial " << trial;
    const auto& s = packets[0].samples;
    ASSERT_EQ(s.size(), static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(s[i].distance_mm, std::round(e.distances_mm[i]));
      EXPECT_EQ(s[i].interference, e.interference[i]);
      EXPECT_GE(s[i].angle_deg, 0.0);
      EXPECT_LT(s[i].angle_deg, 360.0);
    }
    // FSA / LSA are rounded to 1/64 deg: the end samples are off by at most 1/128 deg.
    const double tol = 1.0 / 128 + 1e-9;
    EXPECT_LE(std::abs(AngleDiffDeg(s.front().angle_deg, e.first_angle_deg)), tol);
    EXPECT_LE(std::abs(AngleDiffDeg(s.back().angle_deg, e.last_angle_deg)), tol);
  }
}

TEST(X4RoundTripTest, EverySplitAndByteByByteGiveTheSameRecords) {
  std::mt19937 rng(7);
  Bytes stream = EncodeX4DeviceInfo(X4DeviceInfo{kX4ModelCode, 0x0102, 3, {}, {}});
  const Bytes h = EncodeX4Health(X4Health{0, 0, {}});
  stream.insert(stream.end(), h.begin(), h.end());
  const Bytes scans = MakeScanStream(2, 3, &rng);
  stream.insert(stream.end(), scans.begin(), scans.end());

  X4Decoder whole;
  whole.Feed(stream, kT0);
  const auto ref_packets = whole.TakePackets();
  const auto ref_scans = whole.TakeScans();
  ASSERT_EQ(ref_packets.size(), 8u);
  ASSERT_EQ(ref_scans.size(), 1u);
  ASSERT_EQ(whole.TakeDeviceInfos().size(), 1u);
  ASSERT_EQ(whole.TakeHealth().size(), 1u);

  auto check = [&](X4Decoder* d, const std::string& what) {
    const auto packets = d->TakePackets();
    ASSERT_EQ(packets.size(), ref_packets.size()) << what;
    for (size_t i = 0; i < packets.size(); ++i) {
      EXPECT_TRUE(SamePacket(packets[i], ref_packets[i])) << what << " packet " << i;
    }
    const auto scans_out = d->TakeScans();
    ASSERT_EQ(scans_out.size(), 1u) << what;
    EXPECT_EQ(scans_out[0].samples.size(), ref_scans[0].samples.size()) << what;
    EXPECT_EQ(d->TakeDeviceInfos().size(), 1u) << what;
    EXPECT_EQ(d->TakeHealth().size(), 1u) << what;
    EXPECT_EQ(d->stats().bytes_skipped, 0u) << what;
    EXPECT_EQ(d->stats().frames_ok, whole.stats().frames_ok) << what;
    ExpectAccounting(*d);
  };
  for (size_t split = 0; split <= stream.size(); ++split) {
    X4Decoder d;
    d.Feed(stream.data(), split, kT0);
    d.Feed(stream.data() + split, stream.size() - split, kT0);
    check(&d, "split " + std::to_string(split));
  }
  X4Decoder one;
  for (uint8_t b : stream) one.Feed(&b, 1, kT0);
  check(&one, "byte by byte");
}

// ---------------------------------------------------------------------------
// Revolutions and time stamps.

TEST(X4ScanTest, RevolutionsBetweenRingStarts) {
  std::mt19937 rng(3);
  Bytes stream = MakeScanStream(4, 5, &rng);
  X4Decoder d;
  d.Feed(stream, kT0);
  // Four ring starts close three revolutions; the fourth is still open.
  const auto scans = d.TakeScans();
  ASSERT_EQ(scans.size(), 3u);
  for (size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(scans[i].index, i);
    EXPECT_EQ(scans[i].samples.size(), 1u + 5 * 40);
    EXPECT_EQ(scans[i].packet_count, 6u);
    EXPECT_NEAR(scans[i].scan_frequency_hz, 6.0 + 0.1 * i, 1e-9);
    EXPECT_FALSE(scans[i].had_errors);
    EXPECT_EQ(scans[i].start_time, scans[i].samples.front().time);
    EXPECT_EQ(scans[i].end_time, scans[i].samples.back().time);
  }
  EXPECT_EQ(d.scans_completed(), 3u);
  EXPECT_EQ(d.samples_before_first_ring(), 0u);
}

TEST(X4ScanTest, PacketsBeforeTheFirstRingStartAreNotAScan) {
  X4Decoder d;
  d.Feed(kHandPacket, kT0);
  d.Feed(ReadTestdata("ydlidar_doc_zero_packet.bin"), kT0);
  d.Feed(kHandPacket, kT0);
  EXPECT_TRUE(d.TakeScans().empty());
  EXPECT_EQ(d.samples_before_first_ring(), 3u);
  d.Feed(ReadTestdata("ydlidar_doc_zero_packet.bin"), kT0);
  const auto scans = d.TakeScans();
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].samples.size(), 4u);  // 1 ring-start sample + 3.
}

TEST(X4ScanTest, LostPacketMarksTheRevolution) {
  std::mt19937 rng(5);
  Bytes stream = MakeScanStream(3, 4, &rng);
  // Corrupt one sample byte of the second packet of revolution 1 (index 1).
  // Layout: header 7, ring 12, 4 x 90, ring 12, packet 90, packet 90 ...
  const size_t offset = 7 + (12 + 4 * 90) + 12 + 90 + 20;
  stream[offset] ^= 0x40;
  X4Decoder d;
  d.Feed(stream, kT0);
  const auto scans = d.TakeScans();
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_FALSE(scans[0].had_errors);
  EXPECT_TRUE(scans[1].had_errors);
  EXPECT_EQ(scans[1].samples.size(), 1u + 3 * 40);
  EXPECT_EQ(d.stats().checksum_errors, 1u);

  X4DecoderOptions drop;
  drop.drop_scans_with_errors = true;
  X4Decoder d2(drop);
  d2.Feed(stream, kT0);
  const auto kept = d2.TakeScans();
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].index, 0u);
  EXPECT_EQ(d2.scans_completed(), 2u);
}

TEST(X4TimeTest, SampleTimesFollowTheDocumentedRule) {
  X4DecoderOptions o;
  o.sample_rate_hz = 5000;
  o.latency = std::chrono::milliseconds(2);
  o.baud_rate = 128000;
  X4Decoder d(o);
  d.Feed(kHandPacket, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  const auto& s = packets[0].samples;
  // t_last = 100 s - 2 ms - 16 bytes * 10 bits / 128000 baud (1.25 ms) = 99.99675 s.
  EXPECT_EQ(ToNanoseconds(s[2].time), 99'996'750'000);
  EXPECT_EQ(ToNanoseconds(s[1].time), 99'996'550'000);  // - 200 us.
  EXPECT_EQ(ToNanoseconds(s[0].time), 99'996'350'000);
  EXPECT_EQ(packets[0].receive_time, kT0);

  X4DecoderOptions no_tx;
  no_tx.baud_rate = 0;
  X4Decoder d2(no_tx);
  d2.Feed(kHandPacket, kT0);
  EXPECT_EQ(d2.TakePackets()[0].samples[2].time, kT0);
}

// The busy-line rule (X4DecoderOptions, docs/device-codecs.md) on hand-checked
// values: 5 kHz, 128000 baud (78.125 us a byte), no latency. A 40-sample
// packet is 90 bytes (7.03125 ms on the line), a 1-sample ring-start packet
// 12 bytes (0.9375 ms).
TEST(X4TimeTest, PacketQueuedBehindThePreviousOneTakesItsTimeFromTheSampleClock) {
  X4DecoderOptions o;
  o.sample_rate_hz = 5000;
  o.baud_rate = 128000;
  auto packet = [](bool ring_start, size_t n) {
    X4PacketToEncode p;
    p.ring_start = ring_start;
    p.distances_mm.assign(n, 1000.0);
    p.first_angle_deg = 10.0;
    p.last_angle_deg = 10.0 + 0.5 * static_cast<double>(n - 1);
    Bytes out;
    EXPECT_TRUE(EncodeX4ScanPacket(p, &out));
    return out;
  };
  const Bytes a = packet(false, 40), ring = packet(true, 1), c = packet(false, 40);
  ASSERT_EQ(a.size(), 90u);
  ASSERT_EQ(ring.size(), 12u);
  // A received at 100 s: idle line, t_A = 100 s - 7.03125 ms = 99.99296875 s.
  // The ring-start packet right behind it, at 100.0009375 s: its
  // transmission began at 100 s = e_A (queued), so its sample is the one
  // after A's last: t = t_A + 200 us = 99.99316875 s (the transmission rule
  // alone would give 100 s, 6.83 ms late).
  // C, 40 samples later on the sample clock and sent at once:
  // R_C = t_ring + 8 ms + 7.03125 ms = 100.0082 s; idle (b_C = 100.00116875 s
  // > e_ring = 100.0009375 s), t_C = b_C = t_ring + 8 ms.
  X4Decoder d(o);
  d.Feed(a, kT0);
  d.Feed(ring, kT0 + Duration(937'500));
  d.Feed(c, kT0 + Duration(8'200'000));
  auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 3u);
  EXPECT_EQ(ToNanoseconds(packets[0].samples.back().time), 99'992'968'750);
  EXPECT_EQ(ToNanoseconds(packets[0].samples.front().time), 99'985'168'750);  // - 39 x 200 us.
  EXPECT_EQ(ToNanoseconds(packets[1].samples[0].time), 99'993'168'750);
  EXPECT_EQ(ToNanoseconds(packets[2].samples.back().time), 100'001'168'750);
  EXPECT_EQ(ToNanoseconds(packets[2].samples.front().time), 99'993'368'750);  // ring + 200 us.

  // A receive time that comes too early for the line (here all three in one
  // chunk at 100 s): each packet ends no earlier than the previous one plus
  // its own transmission, e = 100 s, 100.0009375 s, 100.00796875 s; the
  // later two are queued, so the sample clock times them: t_ring = t_A +
  // 200 us as above, t_C = min(b_C = 100.0009375 s, t_ring + 8 ms) =
  // 100.0009375 s (the line bound is the tighter one).
  Bytes all = a;
  all.insert(all.end(), ring.begin(), ring.end());
  all.insert(all.end(), c.begin(), c.end());
  X4Decoder one_chunk(o);
  one_chunk.Feed(all, kT0);
  packets = one_chunk.TakePackets();
  ASSERT_EQ(packets.size(), 3u);
  EXPECT_EQ(ToNanoseconds(packets[0].samples.back().time), 99'992'968'750);
  EXPECT_EQ(ToNanoseconds(packets[1].samples[0].time), 99'993'168'750);
  EXPECT_EQ(ToNanoseconds(packets[2].samples.back().time), 100'000'937'500);

  // A garbage byte between A and the ring-start packet: the stream is not
  // known to be contiguous, so the ring-start packet gets the transmission
  // rule alone: 100.0009375 s - 0.9375 ms = 100 s.
  X4Decoder broken(o);
  broken.Feed(a, kT0);
  broken.Feed(Bytes{0x00}, kT0 + Duration(100'000));
  broken.Feed(ring, kT0 + Duration(937'500));
  packets = broken.TakePackets();
  ASSERT_EQ(packets.size(), 2u);
  EXPECT_EQ(ToNanoseconds(packets[1].samples[0].time), 100'000'000'000);
}

TEST(X4TimeTest, PacketGetsTheTimeOfTheChunkWithItsLastByte) {
  X4DecoderOptions o;
  o.baud_rate = 0;
  X4Decoder d(o);
  const Time t1 = kT0 + std::chrono::milliseconds(5);
  d.Feed(kHandPacket.data(), kHandPacket.size() - 1, kT0);
  EXPECT_TRUE(d.TakePackets().empty());
  d.Feed(kHandPacket.data() + kHandPacket.size() - 1, 1, t1);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(packets[0].receive_time, t1);
  EXPECT_EQ(packets[0].samples.back().time, t1);
}

// ---------------------------------------------------------------------------
// Garbage and corruption.

TEST(X4RobustnessTest, GarbageAndCorruptPacketsAreCountedGoodOnesKept) {
  std::mt19937 rng(11);
  const Bytes clean = MakeScanStream(2, 3, &rng);  // Header + 8 packets.
  // Every chunk comes at kT0, and the busy-line rule times a packet after
  // an error differently from one that follows its predecessor
  // (X4TimeTest.PacketQueuedBehind...): compare without the line model, so
  // that each packet's time is its receive time.
  X4DecoderOptions no_line;
  no_line.baud_rate = 0;
  X4Decoder ref(no_line);
  ref.Feed(clean, kT0);
  const auto ref_packets = ref.TakePackets();
  ASSERT_EQ(ref_packets.size(), 8u);

  // Split the clean stream back into its frames.
  std::vector<Bytes> frames;
  frames.emplace_back(clean.begin(), clean.begin() + 7);
  for (size_t pos = 7; pos < clean.size();) {
    const size_t len = 10 + 2 * clean[pos + 3];
    frames.emplace_back(clean.begin() + pos, clean.begin() + pos + len);
    pos += len;
  }
  ASSERT_EQ(frames.size(), 9u);
  const Bytes good40 = frames[2];  // A 40-sample packet.

  Bytes stream;
  auto add = [&stream](const Bytes& b) { stream.insert(stream.end(), b.begin(), b.end()); };
  add({0x00, 0x13, 0x37});  // Garbage before anything: 3 skipped bytes.
  add(frames[0]);
  add(frames[1]);
  Bytes flipped = good40;
  flipped[30] ^= 0x01;  // Bad check code.
  add(flipped);
  add(frames[2]);
  Bytes bad_lsn = good40;
  bad_lsn[3] = 0;  // LSN 0: length error.
  add(Bytes(bad_lsn.begin(), bad_lsn.begin() + 10));
  add(frames[3]);
  Bytes big_lsn = good40;
  big_lsn[3] = 200;  // Above max_samples_per_packet: length error.
  add(Bytes(big_lsn.begin(), big_lsn.begin() + 10));
  add(frames[4]);
  add(Bytes(good40.begin(), good40.begin() + 50));  // Truncated packet...
  add(frames[5]);                                   // ...a good one starts inside its extent.
  add({0xAA, 0x11, 0xA5, 0x00});                    // Sync bytes without their partner.
  add(frames[6]);
  add(frames[7]);
  add(frames[8]);

  for (size_t chunk : {size_t{1}, size_t{7}, size_t{64}, stream.size()}) {
    X4Decoder d(no_line);
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), kT0);
    }
    const auto packets = d.TakePackets();
    ASSERT_EQ(packets.size(), ref_packets.size()) << "chunk " << chunk;
    for (size_t i = 0; i < packets.size(); ++i) {
      EXPECT_TRUE(SamePacket(packets[i], ref_packets[i])) << "chunk " << chunk << " packet " << i;
    }
    const DecoderStats& s = d.stats();
    EXPECT_EQ(s.frames_ok, 9u);
    EXPECT_GE(s.checksum_errors, 2u);  // The flipped and the truncated packet.
    EXPECT_EQ(s.length_errors, 2u);
    EXPECT_EQ(s.bytes_in_frames, clean.size());
    EXPECT_EQ(s.bytes_skipped, stream.size() - clean.size());
    EXPECT_EQ(d.BufferedBytes(), 0u);
    ExpectAccounting(d);
  }
}

TEST(X4RobustnessTest, BadCandidateDoesNotSwallowAGoodPacketInsideIt) {
  // A fake header announcing 40 samples, immediately followed by a good packet
  // that lies entirely inside the fake one's 90-byte extent.
  Bytes stream = {0xAA, 0x55, 0x00, 40, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00};
  stream.insert(stream.end(), kHandPacket.begin(), kHandPacket.end());
  stream.resize(stream.size() + 100, 0x00);  // Enough bytes to complete the fake.
  X4Decoder d;
  d.Feed(stream, kT0);
  const auto packets = d.TakePackets();
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(packets[0].fsa, 0x2801);
  EXPECT_EQ(d.stats().checksum_errors, 1u);
  ExpectAccounting(d);
}

TEST(X4RobustnessTest, RandomBytesNeverCrashAndAreAccounted) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  X4Decoder d;
  for (int i = 0; i < 200; ++i) {
    Bytes chunk(static_cast<size_t>(byte(rng)));
    for (auto& b : chunk) b = static_cast<uint8_t>(byte(rng) < 40 ? 0xAA : byte(rng));
    d.Feed(chunk, kT0);
  }
  d.Feed(nullptr, 5, kT0);
  ExpectAccounting(d);
  EXPECT_LE(d.BufferedBytes(), 10u + 2 * 128);
}

TEST(X4OptionsTest, Validation) {
  X4DecoderOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.sample_rate_hz = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_FALSE(error.empty());
  o = X4DecoderOptions();
  o.max_samples_per_packet = 300;
  EXPECT_FALSE(o.IsValid(&error));
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
