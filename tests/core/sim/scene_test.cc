#include "core/sim/scene.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sweepscan::sim {
namespace {

TEST(SceneTest, RoomSeenFromInside) {
  const Scene s({Box{"room", {5, 2.5, 1.25}, {10, 5, 2.5}, 0.0, true, 0.0}});
  RayHit hit;
  ASSERT_TRUE(s.Cast({2, 1, 1}, {0, 0, 1}, 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.range, 1.5, 1e-12);
  EXPECT_EQ(hit.face, 5);
  EXPECT_TRUE(hit.normal.isApprox(Eigen::Vector3d(0, 0, -1)));
  const Eigen::Vector3d d = Eigen::Vector3d(1, 1, 0).normalized();
  ASSERT_TRUE(s.Cast({2, 1, 1}, d, 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.range, 4 * std::sqrt(2.0), 1e-12);  // hits y = 5 at x = 6
  EXPECT_EQ(hit.face, 3);
  EXPECT_FALSE(s.Cast({2, 1, 1}, {-1, 0, 0}, 0.0, 1.5, &hit));  // wall at 2 m > max range
}

TEST(SceneTest, SolidBoxInFrontOfWall) {
  Scene s({Box{"room", {5, 2.5, 1.25}, {10, 5, 2.5}, 0.0, true, 0.0}});
  s.Add(Box{"crate", {5, 1, 0.5}, {1, 1, 1}, 0.0, false, 0.0});
  RayHit hit;
  ASSERT_TRUE(s.Cast({5, 3, 0.5}, {0, -1, 0}, 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.range, 1.5, 1e-12);
  EXPECT_EQ(s.boxes()[hit.primitive].label, "crate");
  EXPECT_EQ(hit.face, 3);
  ASSERT_TRUE(s.Cast({5, 3, 1.5}, {0, -1, 0}, 0.0, 10.0, &hit));  // over the crate
  EXPECT_NEAR(hit.range, 3.0, 1e-12);
}

TEST(SceneTest, RotatedBox) {
  // A 2 x 2 x 2 cube at the origin turned 45 deg: its corner points along +x
  // at sqrt(2).
  const Scene s({Box{"cube", {0, 0, 0}, {2, 2, 2}, M_PI / 4, false, 0.0}});
  RayHit hit;
  ASSERT_TRUE(s.Cast({5, 0, 0.5}, {-1, 0, 0}, 0.0, 10.0, &hit));
  EXPECT_NEAR(hit.range, 5 - std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(s.DistanceToSurface({3, 0, 0}), 3 - std::sqrt(2.0), 1e-9);
}

TEST(SceneTest, DistanceToSurface) {
  const Scene s({Box{"room", {5, 2.5, 1.25}, {10, 5, 2.5}, 0.0, true, 0.0}});
  EXPECT_NEAR(s.DistanceToSurface({5, 2.5, 1.0}), 1.0, 1e-12);   // floor is nearest
  EXPECT_NEAR(s.DistanceToSurface({0.3, 2.5, 1.25}), 0.3, 1e-12);
  EXPECT_NEAR(s.DistanceToSurface({-0.1, 2.5, 1.25}), 0.1, 1e-12);  // just outside a wall
}

TEST(SceneTest, PresetsAreValidAndLabHasTarget) {
  std::string error;
  EXPECT_TRUE(LabScene().IsValid(&error)) << error;
  EXPECT_TRUE(StairwellScene().IsValid(&error)) << error;
  EXPECT_GE(LabScene().Find("target"), 0);
  Scene bad({Box{"flat", {0, 0, 0}, {1, 0, 1}, 0.0, false, 0.0}});
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("flat"), std::string::npos);
}

// The diamond target: a board turned 45 deg about its own y axis. Its
// half-width at height dz above its centre is 0.3 sqrt(2) - |dz|.
TEST(SceneTest, PitchTurnsABoardIntoADiamond) {
  const Scene s = LabScene(LabTarget::kDiamond);
  const int target = s.Find("target");
  ASSERT_GE(target, 0);
  const double half = 0.3 * std::sqrt(2.0);
  RayHit hit;
  const Eigen::Vector3d toward_wall(0, -1, 0);
  // At the centre height the board spans x = 5 +- half.
  ASSERT_TRUE(s.Cast({5.0 + half - 0.005, 2.0, 1.35}, toward_wall, 0.0, 10.0, &hit));
  EXPECT_EQ(hit.primitive, target);
  EXPECT_NEAR(hit.range, 2.0 - 0.16, 1e-9);
  EXPECT_NEAR(hit.normal.y(), 1.0, 1e-12);
  ASSERT_TRUE(s.Cast({5.0 + half + 0.005, 2.0, 1.35}, toward_wall, 0.0, 10.0, &hit));
  EXPECT_NE(hit.primitive, target);
  // 0.3 m higher only +-(half - 0.3) remains.
  ASSERT_TRUE(s.Cast({5.0 - (half - 0.3) + 0.005, 2.0, 1.65}, toward_wall, 0.0, 10.0, &hit));
  EXPECT_EQ(hit.primitive, target);
  ASSERT_TRUE(s.Cast({5.0 - (half - 0.3) - 0.005, 2.0, 1.65}, toward_wall, 0.0, 10.0, &hit));
  EXPECT_NE(hit.primitive, target);
  // The top corner is on the surface; 5 mm thick board.
  EXPECT_NEAR(s.DistanceToSurface({5.0, 0.16, 1.35 + half}), 0.0, 1e-9);
  EXPECT_NEAR(s.boxes()[target].size.y(), 0.005, 1e-12);
  std::string error;
  EXPECT_TRUE(s.IsValid(&error)) << error;
  Scene bad({Box{"nan", {0, 0, 0}, {1, 1, 1}, 0.0, false, 0.0, std::nan("")}});
  EXPECT_FALSE(bad.IsValid(&error));
}

TEST(SceneTest, StairsRise) {
  const Scene s = StairwellScene();
  RayHit hit;
  // Looking down onto the 5th step (x in [4.12, 4.40]) from 3 m height.
  ASSERT_TRUE(s.Cast({4.2, 1.5, 3.0}, {0, 0, -1}, 0.0, 10.0, &hit));
  EXPECT_NEAR(3.0 - hit.range, 5 * 0.17, 1e-9);
}

}  // namespace
}  // namespace sweepscan::sim
