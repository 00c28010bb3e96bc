#include "core/pose/pose_estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

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

// Heading error of `poses` against the simulation's truth: its mean (a
// constant turn of the whole cloud, harmless) and the RMS of what is left,
// the wander that puts two sightings of a wall apart.
struct HeadingError {
  double mean = 0.0, wander_rms = 0.0;
};
HeadingError HeadingErrorAgainstTruth(const PoseBuffer& poses, const sim::SimWorld& world) {
  std::vector<double> e;
  for (size_t i = 0; i < poses.size(); ++i) {
    const double t = ToSeconds(poses.time(i)) - sim::SimWorld::kStartTimeS;
    const Eigen::Matrix3d r = poses.pose(i).rotation().toRotationMatrix();
    e.push_back(WrapAngle(std::atan2(r(1, 0), r(0, 0)) - world.trajectory().PoseAt(t).yaw));
  }
  HeadingError h;
  for (double v : e) h.mean += v / e.size();
  for (double v : e) h.wander_rms += (v - h.mean) * (v - h.mean) / e.size();
  h.wander_rms = std::sqrt(h.wander_rms);
  return h;
}

// The smoothed EKF (options.smooth; ekf.h, "Smoothing") on the calibration
// circle with the simulator's sensor noise (IMU yaw 0.5 deg white, gyro 3
// mrad/s): every pose uses the whole drive's yaw readings, so the heading
// wanders less about its mean than the forward filter's, over several
// seeds; the poses cover the same span, and the last pose is the filter's.
TEST(PoseEstimatorTest, SmoothedHeadingWandersLessThanTheFilters) {
  for (uint64_t seed : {1, 2, 3, 4}) {
    sim::SimConfig c = testing::CircleConfig(seed);
    c.imu.gyro_bias_rad_s = 0.001;
    sim::SimWorld world(c);
    const SensorLog log = world.RunAll();
    PoseEstimatorOptions o;
    o.initial_pose = c.start;
    const PoseEstimator forward = EstimatePoses(log, o, c.geometry);
    o.smooth = true;
    const PoseEstimator smoothed = EstimatePoses(log, o, c.geometry);
    const PoseBuffer& f = forward.poses();
    const PoseBuffer& s = smoothed.poses();
    EXPECT_EQ(s.earliest(), f.earliest());
    EXPECT_EQ(s.latest(), f.latest());
    EXPECT_GT(s.size(), f.size() / 2);
    EXPECT_LT((s.pose(s.size() - 1).translation() - f.pose(f.size() - 1).translation()).norm(), 1e-12);
    const HeadingError ef = HeadingErrorAgainstTruth(f, world);
    const HeadingError es = HeadingErrorAgainstTruth(s, world);
    std::printf("seed %llu: heading wander (RMS about the mean) forward %.3f mrad, smoothed %.3f mrad; "
                "mean %+.3f / %+.3f mrad\n",
                static_cast<unsigned long long>(seed), 1e3 * ef.wander_rms, 1e3 * es.wander_rms,
                1e3 * ef.mean, 1e3 * es.mean);
    EXPECT_LT(es.wander_rms, 0.7 * ef.wander_rms) << "seed " << seed;
  }
}

// Angle between the body's z axis and the world's: the tilt error of a pose,
// the simulator's floor being flat (its true tilt is zero).
double TiltErrorRms(const PoseBuffer& poses) {
  double sum = 0.0;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Matrix3d r = poses.pose(i).rotation().toRotationMatrix();
    const double tilt = std::acos(std::clamp(r(2, 2), -1.0, 1.0));
    sum += tilt * tilt;
  }
  return std::sqrt(sum / poses.size());
}

