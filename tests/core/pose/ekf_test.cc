#include "core/pose/ekf.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace sweepscan {
namespace {

PoseEkf MakeFilter(const EkfOptions& o = EkfOptions()) {
  PoseEkf ekf(o);
  PoseEkf::State var;
  var << 1e-8, 1e-8, 1e-8, 0.25, 0.25, 0.003, 0.003, 1.0, 0.003 * 0.003;
  ekf.Initialize(TimeFromSeconds(0), PoseEkf::State::Zero(), var.asDiagonal());
  return ekf;
}

TEST(EkfTest, PredictionFollowsTheUnicycle) {
  PoseEkf ekf = MakeFilter();
  // Converge v and w from perfect wheels, then check the position the
  // process model produces after 5 s on a circle of radius 1 m.
  for (int i = 1; i <= 250; ++i) ekf.UpdateWheels(TimeFromSeconds(i * 0.02), 0.5, 0.5);
  const double x0 = ekf.state()[PoseEkf::kX], y0 = ekf.state()[PoseEkf::kY];
  const double psi0 = ekf.state()[PoseEkf::kPsi];
  EXPECT_NEAR(ekf.state()[PoseEkf::kV], 0.5, 1e-3);
  EXPECT_NEAR(ekf.state()[PoseEkf::kW], 0.5, 1e-3);
  for (int i = 251; i <= 500; ++i) ekf.UpdateWheels(TimeFromSeconds(i * 0.02), 0.5, 0.5);
  // Exact arc from (x0, y0, psi0) over 5 s with v = 0.5, w = 0.5 (radius 1).
  const double dpsi = 2.5;
  EXPECT_NEAR(ekf.state()[PoseEkf::kX], x0 + (std::sin(psi0 + dpsi) - std::sin(psi0)), 0.01);
  EXPECT_NEAR(ekf.state()[PoseEkf::kY], y0 - (std::cos(psi0 + dpsi) - std::cos(psi0)), 0.01);
}

TEST(EkfTest, GyroOutweighsSlippingWheelsForYawRate) {
  PoseEkf ekf = MakeFilter();
  // Wheels claim 0.3 rad/s (slip), the gyro says 0.1 rad/s: the estimate
  // follows the gyro (ten times less noise) and the gate refuses the wheels.
  for (int i = 1; i <= 500; ++i) {
    const Time t = TimeFromSeconds(i * 0.01);
    ekf.UpdateGyro(t, 0.1);
    if (i % 2 == 0) ekf.UpdateWheels(t, 0.2, 0.3);
  }
  EXPECT_NEAR(ekf.state()[PoseEkf::kW], 0.1, 0.01);
  EXPECT_GT(ekf.counters().rejected, 200);
}

TEST(EkfTest, YawOffsetIsLearntNotFrozen) {
  // IMU heading = world yaw + 0.7 rad + noise; the robot stands still. The
  // first reading is 0.01 rad off; the filter must not keep that bias.
  PoseEkf ekf = MakeFilter();
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 0.0087);
  ekf.UpdateYaw(TimeFromSeconds(0.01), 0.7 + 0.01);
  for (int i = 2; i <= 3000; ++i) {
    const Time t = TimeFromSeconds(i * 0.01);
    ekf.UpdateGyro(t, 0.0);
    ekf.UpdateYaw(t, 0.7 + n(rng));
  }
  EXPECT_NEAR(ekf.state()[PoseEkf::kPsi], 0.0, 0.002);
  EXPECT_NEAR(ekf.state()[PoseEkf::kYawOffset], 0.7, 0.002);
}

TEST(EkfTest, MahalanobisGateRejectsOutliers) {
  PoseEkf ekf = MakeFilter();
  for (int i = 1; i <= 100; ++i) ekf.UpdateGyro(TimeFromSeconds(i * 0.01), 0.0);
  const int rejected = ekf.counters().rejected;
  EXPECT_FALSE(ekf.UpdateGyro(TimeFromSeconds(1.01), 5.0));  // 1000 sigma
  EXPECT_EQ(ekf.counters().rejected, rejected + 1);
  EXPECT_NEAR(ekf.state()[PoseEkf::kW], 0.0, 1e-3);
  EXPECT_TRUE(ekf.UpdateGyro(TimeFromSeconds(1.02), 0.001));
}

