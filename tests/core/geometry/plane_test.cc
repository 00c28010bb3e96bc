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
