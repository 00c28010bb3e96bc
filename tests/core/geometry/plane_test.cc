#include "core/geometry/plane.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace sweepscan {
namespace {

TEST(PlaneTest, RecoversNoisyPlane) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-2, 2);
  std::normal_distribution<double> n(0, 0.003);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
  const double d = -1.5;
  // Basis of the plane.
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 5000; ++i) pts.push_back(-d * normal + u(rng) * e1 + u(rng) * e2 + n(rng) * normal);
  Plane p;
  ASSERT_TRUE(FitPlane(pts, &p));
  EXPECT_LT(std::acos(std::abs(p.normal.dot(normal))), 2e-4);
  EXPECT_NEAR(std::abs(p.d), 1.5, 1e-3);
  EXPECT_NEAR(p.rms, 0.003, 3e-4);
}

TEST(PlaneTest, RefusesDegenerateInput) {
  Plane p;
  EXPECT_FALSE(FitPlane({{0, 0, 0}, {1, 0, 0}}, &p));
  EXPECT_FALSE(FitPlane({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}, &p));  // collinear
}

// The streamed fit is the two-pass one, far from the origin too (a wall
// 5 km out: plain sums of p and p p^T would cancel there), and refuses
// what FitPlane refuses.
TEST(PlaneTest, PlaneFitOfPointsOneAtATimeIsFitPlanes) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3, 3);
  std::normal_distribution<double> n(0, 0.004);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, 1.0, -0.05).normalized();
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  for (const double far : {0.0, 5000.0}) {
    const Eigen::Vector3d origin(far, -far, 2.0);
    std::vector<Eigen::Vector3d> pts;
    PlaneFit fit;
    for (int i = 0; i < 20000; ++i) {
      pts.push_back(origin + u(rng) * e1 + u(rng) * e2 + n(rng) * normal);
      fit.Add(pts.back());
    }
    Plane whole, streamed;
    ASSERT_TRUE(FitPlane(pts, &whole));
    ASSERT_TRUE(fit.Fit(&streamed));
    EXPECT_EQ(streamed.count, 20000u);
    EXPECT_LT((streamed.centroid - whole.centroid).norm(), 1e-9 * (1 + far)) << far;
    EXPECT_NEAR(std::abs(streamed.normal.dot(whole.normal)), 1.0, 1e-12) << far;
    EXPECT_NEAR(streamed.rms, whole.rms, 1e-9) << far;
    EXPECT_NEAR(streamed.rms, 0.004, 3e-4) << far;
  }
  PlaneFit two, line;
  two.Add({0, 0, 0});
  two.Add({1, 0, 0});
  for (int i = 0; i < 4; ++i) line.Add({static_cast<double>(i), 0, 0});
  Plane p;
  EXPECT_FALSE(two.Fit(&p));
  EXPECT_FALSE(line.Fit(&p));
}

TEST(PlaneTest, DistanceBetweenParallelPlanes) {
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 10; ++i) {
    for (int k = 0; k < 10; ++k) {
      a.emplace_back(i, k, 0.0);
      b.emplace_back(i, k, 2.5);
    }
  }
  Plane pa, pb;
  ASSERT_TRUE(FitPlane(a, &pa));
  ASSERT_TRUE(FitPlane(b, &pb));
  EXPECT_NEAR(DistanceBetweenPlanes(pa, pb), 2.5, 1e-12);
  EXPECT_NEAR(AngleBetweenPlanes(pa, pb), 0.0, 1e-12);
}

}  // namespace
}  // namespace sweepscan