TEST(EkfTest, CovarianceStaysSymmetricPositiveDefinite) {
  // With the gyro-bias state on (off, g's row and column stay exactly 0).
  EkfOptions with_bias;
  with_bias.estimate_gyro_bias = true;
  PoseEkf ekf = MakeFilter(with_bias);
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0, 1);
  for (int i = 1; i <= 2000; ++i) {
    const Time t = TimeFromSeconds(i * 0.01);
    ekf.UpdateWheels(t, 0.2 + 0.01 * n(rng), 0.1 + 0.05 * n(rng));
    ekf.UpdateGyro(t, 0.1 + 0.005 * n(rng));
    ekf.UpdateYaw(t, ekf.state()[PoseEkf::kPsi] + 0.3 + 0.0087 * n(rng));
    ekf.UpdateTilt(t, 0.005 * n(rng), 0.005 * n(rng));
  }
  const auto& p = ekf.covariance();
  EXPECT_LT((p - p.transpose()).norm(), 1e-12);
  Eigen::SelfAdjointEigenSolver<PoseEkf::Covariance> eig(p);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
}

// The smoother (ekf.h, "Smoothing") on a case with a closed-form answer: a
// robot standing still whose heading psi is pinned (prior 1e-8, w known to
// be 0), so the IMU's yaw readings z_i = psi + b + n_i inform only the
// heading reference b, whose random walk is switched off. The filter is then
// recursive least squares: its b at step k is the mean of z_1..z_k, with
// variance R / k. The smoother's b at every step must be the mean of all N
// readings, with variance R / N, the batch answer, where the filter's first
// estimates are a reading or two.
TEST(EkfTest, SmootherGivesEveryTimeTheMeanOfAllReadings) {
  EkfOptions o;
  o.yaw_offset_sigma = 1e-12;      // b constant
  o.yaw_sigma = 1e-12;             // psi moves only through w
  o.angular_accel_sigma = 1e-12;   // w constant (0)
  o.gate_chi2_1dof = 0.0;          // keep every reading (the gate refuses ~1 in 1000 here)
  PoseEkf ekf(o);
  PoseEkf::State var;
  // psi pinned to 1e-12 rad^2: the readings' mean then has R / N = 7.6e-8
  // of variance, which a psi prior of 1e-8 would visibly add to.
  var << 1e-8, 1e-8, 1e-12, 1e-12, 1e-12, 0.003, 0.003, 1.0, 0.003 * 0.003;
  ekf.Initialize(TimeFromSeconds(0), PoseEkf::State::Zero(), var.asDiagonal());
  ekf.KeepHistory(true);
  constexpr int kN = 1000;
  const double b_true = 0.4;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, o.imu_yaw_sigma);
  std::vector<double> z(kN);
  double mean = 0.0;
  for (int i = 0; i < kN; ++i) {
    z[i] = b_true + n(rng);
    mean += z[i] / kN;
    ekf.UpdateYaw(TimeFromSeconds(0.01 * (i + 1)), z[i]);
  }
  const std::vector<PoseEkf::Estimate> smoothed = ekf.Smooth();
  const std::vector<PoseEkf::Estimate>& filtered = ekf.history();
  ASSERT_EQ(smoothed.size(), filtered.size() + 1);  // the filter times and the current one
  const double r = o.imu_yaw_sigma * o.imu_yaw_sigma;
  ASSERT_EQ(filtered.size(), static_cast<size_t>(kN));  // t = 0 and the first N - 1 readings
  // The forward filter after k readings: their mean (recursive least
  // squares), with variance R / k. Its first estimates are a reading or two.
  double running = 0.0, worst_forward = 0.0;
  for (size_t k = 1; k < filtered.size(); ++k) {
    running += (z[k - 1] - running) / k;
    ASSERT_NEAR(filtered[k].state[PoseEkf::kYawOffset], running, 1e-6) << "step " << k;
    ASSERT_NEAR(filtered[k].covariance(PoseEkf::kYawOffset, PoseEkf::kYawOffset), r / k, 0.02 * r / k);
    worst_forward = std::max(worst_forward, std::abs(filtered[k].state[PoseEkf::kYawOffset] - mean));
  }
  EXPECT_GT(worst_forward, 3e-3);  // a reading's noise (8.7 mrad) early on
  // The smoother: the mean of all N at every time, and its variance R / N.
  // (1e-6: the pinned psi and w still take ~1e-8 of each innovation.)
  for (size_t k = 1; k < smoothed.size(); ++k) {
    ASSERT_NEAR(smoothed[k].state[PoseEkf::kYawOffset], mean, 1e-6) << "step " << k;
    ASSERT_NEAR(smoothed[k].covariance(PoseEkf::kYawOffset, PoseEkf::kYawOffset), r / kN, 0.02 * r / kN)
        << "step " << k;
    ASSERT_NEAR(smoothed[k].state[PoseEkf::kPsi], 0.0, 1e-5) << "step " << k;
  }
  // The last smoothed estimate is the filter's own.
  EXPECT_EQ(smoothed.back().state, ekf.state());
  EXPECT_EQ(smoothed.back().covariance, ekf.covariance());
}

