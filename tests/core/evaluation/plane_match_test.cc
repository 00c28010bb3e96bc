// Before and after a calibration the same room gives the same surfaces in
// another order (the planes are listed by size, and straightening a wall
// changes its inlier count): MatchPlanes pairs them by place.
#include "core/evaluation/plane_match.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace sweepscan {
namespace {

EvaluatedPlane Surface(const std::string& kind, const Eigen::Vector3d& normal,
                       const Eigen::Vector3d& centroid) {
  EvaluatedPlane p;
  p.kind = kind;
  p.plane.normal = normal.normalized();
  p.plane.centroid = centroid;
  p.plane.d = -p.plane.normal.dot(centroid);
  return p;
}

// A 5 x 4 x 2.5 m room: floor, ceiling, four walls (0 .. 5), and a
// cupboard's face 0.2 m in front of the wall x = 5 (6).
CloudEvaluation Room(double turn_rad, double shift_m) {
  const Eigen::Vector3d tilt(std::sin(turn_rad), 0.0, std::cos(turn_rad));
  CloudEvaluation e;
  e.planes = {Surface("floor", tilt, {2.5, 2.0, shift_m}),
              Surface("ceiling", tilt, {2.5, 2.0, 2.5 + shift_m}),
              Surface("wall", {1, 0, turn_rad}, {shift_m, 2.0, 1.2}),
              Surface("wall", {1, 0, -turn_rad}, {5.0 + shift_m, 2.0, 1.2}),
              Surface("wall", {0, 1, turn_rad}, {2.5, shift_m, 1.2}),
              Surface("wall", {0, -1, turn_rad}, {2.5, 4.0 + shift_m, 1.2}),
              Surface("wall", {1, 0, 0}, {4.8 + shift_m, 1.0, 0.5})};
  return e;
}

TEST(PlaneMatchTest, TheSameSurfacesInAnotherOrderAreFound) {
  const CloudEvaluation now = Room(0.0, 0.0);
  // Before: turned by 20 mrad and 1 cm off, in another order, the
  // cupboard not found, and a plane now's room has not (a table top).
  CloudEvaluation before = Room(0.02, 0.01);
  const std::vector<int> order = {3, 0, 5, 1, 2, 4};  // before's row k is now's plane order[k]
  std::vector<EvaluatedPlane> shuffled;
  for (int k : order) shuffled.push_back(before.planes[static_cast<size_t>(k)]);
  shuffled.push_back(Surface("other", {0, 0, 1}, {1.0, 1.0, 0.75}));
  before.planes = shuffled;

  const std::vector<int> match = MatchPlanes(now, before);
  ASSERT_EQ(match.size(), now.planes.size());
  for (size_t k = 0; k < order.size(); ++k) {
    EXPECT_EQ(match[static_cast<size_t>(order[k])], static_cast<int>(k))
        << "now's plane " << order[k];
  }
  EXPECT_EQ(match[6], -1);  // the cupboard: 0.2 m from the wall, but that wall is taken

  // Rooms' dimensions follow their planes.
  CloudEvaluation now_d = now;
  now_d.dimensions = {{0, 1, "vertical", 2.5, 0.0}, {2, 3, "horizontal", 5.0, 0.0}};
  CloudEvaluation before_d = before;
  before_d.dimensions = {{4, 0, "horizontal", 5.01, 0.0}, {1, 3, "vertical", 2.49, 0.0}};
  EXPECT_EQ(MatchDimensions(now_d, before_d, match), (std::vector<int>{1, 0}));
}

TEST(PlaneMatchTest, ADifferentKindOrAFarPlaneIsNotTheSameSurface) {
  CloudEvaluation now;
  now.planes = {Surface("wall", {1, 0, 0}, {0, 0, 1})};
  CloudEvaluation before;
  before.planes = {Surface("other", {1, 0, 0}, {0, 0, 1}),    // another kind
                   Surface("wall", {1, 0, 0}, {0.5, 0, 1}),   // 0.5 m away
                   Surface("wall", {1, 0.3, 0}, {0, 0, 1})};  // turned 17 degrees
  EXPECT_EQ(MatchPlanes(now, before), (std::vector<int>{-1}));
  // A wall 0.25 m away is within the offset allowed, a normal of the
  // opposite sign is the same plane.
  before.planes.push_back(Surface("wall", {-1, 0, 0}, {0.25, 3.0, 2.0}));
  EXPECT_EQ(MatchPlanes(now, before), (std::vector<int>{3}));
}

}  // namespace
}  // namespace sweepscan
