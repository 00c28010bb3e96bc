// The simulated recording through the real bytes (devices -> agent -> link
// -> session -> decoders) must give the same cloud as the simulator's direct
// records, within the resolution of the wire formats.
#include "hardware/emulation/simulate_session.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <unordered_map>

#include "core/cloud/reconstruct.h"
#include "hardware/link/telemetry_decoder.h"
#include "tests/testing/worlds.h"
#include "tests/testing/run_command.h"

namespace sweepscan::hardware {
namespace {

std::string FreshDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/sweepscan_simsession_" + name;
  sweepscan::testing::ShellOrFail("rm -rf '" + dir + "'");
  return dir;
}

TEST(SimulateSessionTest, BytePathMatchesDirectRecords) {
  sim::SimConfig config = testing::LabConfig(5);
  config.path = {{0.2, 0.0, 6.0}, {0.0, 0.3, 4.0}, {0.2, 0.1, 4.0}};
  const std::string dir = FreshDir("lab");
  SimulateSessionReport report;
  const Status s = SimulateSession(config, dir, SimulateSessionOptions(), &report);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_GT(report.telemetry_frames, 1000u);
  EXPECT_EQ(report.link.codec.checksum_errors, 0u);
  EXPECT_EQ(report.link.codec.bytes_skipped, 0u);

  SensorLog bytes_log;
  SessionDecodeInfo info;
  const Status d = DecodeSession(dir, &bytes_log, &info);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(info.frames_refused, 0u);

  sim::SimWorld world(config);
  const SensorLog direct = world.RunAll();
  // Every direct revolution arrives (the last one may still be open when
  // the recording ends).
  EXPECT_GE(bytes_log.scans.size() + 1, direct.scans.size());
  EXPECT_GT(bytes_log.scans.size(), direct.scans.size() - 2);

  // Sample by sample, matched by time (to the microsecond).
  std::unordered_map<int64_t, const LidarSample*> by_time;
  for (const auto& scan : direct.scans) {
    for (const auto& smp : scan.samples) by_time[ToNanoseconds(smp.time) / 1000] = &smp;
  }
  size_t matched = 0;
  double worst_range = 0.0, worst_theta = 0.0;
  for (const auto& scan : bytes_log.scans) {
    for (const auto& smp : scan.samples) {
      const auto it = by_time.find((ToNanoseconds(smp.time) + 500) / 1000);
      if (it == by_time.end()) continue;
      ++matched;
      if (it->second->range_m > 0.0f && smp.range_m > 0.0f) {
        worst_range = std::max(worst_range, std::abs(double(smp.range_m) - it->second->range_m));
        worst_theta = std::max(worst_theta, std::abs(WrapAngle(double(smp.theta) - it->second->theta)));
      }
    }
  }
  std::printf("matched %zu samples by time; worst range difference %.4f mm, angle %.5f deg\n", matched,
              worst_range * 1e3, worst_theta * 180 / M_PI);
  EXPECT_GT(matched, 65000u);  // 14 s at 5 kHz
  EXPECT_LT(worst_range, 1e-6);                // whole millimetres both ways
  EXPECT_LT(worst_theta, (1.0 / 64) * M_PI / 180);  // FSA/LSA field resolution

  // The clouds: EKF poses from the decoded wheel (integer mm/s) and IMU
  // (float) records versus the direct doubles.
  ReconstructionOptions o;
  o.pose.initial_pose = config.start;
  ReconstructionResult a, b;
  ASSERT_TRUE(Reconstruct(direct, config.geometry, o, nullptr, &a).ok());
  ASSERT_TRUE(Reconstruct(bytes_log, config.geometry, o, nullptr, &b).ok());
  std::unordered_map<int64_t, const CloudPoint*> points;
  for (const auto& p : a.points) points[p.time_ns / 1000] = &p;
  std::vector<double> d3;
  for (const auto& p : b.points) {
    const auto it = points.find((p.time_ns + 500) / 1000);
    if (it == points.end()) continue;
    d3.push_back(std::hypot(p.x - it->second->x, p.y - it->second->y, p.z - it->second->z));
  }
  ASSERT_GT(d3.size(), 60000u);
  std::sort(d3.begin(), d3.end());
  const double median = d3[d3.size() / 2], p99 = d3[d3.size() * 99 / 100];
  std::printf("cloud through the bytes vs direct: median %.2f mm, p99 %.2f mm, max %.2f mm over %zu points\n",
              median * 1e3, p99 * 1e3, d3.back() * 1e3, d3.size());
  EXPECT_LT(median, 0.002);
  EXPECT_LT(p99, 0.01);
}

TEST(SimulateSessionTest, RefusesExistingFolderAndBadConfig) {
  const std::string dir = FreshDir("twice");
  sim::SimConfig config = testing::LabConfig(1);
  config.path = {{0.2, 0.0, 1.0}};
  SimulateSessionReport report;
  ASSERT_TRUE(SimulateSession(config, dir, SimulateSessionOptions(), &report).ok());
  EXPECT_FALSE(SimulateSession(config, dir, SimulateSessionOptions(), &report).ok());
  SimulateSessionOptions overwrite;
  overwrite.overwrite = true;
  EXPECT_TRUE(SimulateSession(config, dir, overwrite, &report).ok());
  config.path.clear();
  EXPECT_FALSE(SimulateSession(config, FreshDir("bad"), SimulateSessionOptions(), &report).ok());
}

}  // namespace
}  // namespace sweepscan::hardware