// The smoother with the gyro-bias state frozen (g's variance exactly 0, a
// singular predicted covariance) and through a heading that wraps at pi:
// finite everywhere, g stays 0, and the smoothed heading is no further from
// the truth than the filter's on a noisy turn in place.
TEST(EkfTest, SmootherWithFrozenBiasAndWrappingHeading) {
  EkfOptions o;
  o.estimate_gyro_bias = false;
  PoseEkf ekf = MakeFilter(o);
  ekf.KeepHistory(true);
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  const double w = 0.5;  // rad/s: 12 s turn through +-pi twice
  std::vector<double> truth;
  for (int i = 1; i <= 1200; ++i) {
    const Time t = TimeFromSeconds(i * 0.01);
    const double psi = WrapAngle(w * i * 0.01);
    truth.push_back(psi);
    ekf.UpdateWheels(t, 0.0, w + 0.05 * n(rng));
    ekf.UpdateGyro(t, w + 0.005 * n(rng));
    ekf.UpdateYaw(t, WrapAngle(psi + 0.2 + 0.0087 * n(rng)));
  }
  const std::vector<PoseEkf::Estimate> smoothed = ekf.Smooth();
  const std::vector<PoseEkf::Estimate>& filtered = ekf.history();
  ASSERT_EQ(smoothed.size(), 1201u);
  double sq_f = 0.0, sq_s = 0.0;
  for (size_t k = 1; k < smoothed.size(); ++k) {
    const auto& s = smoothed[k].state;
    ASSERT_TRUE(s.allFinite()) << k;
    ASSERT_TRUE(smoothed[k].covariance.allFinite()) << k;
    EXPECT_EQ(s[PoseEkf::kGyroBias], 0.0);
    EXPECT_LE(std::abs(s[PoseEkf::kPsi]), M_PI);
    const double t_psi = truth[k - 1];
    if (k < filtered.size()) sq_f += std::pow(WrapAngle(filtered[k].state[PoseEkf::kPsi] - t_psi), 2);
    if (k < filtered.size()) sq_s += std::pow(WrapAngle(s[PoseEkf::kPsi] - t_psi), 2);
  }
  EXPECT_LT(sq_s, sq_f);
}

// The tilt's random walk grows with the distance driven (ekf.h): hand-worked
// variances from a zero covariance. At rest, 10 s add tilt_sigma^2 10 =
// 1e-7 rad^2; at 0.2 m/s (either way) they add (1e-8 + 0.00224^2 0.2) 10 =
// 1.01352e-5, the 1 mrad/sqrt(s) the filter had before.
TEST(EkfTest, TiltRandomWalkGrowsWithTheDistanceDriven) {
  const EkfOptions o;
  for (double v : {0.0, 0.2, -0.2}) {
    PoseEkf::State s = PoseEkf::State::Zero();
    s[PoseEkf::kV] = v;
    PoseEkf::State s_pred;
    PoseEkf::Covariance p_pred, f;
    PoseEkf::PredictState(o, s, PoseEkf::Covariance::Zero(), 10.0, &s_pred, &p_pred, &f);
    const double expected = v == 0.0 ? 1e-7 : 1.01352e-5;
    EXPECT_NEAR(p_pred(PoseEkf::kRoll, PoseEkf::kRoll), expected, 1e-12) << v;
    EXPECT_NEAR(p_pred(PoseEkf::kPitch, PoseEkf::kPitch), expected, 1e-12) << v;
  }
  EkfOptions bad;
  bad.tilt_sigma_per_metre = -1e-3;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  bad.tilt_sigma_per_metre = 0.0;  // a tilt that changes in time only
  EXPECT_TRUE(bad.IsValid(&error)) << error;
}