// On the refined picks' slow calibration drive (0.05 m/s) with the IMU's
// tilt readings 0.45 deg noisy, the tilt's random walk in distance driven
// (ekf.h) lets the smoothed tilt average the noise over about twice as long
// as the old 1 mrad/sqrt(s) in time: its error is smaller by about
// (0.5 / 1)^(1/2) (a random walk observed in white noise has an error
// variance ~ sqrt(q r)).
TEST(PoseEstimatorTest, SlowDriveTiltAveragesTheImuNoiseLonger) {
  for (uint64_t seed : {1, 2}) {
    sim::SimConfig c = testing::CircleConfig(seed);
    c.path = {CircleSegment(0.83, 0.05, 1.0, /*left=*/true)};
    c.imu.tilt_noise_rad = 0.45 * M_PI / 180.0;
    sim::SimWorld world(c);
    const SensorLog log = world.RunAll();
    PoseEstimatorOptions o;
    o.initial_pose = c.start;
    o.smooth = true;
    const double now = TiltErrorRms(EstimatePoses(log, o, c.geometry).poses());
    o.ekf.tilt_sigma = 0.001;  // the random walk in time alone, before
    o.ekf.tilt_sigma_per_metre = 0.0;
    const double before = TiltErrorRms(EstimatePoses(log, o, c.geometry).poses());
    std::printf("seed %llu: smoothed tilt error RMS %.3f mrad (in time alone: %.3f mrad)\n",
                static_cast<unsigned long long>(seed), 1e3 * now, 1e3 * before);
    EXPECT_LT(now, 0.8 * before) << "seed " << seed;
    EXPECT_LT(now, 1e-3) << "seed " << seed;
  }
}

// Odometry poses and the live estimator are never smoothed: smooth only
// asks EstimatePoses (a whole log) to smooth the EKF.
TEST(PoseEstimatorTest, SmoothingLeavesOdometryAlone) {
  sim::SimConfig c = testing::CircleConfig(1);
  sim::SimWorld world(c);
  const SensorLog log = world.RunAll();
  PoseEstimatorOptions o;
  o.initial_pose = c.start;
  o.source = PoseSource::kOdometry;
  const PoseBuffer plain = EstimatePoses(log, o, c.geometry).poses();
  o.smooth = true;
  const PoseBuffer smoothed = EstimatePoses(log, o, c.geometry).poses();
  ASSERT_EQ(plain.size(), smoothed.size());
  for (size_t i = 0; i < plain.size(); i += 97) {
    EXPECT_EQ(plain.pose(i).translation(), smoothed.pose(i).translation());
  }
}

TEST(PoseEstimatorTest, PoseSourceNames) {
  PoseSource s;
  ASSERT_TRUE(ParsePoseSource("odometry", &s));
  EXPECT_EQ(s, PoseSource::kOdometry);
  EXPECT_STREQ(PoseSourceName(PoseSource::kTruth), "truth");
  EXPECT_FALSE(ParsePoseSource("gps", &s));
}

// A drive with a 10 s hole in every stream (the link to the robot dropped):
// the robot drives straight, then on an arc (0.3 m/s, 0.3 rad/s) when the
// data stops at 9.6 s; 0.4 s later it stops (the agent's watchdog) and
// stands still until 20 s, after the data is back at 19.6 s. Truth: 0.12 m
// and 0.12 rad of motion inside the gap. `cut` removes the records in
// (t0, t1) from every stream (times from the simulation's start).
constexpr double kGapFrom = 9.6, kGapTo = 19.6;

SensorLog CutHole(SensorLog log, double t0, double t1) {
  const Time a = TimeFromSeconds(sim::SimWorld::kStartTimeS + t0);
  const Time b = TimeFromSeconds(sim::SimWorld::kStartTimeS + t1);
  const auto inside = [&](const auto& r) { return r.time > a && r.time < b; };
  log.wheels.erase(std::remove_if(log.wheels.begin(), log.wheels.end(), inside), log.wheels.end());
  log.imu.erase(std::remove_if(log.imu.begin(), log.imu.end(), inside), log.imu.end());
  for (LidarScan& scan : log.scans) {
    scan.samples.erase(std::remove_if(scan.samples.begin(), scan.samples.end(), inside), scan.samples.end());
  }
  log.scans.erase(std::remove_if(log.scans.begin(), log.scans.end(),
                                 [](const LidarScan& s) { return s.samples.empty(); }),
                  log.scans.end());
  return log;
}

