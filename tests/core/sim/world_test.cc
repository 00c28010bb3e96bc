#include "core/sim/world.h"

#include <gtest/gtest.h>

#include "tests/testing/worlds.h"

namespace sweepscan::sim {
namespace {

TEST(WorldTest, LidarTimingMatchesTheX4) {
  const SimConfig c = testing::LabConfig();
  SimWorld world(c);
  const SensorLog log = world.RunAll();
  // 5 kHz samples, 7 Hz revolutions: about 714 samples a scan.
  const double duration = world.duration_s();
  EXPECT_NEAR(static_cast<double>(log.scans.size()), duration * 7.0, 2.0);
  for (size_t i = 1; i + 1 < log.scans.size(); ++i) {
    const auto& s = log.scans[i];
    EXPECT_NEAR(static_cast<double>(s.samples.size()), 5000.0 / 7.0, 1.0);
    EXPECT_EQ(s.index, i);
    EXPECT_NEAR(ToSeconds(s.samples[1].time - s.samples[0].time), 1.0 / 5000, 1e-9);
    EXPECT_EQ(s.samples.back().beam, s.samples.size() - 1);
  }
  size_t zero = 0, total = 0;
  for (const auto& s : log.scans) {
    for (const auto& smp : s.samples) {
      ++total;
      if (smp.range_m == 0.0f) {
        ++zero;
      } else {
        EXPECT_GE(smp.range_m, 0.12f);
        EXPECT_LE(smp.range_m, 10.0f);
        // Quantised to the X4's 1 mm.
        EXPECT_NEAR(smp.range_m * 1000.0, std::round(smp.range_m * 1000.0), 1e-3);
      }
    }
  }
  // Dropouts: 1 % at random plus grazing returns, not more than a few percent.
  EXPECT_GT(zero, total / 200);
  EXPECT_LT(zero, total / 10);
}

TEST(WorldTest, NoiseFreeRangesAreExactRayCasts) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.mounting_error = {0.01, -0.02, 0.03};
  SimWorld world(c);
  world.KeepSampleTruth(true);
  const SensorLog log = world.RunAll();
  size_t k = 0, checked = 0;
  for (const auto& scan : log.scans) {
    for (const auto& s : scan.samples) {
      const SampleTruth& t = world.sample_truth()[k++];
      if (s.range_m == 0.0f || checked > 5000) continue;
      ++checked;
      // Re-derive the point from the true lidar pose at the sample's time.
      const Eigen::Vector3d p = world.TrueWorldFromLidar(s.time) * LidarPoint(s.range_m, s.theta);
      EXPECT_LT(c.scene.DistanceToSurface(p), 1e-5);
      EXPECT_NEAR(s.range_m, t.true_range, 1e-5);
    }
  }
  EXPECT_GT(checked, 5000u);
}

TEST(WorldTest, WheelScaleErrorAndImuHeadingReference) {
  SimConfig c = testing::LabConfig();
  testing::MakeNoiseFree(&c);
  c.odometry.scale_error_left = 0.01;
  SimWorld world(c);
  const SensorLog log = world.RunAll();
  ASSERT_GT(log.wheels.size(), 100u);
  // On the first straight (0.2 m/s) the left wheel reads 1 % high.
  EXPECT_NEAR(log.wheels[50].left_mps, 0.202, 1e-9);
  EXPECT_NEAR(log.wheels[50].right_mps, 0.2, 1e-9);
  // IMU heading = world yaw + its reference offset.
  EXPECT_NEAR(log.imu[10].yaw, c.imu.yaw_reference_offset_rad, 1e-12);
  // During the half turn the gyro reads 0.3 rad/s.
  EXPECT_NEAR(log.imu[4000].gyro_z, 0.3, 1e-12);
}

TEST(WorldTest, RunUntilInPiecesEqualsRunAll) {
  const SimConfig c = testing::CircleConfig(3);
  SimWorld whole(c), pieces(c);
  const SensorLog a = whole.RunAll();
  SensorLogCollector collector;
  for (double t = 1.0; !pieces.finished(); t += 0.0371) pieces.RunUntil(TimeFromSeconds(t), &collector);
  const SensorLog& b = *collector.log();
  ASSERT_EQ(a.scans.size(), b.scans.size());
  ASSERT_EQ(a.wheels.size(), b.wheels.size());
  ASSERT_EQ(a.imu.size(), b.imu.size());
  EXPECT_EQ(a.scans[10].samples[100].range_m, b.scans[10].samples[100].range_m);
  EXPECT_EQ(a.imu[77].yaw, b.imu[77].yaw);
}

TEST(WorldTest, TrajectoryIsExact) {
  const Trajectory t({0, 0, 0}, {{0.2, 0.0, 10.0}, {0.0, 0.5, M_PI}});
  EXPECT_NEAR(t.PoseAt(10.0).x, 2.0, 1e-12);
  EXPECT_NEAR(t.PoseAt(10.0 + M_PI).x, 2.0, 1e-12);
  EXPECT_NEAR(std::abs(t.PoseAt(10.0 + M_PI).yaw), M_PI / 2, 1e-12);
  EXPECT_NEAR(t.TwistAt(11.0).w, 0.5, 1e-12);
  EXPECT_NEAR(t.TwistAt(100.0).v, 0.0, 1e-12);
}

TEST(WorldTest, ConfigValidation) {
  SimConfig c = testing::LabConfig();
  std::string error;
  EXPECT_TRUE(c.IsValid(&error)) << error;
  c.lidar.max_range_m = 0.1;
  EXPECT_FALSE(c.IsValid(&error));
  c = testing::LabConfig();
  c.path.clear();
  EXPECT_FALSE(c.IsValid(&error));
}

}  // namespace
}  // namespace sweepscan::sim
