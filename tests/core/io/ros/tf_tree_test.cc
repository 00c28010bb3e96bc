#include "core/io/ros/tf_tree.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sweepscan::io {
namespace {

RosTransform Edge(const std::string& parent, const std::string& child, std::array<double, 3> t,
                  std::array<double, 4> q = {0, 0, 0, 1}) {
  RosTransform x;
  x.header.frame_id = parent;
  x.child_frame_id = child;
  x.translation = t;
  x.rotation = q;
  return x;
}

std::array<double, 4> AboutZ(double a) { return {0, 0, std::sin(a / 2), std::cos(a / 2)}; }

TEST(TfTreeTest, ChainsEdgesBothWays) {
  TfTree tf;
  // base -> mast: 1 m up, turned 90 deg about z; mast -> laser: 1 m along mast's x.
  tf.Add({{Edge("base", "mast", {0, 0, 1}, AboutZ(M_PI / 2)), Edge("mast", "laser", {1, 0, 0})}}, true);
  Rigid3d base_from_laser;
  std::string path;
  bool moving = true;
  ASSERT_TRUE(tf.Resolve("base", "laser", &base_from_laser, &path, &moving).ok());
  EXPECT_EQ(path, "base -> mast -> laser");
  EXPECT_FALSE(moving);
  // mast's x is base's y: the laser sits at (0, 1, 1).
  EXPECT_TRUE(base_from_laser.translation().isApprox(Eigen::Vector3d(0, 1, 1), 1e-12));
  // Backwards: laser_from_base is the inverse.
  Rigid3d laser_from_base;
  ASSERT_TRUE(tf.Resolve("laser", "base", &laser_from_base, &path, &moving).ok());
  EXPECT_TRUE((laser_from_base * base_from_laser).translation().norm() < 1e-12);
  EXPECT_EQ(path, "laser -> mast -> base");
}

TEST(TfTreeTest, LeadingSlashesAreIgnored) {
  TfTree tf;
  tf.Add({{Edge("/base_link", "/laser", {0.1, 0, 0.2})}}, true);
  Rigid3d x;
  std::string path;
  bool moving;
  ASSERT_TRUE(tf.Resolve("base_link", "laser", &x, &path, &moving).ok());
  EXPECT_TRUE(tf.HasFrame("/laser"));
  EXPECT_TRUE(tf.HasFrame("base_link"));
}

TEST(TfTreeTest, MissingPathNamesTheFramesKnown) {
  TfTree tf;
  tf.Add({{Edge("odom", "base_link", {0, 0, 0})}}, false);
  Rigid3d x;
  std::string path;
  bool moving;
  const Status s = tf.Resolve("base_link", "laser", &x, &path, &moving);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "tf has no path from base_link to laser (frames in tf: base_link, odom)");
}

TEST(TfTreeTest, AMovingEdgeIsFlaggedAndAStaticOneWins) {
  TfTree tf;
  tf.Add({{Edge("base", "laser", {0, 0, 0.5})}}, false);
  tf.Add({{Edge("base", "laser", {0, 0, 0.6})}}, false);  // moved 10 cm
  Rigid3d x;
  std::string path;
  bool moving = false;
  ASSERT_TRUE(tf.Resolve("base", "laser", &x, &path, &moving).ok());
  EXPECT_TRUE(moving);
  EXPECT_NEAR(x.translation().z(), 0.5, 1e-12);  // the first kept
  tf.Add({{Edge("base", "laser", {0, 0, 0.7})}}, true);
  ASSERT_TRUE(tf.Resolve("base", "laser", &x, &path, &moving).ok());
  EXPECT_FALSE(moving);
  EXPECT_NEAR(x.translation().z(), 0.7, 1e-12);
}

TEST(TfTreeTest, SameFrameIsIdentityAndZeroQuaternionIsIdentity) {
  TfTree tf;
  Rigid3d x = Rigid3d::FromPose(1, 2, 3, 0, 0, 0);
  std::string path;
  bool moving;
  ASSERT_TRUE(tf.Resolve("base", "/base", &x, &path, &moving).ok());
  EXPECT_EQ(x.translation().norm(), 0.0);
  const Rigid3d r = RigidFromRos({1, 2, 3}, {0, 0, 0, 0});
  EXPECT_EQ(r.rotation().w(), 1.0);
}

}  // namespace
}  // namespace sweepscan::io