// A gap in the records (ekf.h, ResumeAfterGap; docs/models.md, "Gaps in the
// data"): the filter moves over 10 s without the motion model, so nothing
// of the 0.3 m/s before it is carried across (the model would invent 3 m);
// P grows by exactly the given bounds; the first IMU yaw after the gap sets
// the heading; and the smoother treats the two sides as separate drives:
// the estimates before the gap are bit for bit those of the first drive
// smoothed alone.
TEST(EkfTest, GapIsNotPredictedAcrossAndSplitsTheSmoother) {
  auto drive_before = [](PoseEkf* ekf) {
    for (int i = 1; i <= 100; ++i) {
      const Time t = TimeFromSeconds(i * 0.02);
      ekf->UpdateWheels(t, 0.3, 0.0);
      ekf->UpdateYaw(t, 0.5);  // IMU reference 0.5 rad from the world's: b = 0.5
    }
  };
  PoseEkf alone = MakeFilter();
  alone.KeepHistory(true);
  drive_before(&alone);
  PoseEkf ekf = MakeFilter();
  ekf.KeepHistory(true);
  drive_before(&ekf);
  const PoseEkf::State s0 = ekf.state();
  const PoseEkf::Covariance p0 = ekf.covariance();
  EXPECT_NEAR(s0[PoseEkf::kX], 0.6, 0.01);

  PoseEkf::GapReset reset;
  reset.position_sigma = 0.2;
  reset.heading_sigma = 0.3;
  ekf.ResumeAfterGap(TimeFromSeconds(12.0), reset);
  EXPECT_EQ(ekf.time(), TimeFromSeconds(12.0));
  EXPECT_EQ(ekf.state()[PoseEkf::kX], s0[PoseEkf::kX]);
  EXPECT_EQ(ekf.state()[PoseEkf::kY], s0[PoseEkf::kY]);
  EXPECT_EQ(ekf.state()[PoseEkf::kPsi], s0[PoseEkf::kPsi]);
  EXPECT_EQ(ekf.state()[PoseEkf::kV], 0.0);
  EXPECT_EQ(ekf.state()[PoseEkf::kW], 0.0);
  const PoseEkf::Covariance& p = ekf.covariance();
  EXPECT_NEAR(p(PoseEkf::kX, PoseEkf::kX), p0(PoseEkf::kX, PoseEkf::kX) + 0.04, 1e-15);
  EXPECT_NEAR(p(PoseEkf::kPsi, PoseEkf::kPsi), p0(PoseEkf::kPsi, PoseEkf::kPsi) + 0.09, 1e-15);
  EXPECT_EQ(p(PoseEkf::kV, PoseEkf::kX), 0.0);
  EXPECT_EQ(p(PoseEkf::kV, PoseEkf::kV), reset.velocity_variance);

  // The robot turned by 0.25 rad in the gap and stands still: the first
  // yaw reading (b known) sets psi to within a few % of the turn's size.
  ekf.UpdateWheels(TimeFromSeconds(12.0), 0.0, 0.0);
  ekf.UpdateYaw(TimeFromSeconds(12.0), 0.5 + s0[PoseEkf::kPsi] + 0.25);
  EXPECT_NEAR(WrapAngle(ekf.state()[PoseEkf::kPsi] - s0[PoseEkf::kPsi]), 0.25, 0.01);
  for (int i = 1; i <= 100; ++i) {
    const Time t = TimeFromSeconds(12.0 + i * 0.02);
    ekf.UpdateWheels(t, 0.0, 0.0);
    ekf.UpdateYaw(t, 0.5 + s0[PoseEkf::kPsi] + 0.25);
  }
  EXPECT_NEAR(ekf.state()[PoseEkf::kX], s0[PoseEkf::kX], 0.005) << "no motion invented";

  const std::vector<PoseEkf::Estimate> with_gap = ekf.Smooth();
  const std::vector<PoseEkf::Estimate> first = alone.Smooth();
  ASSERT_GT(with_gap.size(), first.size());
  EXPECT_TRUE(with_gap[first.size()].after_gap);
  EXPECT_EQ(with_gap[first.size()].time, TimeFromSeconds(12.0));
  for (size_t k = 0; k < first.size(); ++k) {
    ASSERT_EQ(with_gap[k].time, first[k].time);
    ASSERT_FALSE(with_gap[k].after_gap);
    ASSERT_EQ(with_gap[k].state, first[k].state) << "estimate " << k;
  }
  EXPECT_EQ(with_gap[first.size() - 1].state, s0) << "the segment's end is its own smoothed estimate";
}

TEST(EkfTest, OptionsValidation) {
  EkfOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.gyro_sigma = 0.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_FALSE(error.empty());
}

}  // namespace
}  // namespace sweepscan
