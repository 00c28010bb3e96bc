#include "core/geometry/transform.h"

#include <gtest/gtest.h>

#include <random>

namespace sweepscan {
namespace {

TEST(TransformTest, WrapAngleKeepsRange) {
  EXPECT_NEAR(WrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(-3 * M_PI + 0.1), -M_PI + 0.1, 1e-12);
  EXPECT_NEAR(WrapAngle(0.5), 0.5, 1e-15);
  EXPECT_NEAR(WrapAngle(2 * M_PI + 0.25), 0.25, 1e-12);
}

TEST(TransformTest, ChainReadsRight) {
  // body 2 m along world x, turned 90 deg left; a point 1 m ahead of the body
  // is at (2, 1) in the world.
  const Rigid3d world_from_body = Rigid3d::FromPose(2, 0, 0, 0, 0, M_PI / 2);
  const Rigid3d body_from_sensor = Rigid3d::Translation({1, 0, 0.5});
  const Eigen::Vector3d p = (world_from_body * body_from_sensor) * Eigen::Vector3d::Zero();
  EXPECT_NEAR(p.x(), 2.0, 1e-12);
  EXPECT_NEAR(p.y(), 1.0, 1e-12);
  EXPECT_NEAR(p.z(), 0.5, 1e-12);
}

TEST(TransformTest, InverseComposesToIdentity) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int i = 0; i < 50; ++i) {
    const Rigid3d t = Rigid3d::FromPose(u(rng), u(rng), u(rng), u(rng), 0.4 * u(rng), u(rng));
    const Rigid3d id = t * t.inverse();
    EXPECT_LT(id.translation().norm(), 1e-12);
    EXPECT_NEAR(std::abs(id.rotation().w()), 1.0, 1e-12);
  }
}

TEST(TransformTest, RollPitchYawRoundTrip) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d rpy(u(rng), u(rng), 2 * u(rng));
    const Eigen::Vector3d back =
        RollPitchYawFromQuaternion(QuaternionFromRollPitchYaw(rpy[0], rpy[1], rpy[2]));
    EXPECT_NEAR(back[0], rpy[0], 1e-9);
    EXPECT_NEAR(back[1], rpy[1], 1e-9);
    EXPECT_NEAR(WrapAngle(back[2] - rpy[2]), 0.0, 1e-9);
  }
}

TEST(TransformTest, ZyxOrderMatchesMatrices) {
  const double r = 0.1, p = -0.2, y = 0.3;
  const Eigen::Matrix3d expected = RotZ(y) * RotY(p) * RotX(r);
  EXPECT_TRUE(QuaternionFromRollPitchYaw(r, p, y).toRotationMatrix().isApprox(expected, 1e-12));
}

TEST(TransformTest, InterpolateHalfway) {
  const Rigid3d a = Rigid3d::FromPose(0, 0, 0, 0, 0, 0);
  const Rigid3d b = Rigid3d::FromPose(2, 4, 0, 0, 0, 1.0);
  const Rigid3d m = Interpolate(a, b, 0.5);
  EXPECT_NEAR(m.translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(m.translation().y(), 2.0, 1e-12);
  EXPECT_NEAR(YawFromQuaternion(m.rotation()), 0.5, 1e-12);
}

}  // namespace
}  // namespace sweepscan
