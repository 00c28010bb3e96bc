// Line extraction on simulated scans with known truth.
#include "core/sfm/line_extraction.h"

#include <gtest/gtest.h>

#include <random>

#include "core/geometry/transform.h"
#include "core/sim/scene.h"

namespace sweepscan::sfm {
namespace {

TEST(LineExtractionTest, TotalLeastSquaresOfExactPoints) {
  // Points on y = 0.5 x + 1 (normal (-0.5, 1)/|.|, hand-checked).
  std::vector<Eigen::Vector2d> pts;
  std::vector<int> idx;
  for (int i = 0; i < 11; ++i) {
    pts.emplace_back(0.1 * i, 0.05 * i + 1.0);
    idx.push_back(i);
  }
  const ScanLine l = FitScanLine(pts, idx);
  EXPECT_NEAR(std::abs(l.direction.dot(Eigen::Vector2d(2, 1).normalized())), 1.0, 1e-12);
  EXPECT_NEAR(l.rms, 0.0, 1e-9);
  EXPECT_NEAR(l.length, std::hypot(1.0, 0.5), 1e-12);
  EXPECT_NEAR(l.centroid.x(), 0.5, 1e-12);
  EXPECT_NEAR(l.centroid.y(), 1.25, 1e-12);
}

// A 2D lidar at (1, 0.8) in a 4 x 3 m rectangle with a 0.4 m box in one
// corner: 720 samples, 5 mm noise, 1 % dropouts. The four walls come out as
// lines within 1.5 cm and 1 deg of the truth; the box's 0.4 m faces are
// shorter than 0.5 m and are left out.
TEST(LineExtractionTest, RectangularRoomScan) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector2d origin(1.0, 0.8);
  std::vector<Eigen::Vector2d> pts;
  for (int k = 0; k < 720; ++k) {
    const double a = 2 * M_PI * k / 720;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double t = 1e9;
    // Walls x = 0, x = 4, y = 0, y = 3.
    if (d.x() < 0) t = std::min(t, -origin.x() / d.x());
    if (d.x() > 0) t = std::min(t, (4 - origin.x()) / d.x());
    if (d.y() < 0) t = std::min(t, -origin.y() / d.y());
    if (d.y() > 0) t = std::min(t, (3 - origin.y()) / d.y());
    // Box [3.6, 4] x [2.6, 3] (its faces x = 3.6, y = 2.6).
    if (d.x() > 0) {
      const double tb = (3.6 - origin.x()) / d.x();
      const double y = origin.y() + tb * d.y();
      if (y >= 2.6 && y <= 3.0) t = std::min(t, tb);
    }
    if (d.y() > 0) {
      const double tb = (2.6 - origin.y()) / d.y();
      const double x = origin.x() + tb * d.x();
      if (x >= 3.6 && x <= 4.0) t = std::min(t, tb);
    }
    if (u(rng) < 0.01) {
      pts.emplace_back(NAN, NAN);
      continue;
    }
    pts.push_back(d * (t + noise(rng)));  // sensor frame: translation only
  }
  const std::vector<ScanLine> lines = ExtractLines(pts);
  // Truth in the sensor frame: n . p = c.
  struct Wall { Eigen::Vector2d n; double c; };
  const Wall walls[] = {{{1, 0}, -1.0}, {{1, 0}, 3.0}, {{0, 1}, -0.8}, {{0, 1}, 2.2}};
  int matched[4] = {0, 0, 0, 0};
  for (const ScanLine& l : lines) {
    EXPECT_GE(l.length, 0.5);
    EXPECT_LT(l.rms, 0.01);
    bool found = false;
    for (int w = 0; w < 4; ++w) {
      const double angle = std::acos(std::min(1.0, std::abs(l.normal.dot(walls[w].n))));
      const double offset = std::abs(walls[w].n.dot(l.centroid) - walls[w].c);
      if (angle < 1.0 * M_PI / 180 && offset < 0.015) {
        ++matched[w];
        found = true;
        // Every supporting sample lies on that wall.
        for (int i : l.indices) EXPECT_LT(std::abs(walls[w].n.dot(pts[i]) - walls[w].c), 0.03);
      }
    }
    EXPECT_TRUE(found) << "line at " << l.centroid.transpose() << " dir " << l.direction.transpose();
  }
  for (int w = 0; w < 4; ++w) EXPECT_GE(matched[w], 1) << "wall " << w;
  // The x = 4 wall (w = 1) is interrupted by the box: up to two pieces.
  EXPECT_LE(static_cast<int>(lines.size()), 6);
}

// A vertical scan plane cast in the simulated lab (core/sim/scene.h): every
// extracted line's samples lie on one surface of the scene, and the floor,
// ceiling and walls are found.
TEST(LineExtractionTest, VerticalScanInTheSimulatedLab) {
  const sim::Scene scene = sim::LabScene();
  const Eigen::Vector3d origin(3.0, 2.5, 0.4);
  const Eigen::Matrix3d R = RotZ(0.3);  // scan plane: the lidar's y-z plane, turned 0.3 rad
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::vector<Eigen::Vector2d> pts;
  std::vector<Eigen::Vector3d> world;
  for (int k = 0; k < 720; ++k) {
    const double theta = 2 * M_PI * k / 720;
    const Eigen::Vector3d dir = R * Eigen::Vector3d(0, std::sin(theta), std::cos(theta));
    sim::RayHit hit;
    if (!scene.Cast(origin, dir, 0.12, 10.0, &hit)) {
      pts.emplace_back(NAN, NAN);
      world.emplace_back(NAN, NAN, NAN);
      continue;
    }
    const double rho = hit.range + noise(rng);
    pts.emplace_back(rho * std::sin(theta), rho * std::cos(theta));
    world.push_back(origin + hit.range * dir);
  }
  const std::vector<ScanLine> lines = ExtractLines(pts);
  ASSERT_GE(lines.size(), 4u);
  int horizontal = 0, vertical = 0;
  for (const ScanLine& l : lines) {
    double worst = 0;
    for (int i : l.indices) worst = std::max(worst, scene.DistanceToSurface(world[i]));
    EXPECT_LT(worst, 1e-6);  // true hit points: on a surface by construction
    EXPECT_LT(l.rms, 0.006);
    // In the scan plane, y is horizontal and z vertical.
    if (std::abs(l.direction.y()) > 0.999) ++horizontal;
    if (std::abs(l.direction.x()) > 0.999) ++vertical;
  }
  EXPECT_GE(horizontal, 2);  // floor and ceiling (and desk tops)
  EXPECT_GE(vertical, 2);    // walls
}

}  // namespace
}  // namespace sweepscan::sfm
