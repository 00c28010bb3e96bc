// CombineAngleEstimates and WithSigmas (core/calibration/combine.h) against
// the closed form and against drawn estimates whose truth is known.
#include "core/calibration/combine.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>

namespace sweepscan {
namespace {

Eigen::Vector3d Vec(const MountingError& m) { return {m.alpha, m.beta, m.gamma}; }
MountingError Angles(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

// The board's covariance as the refined corners report it on the lab
// diamond (mrad^2 scaled to rad^2): alpha and beta 3 mrad each, correlated
// 0.88, gamma 0.6 mrad; the room's planes': 0.3, 0.2, 0.1 mrad, independent.
Eigen::Matrix3d BoardCovariance() {
  Eigen::Matrix3d c;
  c << 9.0, 0.88 * 9.0, 0.0, 0.88 * 9.0, 9.0, 0.0, 0.0, 0.0, 0.36;
  return c * 1e-6;
}
Eigen::Matrix3d PlanesCovariance() {
  return Eigen::Vector3d(0.09, 0.04, 0.01).asDiagonal().toDenseMatrix() * 1e-6;
}

TEST(CombineAngleEstimatesTest, IsTheInformationWeightedMean) {
  // Isotropic 4 and 1: x = (a / 4 + b) / (1 / 4 + 1) = 0.2 a + 0.8 b, C = 0.8.
  const Eigen::Matrix3d a_cov = 4e-6 * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d b_cov = 1e-6 * Eigen::Matrix3d::Identity();
  const MountingError a{0.010, -0.020, 0.030}, b{0.011, -0.019, 0.0305};
  const CombinedAngles c =
      CombineAngleEstimates(a, a_cov, b, b_cov, Eigen::Matrix3d::Zero());
  ASSERT_TRUE(c.combined);
  const Eigen::Vector3d want = 0.2 * Vec(a) + 0.8 * Vec(b);
  EXPECT_LT((Vec(c.angles) - want).norm(), 1e-12);
  EXPECT_LT((c.covariance_rad2 - 0.8e-6 * Eigen::Matrix3d::Identity()).norm(), 1e-15);
  EXPECT_NEAR(c.sigma_rad[0], std::sqrt(0.8e-6), 1e-12);
  // d^2 = |a - b|^2 / 5e-6.
  EXPECT_NEAR(c.chi2, (Vec(a) - Vec(b)).squaredNorm() / 5e-6, 1e-9);
}

// Estimates drawn about a known truth with the two covariances: the
// combination's errors scatter as its covariance says (within the sampling
// error of 20 000 draws), far less than the board's along alpha + beta, and
// d^2 exceeds the bound about one time in a thousand.
TEST(CombineAngleEstimatesTest, DrawnEstimatesScatterAsTheCombinedCovarianceSays) {
  const Eigen::Matrix3d a_cov = BoardCovariance(), b_cov = PlanesCovariance();
  const Eigen::Matrix3d la = a_cov.llt().matrixL(), lb = b_cov.llt().matrixL();
  const Eigen::Vector3d truth(0.02, -0.015, 0.03);
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  auto draw = [&] { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)); };
  const int kDraws = 20000;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  double board_sum = 0.0, combined_sum = 0.0;
  int over = 0;
  Eigen::Matrix3d want;
  for (int i = 0; i < kDraws; ++i) {
    const Eigen::Vector3d a = truth + la * draw(), b = truth + lb * draw();
    const CombinedAngles c =
        CombineAngleEstimates(Angles(a), a_cov, Angles(b), b_cov, Eigen::Matrix3d::Zero(), 1e9);
    ASSERT_TRUE(c.combined);
    want = c.covariance_rad2;
    const Eigen::Vector3d e = Vec(c.angles) - truth;
    scatter += e * e.transpose();
    board_sum += std::pow((a[0] - truth[0] + a[1] - truth[1]) / std::sqrt(2.0), 2);
    combined_sum += std::pow((e[0] + e[1]) / std::sqrt(2.0), 2);
    over += c.chi2 > kMaxCombineChi2;
  }
  scatter /= kDraws;
  for (int i = 0; i < 3; ++i) {
    // 20 000 draws: a variance's relative sampling error is sqrt(2 / n) = 1 %.
    EXPECT_NEAR(scatter(i, i) / want(i, i), 1.0, 0.05) << i;
  }
  const Eigen::Matrix3d expected = (a_cov.inverse() + b_cov.inverse()).inverse();
  EXPECT_LT((want - expected).norm(), 1e-6 * expected.norm());
  // Along alpha + beta the board alone errs sqrt(9 (1 + 0.88)) = 4.1 mrad.
  EXPECT_NEAR(std::sqrt(board_sum / kDraws), 4.11e-3, 0.1e-3);
  EXPECT_LT(std::sqrt(combined_sum / kDraws), 0.3e-3);
  // p = 0.001 of chi^2 (3 dof): 20 expected, Poisson sd 4.5.
  EXPECT_GT(over, 5);
  EXPECT_LT(over, 40);
}

TEST(CombineAngleEstimatesTest, DisagreementBeyondChanceIsNotCombined) {
  const Eigen::Matrix3d a_cov = BoardCovariance(), b_cov = PlanesCovariance();
  const MountingError a{0.010, 0.010, 0.030};
  // gamma 5 mrad apart: 5 / sqrt(0.36 + 0.01) = 8.2 sigma, d^2 = 67.6.
  const MountingError b{0.010, 0.010, 0.035};
  CombinedAngles c = CombineAngleEstimates(a, a_cov, b, b_cov, Eigen::Matrix3d::Zero());
  EXPECT_FALSE(c.combined);
  EXPECT_NEAR(c.chi2, 25.0 / 0.37, 1e-6);
  EXPECT_EQ(Vec(c.angles), Vec(a));
  EXPECT_EQ(c.covariance_rad2, a_cov);
  // The same difference, with errors outside both measurements allowed for
  // (the poses', 2 mrad of gamma each way): within chance, combined.
  Eigen::Matrix3d unmodelled = Eigen::Matrix3d::Zero();
  unmodelled(2, 2) = 8e-6;
  c = CombineAngleEstimates(a, a_cov, b, b_cov, unmodelled);
  EXPECT_TRUE(c.combined);
  EXPECT_NEAR(c.chi2, 25.0 / 8.37, 1e-6);
  EXPECT_GT(c.angles.gamma, 0.0345);  // the planes' gamma, 36 times the board's weight
}

TEST(CombineAngleEstimatesTest, AnUnusableCovarianceIsNotCombined) {
  const MountingError a{0.01, 0.02, 0.03}, b{0.011, 0.021, 0.031};
  Eigen::Matrix3d singular = PlanesCovariance();
  singular(2, 2) = 0.0;  // unknown (CalibrationSummary::covariance_rad2 zero)
  for (const Eigen::Matrix3d& bad :
       {Eigen::Matrix3d(Eigen::Matrix3d::Zero()), singular,
        Eigen::Matrix3d(Eigen::Matrix3d::Constant(std::nan("")))}) {
    const CombinedAngles c = CombineAngleEstimates(a, BoardCovariance(), b, bad,
                                                   Eigen::Matrix3d::Zero());
    EXPECT_FALSE(c.combined);
    EXPECT_EQ(Vec(c.angles), Vec(a));
  }
}

TEST(WithSigmasTest, KeepsTheShapesCorrelationsAndTheGivenSigmas) {
  const Eigen::Matrix3d out = WithSigmas(BoardCovariance() * 4.0, Eigen::Vector3d(1.0, 2.0, 0.5));
  EXPECT_DOUBLE_EQ(out(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(out(1, 1), 4.0);
  EXPECT_DOUBLE_EQ(out(2, 2), 0.25);
  EXPECT_NEAR(out(0, 1), 0.88 * 2.0, 1e-12);
  EXPECT_NEAR(out(1, 0), 0.88 * 2.0, 1e-12);
  EXPECT_EQ(out(0, 2), 0.0);
  // A shape with an angle unknown gives that angle no correlation.
  Eigen::Matrix3d shape = BoardCovariance();
  shape(1, 1) = 0.0;
  const Eigen::Matrix3d lone = WithSigmas(shape, Eigen::Vector3d(1.0, 2.0, 0.5));
  EXPECT_EQ(lone(0, 1), 0.0);
  EXPECT_DOUBLE_EQ(lone(1, 1), 4.0);
}

}  // namespace
}  // namespace sweepscan