Pose2d Pose2dOf(const Rigid3d& p) {
  const Eigen::Matrix3d r = p.rotation().toRotationMatrix();
  return {p.translation().x(), p.translation().y(), std::atan2(r(1, 0), r(0, 0))};
}

TEST(PoseEstimatorTest, GapInTheDataIsAGapNotAMotion) {
  for (uint64_t seed : {1, 2, 3}) {
    const sim::SimConfig c = testing::GapDriveConfig(seed);
    sim::SimWorld world(c);
    const SensorLog log = CutHole(world.RunAll(), kGapFrom, kGapTo);
    const auto truth = [&](Time t) { return world.trajectory().PoseAt(ToSeconds(t) - sim::SimWorld::kStartTimeS); };
    for (int smooth = 0; smooth < 2; ++smooth) {
      SCOPED_TRACE(::testing::Message() << "seed " << seed << (smooth ? " smoothed" : " filtered"));
      PoseEstimatorOptions o;
      o.initial_pose = c.start;
      o.smooth = smooth == 1;
      const PoseEstimator est = EstimatePoses(log, o, c.geometry);
      ASSERT_EQ(est.gaps().size(), 1u);
      const PoseGap& gap = est.gaps()[0];
      // The gap as cut: begin = the last record before 9.6 s (IMU at 100 Hz).
      EXPECT_NEAR(ToSeconds(gap.begin) - sim::SimWorld::kStartTimeS, kGapFrom, 0.011);
      EXPECT_NEAR(ToSeconds(gap.end) - sim::SimWorld::kStartTimeS, kGapTo, 0.011);
      EXPECT_NEAR(gap.length_s, kGapTo - kGapFrom, 0.022);
      EXPECT_EQ(gap.recovery, PoseGap::Recovery::kImuHeading);
      EXPECT_FALSE(gap.turned_beyond_bound);
      ASSERT_TRUE(gap.has_first_pose);
      EXPECT_GE(gap.first_pose, gap.end);
      EXPECT_LT(ToSeconds(gap.first_pose - gap.end), 0.011) << "the first IMU yaw sets the heading";
      // The bound from 0.3 m/s, 0.3 rad/s (wheels 0.255 and 0.345 m/s):
      // (s_l + s_r) / 2 = 0.196 m, max(s_l, s_r) / 0.3 m = 0.77 rad.
      EXPECT_NEAR(gap.travel_bound_m, 0.196, 0.01);
      EXPECT_GE(gap.position_sigma_m, gap.travel_bound_m);

      // The buffer: nothing inside the gap, both ends answer.
      const PoseBuffer& poses = est.poses();
      EXPECT_EQ(poses.gap_count(), 1u);
      Rigid3d before, after, inside;
      ASSERT_TRUE(poses.Lookup(gap.begin, &before));
      ASSERT_TRUE(poses.Lookup(gap.first_pose, &after));
      for (double f : {1e-4, 0.5, 0.9999}) {
        const Time t = gap.begin + std::chrono::duration_cast<Duration>((gap.first_pose - gap.begin) * f);
        EXPECT_FALSE(poses.Lookup(t, &inside)) << f;
      }
      // No motion invented: the position after the gap is the one before
      // it, within the stated bound of the truth (which moved 0.12 m).
      const Pose2d p0 = Pose2dOf(before), p1 = Pose2dOf(after);
      const Pose2d t0 = truth(gap.begin), t1 = truth(gap.first_pose);
      const double held = std::hypot(p1.x - p0.x, p1.y - p0.y);
      const double error_before = std::hypot(p0.x - t0.x, p0.y - t0.y);
      const double error_after = std::hypot(p1.x - t1.x, p1.y - t1.y);
      const double heading_error = std::abs(WrapAngle(p1.yaw - t1.yaw));
      std::printf("seed %llu %s: gap %.2f s, position held (moved %.1f mm), error %.1f mm before, %.1f mm "
                  "after (bound %.0f mm); heading error after %.2f mrad (IMU sigma %.1f, turn in the gap %.0f)\n",
                  static_cast<unsigned long long>(seed), smooth ? "smoothed" : "filtered", gap.length_s,
                  1e3 * held, 1e3 * error_before, 1e3 * error_after, 1e3 * gap.travel_bound_m,
                  1e3 * heading_error, 1e3 * o.ekf.imu_yaw_sigma, 1e3 * std::abs(WrapAngle(t1.yaw - t0.yaw)));
      EXPECT_LT(held, 0.01);
      EXPECT_LT(error_before, 0.03) << "the smoother must not smear the gap into the estimates before it";
      EXPECT_LT(error_after, gap.travel_bound_m);
      EXPECT_LT(heading_error, 3.0 * o.ekf.imu_yaw_sigma);
      // And after the gap the drive goes on from there: at the end, the
      // error is the one the gap left plus the usual drift.
      const Pose2d last = Pose2dOf(poses.pose(poses.size() - 1)), t_last = truth(poses.latest());
      EXPECT_LT(std::hypot(last.x - t_last.x, last.y - t_last.y), error_after + 0.05);
    }
    // The filter without gap handling (max_gap_s beyond the hole) predicts
    // across it at the speed before: metres of invented travel.
    PoseEstimatorOptions o;
    o.initial_pose = c.start;
    o.max_gap_s = 60.0;
    const PoseEstimator naive = EstimatePoses(log, o, c.geometry);
    EXPECT_TRUE(naive.gaps().empty());
    const Pose2d n = naive.LatestPose2d(), tn = truth(naive.poses().latest());
    std::printf("seed %llu without gap handling: %.2f m from the truth at the end\n",
                static_cast<unsigned long long>(seed), std::hypot(n.x - tn.x, n.y - tn.y));
    EXPECT_GT(std::hypot(n.x - tn.x, n.y - tn.y), 1.0);
  }
}

