// The path simplifier against paths whose shape is known: every point given
// must lie within the tolerance of the polyline kept (checked by brute
// force), and the vertex counts must be what the geometry says.
#include "core/geometry/polyline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sweepscan {
namespace {

// The largest distance of any given point to the kept polyline.
double WorstDeviation(const std::vector<Eigen::Vector2d>& given,
                      const std::vector<Eigen::Vector2d>& kept) {
  double worst = 0.0;
  for (const Eigen::Vector2d& p : given) {
    double best = kept.size() == 1 ? (p - kept[0]).norm() : 1e300;
    for (size_t i = 0; i + 1 < kept.size(); ++i) {
      best = std::min(best, DistanceToSegment(p, kept[i], kept[i + 1]));
    }
    worst = std::max(worst, best);
  }
  return worst;
}

TEST(DistanceToSegmentTest, InsideBeyondTheEndsAndDegenerate) {
  const Eigen::Vector2d a(0, 0), b(2, 0);
  EXPECT_DOUBLE_EQ(DistanceToSegment({1, 0.5}, a, b), 0.5);
  EXPECT_DOUBLE_EQ(DistanceToSegment({3, 0}, a, b), 1.0);   // Beyond b: to b.
  EXPECT_DOUBLE_EQ(DistanceToSegment({-3, 4}, a, b), 5.0);  // Beyond a: to a.
  EXPECT_DOUBLE_EQ(DistanceToSegment({3, 4}, a, a), 5.0);
}

TEST(PolylineSimplifierTest, AStraightLegKeepsItsEndsAndTheLatestPoint) {
  PolylineSimplifier s(0.005);
  std::vector<Eigen::Vector2d> given;
  for (int i = 0; i <= 350; ++i) given.emplace_back(0.02 * i, 1.0);  // 35 s at 0.2 m/s, 10 Hz.
  for (const auto& p : given) s.Add(p);
  ASSERT_EQ(s.vertices().size(), 2u);
  EXPECT_EQ(s.vertices().front(), given.front());
  EXPECT_EQ(s.vertices().back(), given.back());
  EXPECT_EQ(s.points_given(), 351u);
}

TEST(PolylineSimplifierTest, ACircleKeepsTheChordCountItsSagittaAllows) {
  // A chord of a circle of radius r deviates from the arc by its sagitta
  // r (1 - cos(theta / 2)); the largest chord angle within tol is
  // theta = 2 acos(1 - tol / r), so a full turn needs at least 2 pi / theta
  // chords, and a greedy end-moving scheme at most twice that.
  const double r = 1.0, tol = 0.005;
  PolylineSimplifier s(tol);
  std::vector<Eigen::Vector2d> given;
  for (int i = 0; i <= 3600; ++i) {
    const double t = 2 * M_PI * i / 3600.0;
    given.emplace_back(r * std::cos(t), r * std::sin(t));
  }
  for (const auto& p : given) s.Add(p);
  const double min_chords = 2 * M_PI / (2 * std::acos(1 - tol / r));  // 31.4
  const double chords = static_cast<double>(s.vertices().size() - 1);
  EXPECT_GE(chords, std::floor(min_chords));
  EXPECT_LE(chords, 2 * std::ceil(min_chords));
  EXPECT_LE(WorstDeviation(given, s.vertices()), tol + 1e-12);
}

TEST(PolylineSimplifierTest, ANoisyBackAndForthDriveStaysWithinTheTolerance) {
  // The lab's back-and-forth drive (legs of 7 m, half turns of radius
  // 0.3 m) with 2 mm of pose noise: every point within 5 mm of the kept
  // line, and a small fraction of the points kept.
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Eigen::Vector2d> given;
  for (int leg = 0; leg < 6; ++leg) {
    const double dir = leg % 2 == 0 ? 1.0 : -1.0, y = 0.6 * (leg % 2);
    for (int i = 0; i < 350; ++i) {
      const double x = dir > 0 ? 0.02 * i : 7.0 - 0.02 * i;
      given.emplace_back(x + noise(rng), y + noise(rng));
    }
    for (int i = 0; i < 15; ++i) {  // The half turn about (end, 0.3).
      const double t = M_PI * i / 15.0, cx = dir > 0 ? 7.0 : 0.0;
      given.emplace_back(cx + dir * 0.3 * std::sin(t),
                         0.3 - (dir > 0 ? 1 : -1) * 0.3 * std::cos(t));
    }
  }
  PolylineSimplifier s(0.005);
  for (const auto& p : given) s.Add(p);
  EXPECT_LE(WorstDeviation(given, s.vertices()), 0.005 + 1e-12);
  EXPECT_LT(s.vertices().size(), given.size() / 4) << s.vertices().size() << " of " << given.size();
  EXPECT_EQ(s.vertices().back(), given.back());
}

TEST(PolylineSimplifierTest, TheCheckIsCappedOnLongLegs) {
  // 10 000 points on one line, at most 100 checked at a time: a fixed
  // vertex every 100 points, still every point on the line.
  PolylineSimplifier s(0.005, 100);
  for (int i = 0; i < 10000; ++i) s.Add({0.01 * i, 0.0});
  EXPECT_NEAR(static_cast<double>(s.vertices().size()), 10000.0 / 99.0, 2.0);
  s.Clear();
  EXPECT_TRUE(s.vertices().empty());
  EXPECT_EQ(s.points_given(), 0u);
}

}  // namespace
}  // namespace sweepscan
