#include "core/pose/ekf.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

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
