#include "core/robot/robot_model.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

TEST(RobotModelTest, LidarPointIsEquationOne) {
  // theta from the vertical: 0 straight up, pi/2 towards +y (robot left).
  EXPECT_TRUE(LidarPoint(2.0, 0.0).isApprox(Eigen::Vector3d(0, 0, 2), 1e-12));
  EXPECT_TRUE(LidarPoint(2.0, M_PI / 2).isApprox(Eigen::Vector3d(0, 2, 0), 1e-12));
  EXPECT_TRUE(LidarPoint(1.0, M_PI).isApprox(Eigen::Vector3d(0, 0, -1), 1e-12));
  const Eigen::Vector3d p = LidarPoint(3.0, M_PI / 6);
  EXPECT_NEAR(p.y(), 1.5, 1e-12);
  EXPECT_NEAR(p.z(), 3.0 * std::sqrt(3.0) / 2, 1e-12);
}

TEST(RobotModelTest, AngleConventionRoundTrip) {
  LidarAngleConvention c;
  EXPECT_NEAR(c.ThetaFromX4Degrees(90.0), M_PI / 2, 1e-12);
  c.sign = -1;
  c.offset_rad = 0.3;
  for (double deg : {0.0, 10.0, 179.5, 359.0}) {
    EXPECT_NEAR(c.X4DegreesFromTheta(c.ThetaFromX4Degrees(deg)), deg, 1e-9);
  }
}

TEST(RobotModelTest, MountingRotationIsZyx) {
  const MountingError e{-0.0058, 0.0126, 0.0355};
  const Eigen::Matrix3d expected = RotZ(e.alpha) * RotY(e.beta) * RotX(e.gamma);
  EXPECT_TRUE(MountingRotation(e).toRotationMatrix().isApprox(expected, 1e-14));
}

TEST(RobotModelTest, GammaTiltsTheScanWithinItsPlane) {
  // A pure gamma (about x) keeps the scan in the body y-z plane.
  RobotGeometry g;
  const Rigid3d t = BodyFromLidar(g, {0, 0, 0.05});
  const Eigen::Vector3d p = t * LidarPoint(2.0, 0.7);
  EXPECT_NEAR(p.x(), g.lidar_offset_x_m, 1e-12);
  // alpha or beta move it out of that plane.
  EXPECT_GT(std::abs((BodyFromLidar(g, {0.05, 0, 0}) * LidarPoint(2.0, 1.2)).x() - g.lidar_offset_x_m), 0.05);
  EXPECT_GT(std::abs((BodyFromLidar(g, {0, 0.05, 0}) * LidarPoint(2.0, 0.2)).x() - g.lidar_offset_x_m), 0.05);
}

TEST(RobotModelTest, LaserBodyWorldChain) {
  // Hand-checked: robot at (1, 2) facing +y; lidar 0.1 ahead, 0.4 up; a
  // return 1 m to the robot's left (theta = 90 deg) lands at (0, 2.1, 0.4).
  RobotGeometry g;
  const Rigid3d world_from_body = Rigid3d::FromPose(1, 2, 0, 0, 0, M_PI / 2);
  const Eigen::Vector3d p = world_from_body * BodyFromLidar(g, {}) * LidarPoint(1.0, M_PI / 2);
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), 2.1, 1e-12);
  EXPECT_NEAR(p.z(), 0.4, 1e-12);
}

TEST(RobotModelTest, WheelsAndTwist) {
  const Twist2d t = TwistFromWheels(0.1, 0.3, 0.15);
  EXPECT_NEAR(t.v, 0.2, 1e-12);
  EXPECT_NEAR(t.w, 0.2 / 0.3, 1e-12);
  double l, r;
  WheelsFromTwist(t, 0.15, &l, &r);
  EXPECT_NEAR(l, 0.1, 1e-12);
  EXPECT_NEAR(r, 0.3, 1e-12);
}

TEST(RobotModelTest, GeometryValidation) {
  RobotGeometry g;
  std::string error;
  EXPECT_TRUE(g.IsValid(&error));
  g.wheel_distance_m = -0.1;
  EXPECT_FALSE(g.IsValid(&error));
  g.wheel_distance_m = NAN;
  EXPECT_FALSE(g.IsValid(&error));
}

}  // namespace
}  // namespace sweepscan
