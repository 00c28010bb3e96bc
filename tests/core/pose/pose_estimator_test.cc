#include "core/pose/pose_estimator.h"

#include <gtest/gtest.h>

#include "core/scenario/scenario.h"
#include "core/sim/world.h"
#include "tests/testing/worlds.h"

namespace sweepscan {
namespace {

// A closed loop (two full circles) with the left wheel slipping: its encoder
// over-reads by 30 % for 4 s and by 20 % for 3 s.
sim::SimConfig SlipLoop(uint64_t seed) {
  sim::SimConfig c = testing::LabConfig(seed);
  c.start = {5.0, 2.5, 0.0};
  c.path = {CircleSegment(1.2, 0.25, 2.0, true)};
  c.slips = {{5.0, 4.0, true, 0.30}, {30.0, 3.0, false, 0.20}};
  return c;
}

double FinalHeadingError(const sim::SimConfig& c, PoseSource source) {
  sim::SimWorld world(c);
  const SensorLog log = world.RunAll();
  PoseEstimatorOptions o;
  o.source = source;
  o.initial_pose = c.start;
  const PoseEstimator est = EstimatePoses(log, o, c.geometry);
  const Pose2d p = est.LatestPose2d();
  const double t = ToSeconds(est.poses().latest()) - sim::SimWorld::kStartTimeS;
  const double true_yaw = world.trajectory().PoseAt(t).yaw;
  return std::abs(WrapAngle(p.yaw - true_yaw));
}

TEST(PoseEstimatorTest, EkfBeatsOdometryUnderWheelSlip) {
  for (uint64_t seed : {1, 2, 3}) {
    const sim::SimConfig c = SlipLoop(seed);
    const double odo = FinalHeadingError(c, PoseSource::kOdometry);
    const double ekf = FinalHeadingError(c, PoseSource::kEkf);
    std::printf("seed %llu: final heading error odometry %.3f deg, EKF %.3f deg\n",
                static_cast<unsigned long long>(seed), odo * 180 / M_PI, ekf * 180 / M_PI);
    EXPECT_GT(odo, 0.05) << "slip must actually hurt odometry";
    EXPECT_LE(ekf, odo / 3.0) << "seed " << seed;
  }
}

TEST(PoseEstimatorTest, OdometryAloneIsExactWithPerfectWheels) {
  sim::SimConfig c = SlipLoop(1);
  testing::MakeNoiseFree(&c);
  EXPECT_LT(FinalHeadingError(c, PoseSource::kOdometry), 1e-6);
}

// The gyro z bias state (docs/models.md): a 2 mrad/s bias, a circle drive
// starting with a 2 s standstill. The standstill seeds g with the mean gyro
// z (200 readings of 3 mrad/s noise: 1-sigma 0.2 mrad/s), and the IMU yaw
// refines it during the drive; the heading stays within a few mrad of the
// truth where the filter without the state (g frozen at 0) lags by ~7 mrad.
TEST(PoseEstimatorTest, GyroBiasFromStandstillAndYaw) {
  sim::SimConfig c = testing::CircleConfig(1);
  c.imu.gyro_bias_rad_s = 0.002;
  c.path.insert(c.path.begin(), sim::DriveSegment{0.0, 0.0, 2.0});
  sim::SimWorld world(c);
  const SensorLog log = world.RunAll();
  double mean_abs_error[2] = {0.0, 0.0};
  for (int with_state = 0; with_state < 2; ++with_state) {
    PoseEstimatorOptions o;
    o.initial_pose = c.start;
    o.ekf.estimate_gyro_bias = with_state == 1;
    const PoseEstimator est = EstimatePoses(log, o, c.geometry);
    EXPECT_NEAR(est.standstill_s(), 2.0, 0.03);
    EXPECT_EQ(est.gyro_bias_seeded(), with_state == 1);
    const double g = est.ekf().state()[PoseEkf::kGyroBias];
    if (with_state == 1) {
      EXPECT_NEAR(g, 0.002, 0.0005);
      EXPECT_LT(std::sqrt(est.ekf().covariance()(PoseEkf::kGyroBias, PoseEkf::kGyroBias)), 0.0003);
    } else {
      EXPECT_EQ(g, 0.0);
    }
    // Mean |heading error| against the truth over the drive.
    int n = 0;
    for (size_t i = 0; i < est.poses().size(); i += 10, ++n) {
      const double t = ToSeconds(est.poses().time(i)) - sim::SimWorld::kStartTimeS;
      const Eigen::Matrix3d r = est.poses().pose(i).rotation().toRotationMatrix();
      const double yaw = std::atan2(r(1, 0), r(0, 0));
      mean_abs_error[with_state] += std::abs(WrapAngle(yaw - world.trajectory().PoseAt(t).yaw));
    }
    mean_abs_error[with_state] /= n;
  }
  std::printf("gyro bias 2 mrad/s: mean |heading error| without the bias state %.3f mrad, with %.3f mrad\n",
              1e3 * mean_abs_error[0], 1e3 * mean_abs_error[1]);
  EXPECT_LT(mean_abs_error[1], 0.004);
  EXPECT_LT(mean_abs_error[1], 0.6 * mean_abs_error[0]);
}

// No standstill (the robot moves from its first record): g keeps its prior
// and is learnt from the IMU yaw within the first turn.
TEST(PoseEstimatorTest, GyroBiasLearntWithoutStandstill) {
  sim::SimConfig c = testing::CircleConfig(2);
  c.imu.gyro_bias_rad_s = -0.002;
  sim::SimWorld world(c);
  PoseEstimatorOptions o;
  o.initial_pose = c.start;
  o.ekf.estimate_gyro_bias = true;  // off by default (ekf.h)
  const PoseEstimator est = EstimatePoses(world.RunAll(), o, c.geometry);
  EXPECT_FALSE(est.gyro_bias_seeded());
  EXPECT_NEAR(est.ekf().state()[PoseEkf::kGyroBias], -0.002, 0.0005);
}

TEST(PoseEstimatorTest, PoseSourceNames) {
  PoseSource s;
  ASSERT_TRUE(ParsePoseSource("odometry", &s));
  EXPECT_EQ(s, PoseSource::kOdometry);
  EXPECT_STREQ(PoseSourceName(PoseSource::kTruth), "truth");
  EXPECT_FALSE(ParsePoseSource("gps", &s));
}

}  // namespace
}  // namespace sweepscan
