// A pairs file names the same physical samples after one X4 packet of the
// session is lost (issue 14): a simulated session through the real bytes,
// picks made on it and written as a pairs file, then the same session with
// one 40-sample packet dropped from its recorded bytes; each pick must
// resolve to the same measurement (range, angle, time) and the same world
// point on both. Version-1 picks by (scan, beam) still load, resolve as
// before where nothing was lost, and are refused with a clear message where
// the loss renumbered their revolution.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <variant>
#include <vector>

#include "core/calibration/picks.h"
#include "core/calibration/samples.h"
#include "core/session/session.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/emulation/simulate_session.h"
#include "hardware/link/link_protocol.h"
#include "hardware/link/telemetry_decoder.h"
#include "tests/testing/worlds.h"
#include "tests/testing/run_command.h"

namespace sweepscan::hardware {
namespace {

SensorLog Decode(const std::vector<SessionRecord>& records, const SessionMeta& meta) {
  TelemetryDecoderOptions o;
  o.wheel_distance_m = meta.geometry.wheel_distance_m;
  o.lidar_angle_convention = meta.lidar_angle_convention;
  EXPECT_TRUE(SerialSettingsFromMeta(meta, "meta.json", &o).ok());
  SensorLog log;
  SessionDecodeInfo info;
  EXPECT_TRUE(DecodeSessionRecords(records, o, &log, &info));
  return log;
}

// The number of samples of the one X4 scan packet a record carries (0 for a
// ring-start packet), or -1 if it carries something else.
int PacketSamples(const SessionRecord& r, Time* receive_time) {
  LinkMessage m;
  if (!ParseLinkFrame(r.bytes.data(), r.bytes.size(), &m).ok()) return -1;
  const auto* t = std::get_if<Telemetry>(&m.payload);
  if (t == nullptr || t->device != static_cast<uint8_t>(LinkDevice::kLidar)) return -1;
  const std::vector<uint8_t>& b = t->bytes;
  if (b.size() < kX4PacketHeaderSize || b[0] != kX4PacketSync1 || b[1] != kX4PacketSync2 ||
      b.size() != kX4PacketHeaderSize + 2u * b[3]) {
    return -1;
  }
  *receive_time = t->receive_time;
  return (b[2] & 0x01) != 0 ? 0 : b[3];
}

const LidarScan* ScanWithIndex(const SensorLog& log, uint32_t index) {
  for (const LidarScan& s : log.scans) {
    if (s.index == index) return &s;
  }
  return nullptr;
}

TEST(StablePicksTest, PairsFileNamesTheSameSamplesAfterOneLostPacket) {
  sim::SimConfig config = testing::LabConfig(3);
  config.path = {{0.2, 0.0, 4.0}, {0.0, 0.3, 4.0}};
  const std::string dir = ::testing::TempDir() + "/sweepscan_stable_picks.sweepscan";
  sweepscan::testing::ShellOrFail("rm -rf '" + dir + "'");
  SimulateSessionReport report;
  const Status simulated = SimulateSession(config, dir, SimulateSessionOptions(), &report);
  ASSERT_TRUE(simulated.ok()) << simulated.message();
  Session session;
  const Status loaded = LoadSession(dir, FramesLoadOptions(), &session);
  ASSERT_TRUE(loaded.ok()) << loaded.message();

  sim::SimWorld world(config);
  world.RunAll();
  const PoseBuffer poses = world.TruthPoses(1000.0);
  const SensorLog log_a = Decode(session.records, session.meta);
  const SampleStore store_a(log_a, poses);
  ASSERT_GT(log_a.scans.size(), 40u);

  // Pass windows: the first and the second half of the drive.
  const auto& all = store_a.observations();
  ASSERT_FALSE(all.empty());
  const int64_t mid = (all.front().time_ns + all.back().time_ns) / 2;
  const std::vector<PassWindow> windows = {{all.front().time_ns, mid - 1, 0},
                                           {mid, all.back().time_ns, 0}};
  // Picks: four samples from beam 300 on of a revolution in each half
  // (beams 0..~714; a revolution's last packets shrink towards the ring
  // start, so the middle stays clear of them).
  const uint32_t scan1 = log_a.scans[log_a.scans.size() / 4].index;
  const uint32_t scan2 = log_a.scans[3 * log_a.scans.size() / 4].index;
  auto samples_of = [&](uint32_t scan) {
    std::vector<LidarObservation> out;
    for (const LidarObservation& o : all) {
      if (o.ref.scan == scan && o.ref.beam >= 300 && out.size() < 4 &&
          (out.empty() || o.ref.beam >= out.back().ref.beam + 40)) {
        out.push_back(o);
      }
    }
    return out;
  };
  const std::vector<LidarObservation> pass1 = samples_of(scan1), pass2 = samples_of(scan2);
  ASSERT_EQ(pass1.size(), 4u);
  ASSERT_EQ(pass2.size(), 4u);
  std::vector<PickPair> picks(4), legacy(4);
  for (size_t k = 0; k < 4; ++k) {
    picks[k] = {SamplePick(pass1[k]), SamplePick(pass2[k])};
    legacy[k] = {PositionPick(pass1[k].ref), PositionPick(pass2[k].ref)};
  }
  // Through the file format, as `calibrate --pairs` reads them.
  std::vector<PickPair> from_file, legacy_from_file;
  ASSERT_TRUE(ParsePairs(PairsToJson(picks), "pairs.json", &from_file).ok());
  ASSERT_TRUE(ParsePairs(PairsToJson(legacy), "old.json", &legacy_from_file).ok());
  ASSERT_NE(PairsToJson(picks).find("\"time_ns\""), std::string::npos);

  // Drop one 40-sample packet of scan1, a few packets before the first pick,
  // followed by another 40-sample packet (so that it is not one of the short
  // packets the decoder sees queued before a ring start).
  const LidarScan* scan1_a = ScanWithIndex(log_a, scan1);
  ASSERT_NE(scan1_a, nullptr);
  const Time scan1_start = scan1_a->samples.front().time;
  const Time first_pick = TimeFromNanoseconds(pass1[0].time_ns);
  size_t drop = session.records.size();
  for (size_t i = 0; i + 1 < session.records.size() && drop == session.records.size(); ++i) {
    Time receive;
    if (PacketSamples(session.records[i], &receive) != 40) continue;
    // Its last sample: receive - 90 bytes * 10 / 128000 baud (idle line).
    const Time last = receive - SerialTransmissionTime(90, 128000.0);
    if (last < scan1_start + std::chrono::milliseconds(20) ||
        last > first_pick - std::chrono::milliseconds(30)) {
      continue;
    }
    for (size_t j = i + 1; j < session.records.size(); ++j) {
      Time next;
      const int n = PacketSamples(session.records[j], &next);
      if (n < 0) continue;
      if (n == 40) drop = i;
      break;
    }
  }
  ASSERT_LT(drop, session.records.size()) << "no packet to drop";
  std::vector<SessionRecord> lossy = session.records;
  lossy.erase(lossy.begin() + static_cast<std::ptrdiff_t>(drop));
  const SensorLog log_b = Decode(lossy, session.meta);
  const SampleStore store_b(log_b, poses);

  // The loss is real: scan1 is 40 samples shorter, the other revolutions
  // keep their numbers, and (scan, beam) of the first pick now names
  // another sample.
  const LidarScan* scan1_b = ScanWithIndex(log_b, scan1);
  ASSERT_NE(scan1_b, nullptr);
  EXPECT_EQ(scan1_b->samples.size() + 40, scan1_a->samples.size());
  EXPECT_EQ(log_b.scans.size(), log_a.scans.size());
  const LidarSample& renumbered = scan1_b->samples[pass1[0].ref.beam];
  EXPECT_NE(ToNanoseconds(renumbered.time), pass1[0].time_ns);

  // The pairs file resolves to the same physical samples on both.
  const RobotGeometry& geometry = session.meta.geometry;
  std::vector<ObservationPair> on_a, on_b;
  const Status ra = ResolvePairs(from_file, store_a, windows, geometry, {}, &on_a);
  ASSERT_TRUE(ra.ok()) << ra.message();
  const Status rb = ResolvePairs(from_file, store_b, windows, geometry, {}, &on_b);
  ASSERT_TRUE(rb.ok()) << rb.message();
  ASSERT_EQ(on_a.size(), 4u);
  ASSERT_EQ(on_b.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    const LidarObservation* truth[2] = {&pass1[k], &pass2[k]};
    const LidarObservation* a[2] = {&on_a[k].pass1, &on_a[k].pass2};
    const LidarObservation* b[2] = {&on_b[k].pass1, &on_b[k].pass2};
    for (int side = 0; side < 2; ++side) {
      EXPECT_EQ(a[side]->time_ns, truth[side]->time_ns) << k << " " << side;
      EXPECT_EQ(b[side]->time_ns, truth[side]->time_ns) << k << " " << side;
      EXPECT_EQ(b[side]->range_m, truth[side]->range_m) << k << " " << side;
      EXPECT_EQ(b[side]->theta, truth[side]->theta) << k << " " << side;
      EXPECT_LE((b[side]->p_lidar - truth[side]->p_lidar).norm(), 1e-9);
      const Eigen::Vector3d wa = ProjectObservation(*a[side], geometry, config.mounting_error);
      const Eigen::Vector3d wb = ProjectObservation(*b[side], geometry, config.mounting_error);
      EXPECT_LE((wa - wb).norm(), 1e-9) << k << " " << side;
    }
    // The beam of the pass-1 picks moved by the lost packet's 40 samples.
    EXPECT_EQ(on_b[k].pass1.ref.beam + 40, on_a[k].pass1.ref.beam) << k;
  }

  // Version-1 picks by (scan, beam) load and resolve as before on the
  // recording they were made on...
  std::vector<ObservationPair> legacy_a;
  ASSERT_TRUE(ResolvePairs(legacy_from_file, store_a, windows, geometry, {}, &legacy_a).ok());
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(legacy_a[k].pass1.time_ns, pass1[k].time_ns) << k;
    EXPECT_EQ(legacy_a[k].pass2.time_ns, pass2[k].time_ns) << k;
  }
  // ...in a revolution without loss they still name the same samples...
  LidarObservation o;
  ASSERT_TRUE(FindPickedSample(legacy_from_file[0].pass2, store_b, &o).ok());
  EXPECT_EQ(o.time_ns, pass2[0].time_ns);
  // ...and where the loss renumbered the revolution they are refused, saying why.
  std::vector<ObservationPair> legacy_b;
  const Status rl = ResolvePairs(legacy_from_file, store_b, windows, geometry, {}, &legacy_b);
  ASSERT_FALSE(rl.ok());
  EXPECT_NE(rl.message().find("pair 1 (pairs[0]) pass1"), std::string::npos) << rl.message();
  EXPECT_NE(rl.message().find("lost samples"), std::string::npos) << rl.message();
  EXPECT_NE(rl.message().find("pick it again"), std::string::npos) << rl.message();
  sweepscan::testing::ShellOrFail("rm -rf '" + dir + "'");
}

}  // namespace
}  // namespace sweepscan::hardware
