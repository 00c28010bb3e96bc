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

TEST(PoseEstimatorTest, PoseSourceNames) {
  PoseSource s;
  ASSERT_TRUE(ParsePoseSource("odometry", &s));
  EXPECT_EQ(s, PoseSource::kOdometry);
  EXPECT_STREQ(PoseSourceName(PoseSource::kTruth), "truth");
  EXPECT_FALSE(ParsePoseSource("gps", &s));
}

}  // namespace
}  // namespace sweepscan