// Wheel odometry alone holds its pose over a gap too (it has no IMU yaw).
TEST(PoseEstimatorTest, OdometryHoldsItsPoseOverAGap) {
  sim::SimConfig c = testing::GapDriveConfig(1);
  testing::MakeNoiseFree(&c);
  sim::SimWorld world(c);
  const SensorLog log = CutHole(world.RunAll(), kGapFrom, kGapTo);
  PoseEstimatorOptions o;
  o.source = PoseSource::kOdometry;
  o.initial_pose = c.start;
  const PoseEstimator est = EstimatePoses(log, o, c.geometry);
  ASSERT_EQ(est.gaps().size(), 1u);
  const PoseGap& gap = est.gaps()[0];
  EXPECT_EQ(gap.recovery, PoseGap::Recovery::kHeld);
  ASSERT_TRUE(gap.has_first_pose);
  const PoseBuffer& poses = est.poses();
  const size_t i = poses.FirstAtOrAfter(gap.first_pose);
  ASSERT_TRUE(i > 0 && poses.AfterGap(i));
  const Pose2d p0 = Pose2dOf(poses.pose(i - 1)), p1 = Pose2dOf(poses.pose(i));
  EXPECT_LT(std::hypot(p1.x - p0.x, p1.y - p0.y), 0.01);
  EXPECT_NEAR(p1.yaw, p0.yaw, 1e-3);
  EXPECT_EQ(FormatPoseGap(gap, TimeFromSeconds(sim::SimWorld::kStartTimeS)).rfind("gap at 9.6 s: 10.0 s without data; pose after it held", 0), 0u)
      << FormatPoseGap(gap, TimeFromSeconds(sim::SimWorld::kStartTimeS));
}

}  // namespace
}  // namespace sweepscan
