// The drawn path against drives whose shape is known: every pose given must
// lie within the stated bound of the polylines drawn (checked by brute
// force), a path that never comes back must be drawn whole, and ground
// driven again must be drawn about once.
#include "core/geometry/path_cover.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sweepscan {
namespace {

using Polylines = std::vector<std::vector<Eigen::Vector2d>>;

double DistanceToPolylines(const Eigen::Vector2d& p, const Polylines& lines) {
  double best = 1e300;
  for (const auto& line : lines) {
    if (line.size() == 1) best = std::min(best, (p - line[0]).norm());
    for (size_t i = 0; i + 1 < line.size(); ++i) best = std::min(best, DistanceToSegment(p, line[i], line[i + 1]));
  }
  return best;
}

double WorstDeviation(const std::vector<Eigen::Vector2d>& given, const Polylines& lines) {
  double worst = 0.0;
  for (const auto& p : given) worst = std::max(worst, DistanceToPolylines(p, lines));
  return worst;
}

double Length(const Polylines& lines) {
  double sum = 0.0;
  for (const auto& line : lines) {
    for (size_t i = 0; i + 1 < line.size(); ++i) sum += (line[i + 1] - line[i]).norm();
  }
  return sum;
}

DrawnPath Drive(const std::vector<Eigen::Vector2d>& poses) {
  DrawnPath path(0.005, 0.02);
  for (const auto& p : poses) path.Add(p);
  return path;
}

TEST(PathCoverTest, ASegmentsPathThatNeverComesBackIsDrawnWhole) {
  // A square spiral with 0.5 m between its turns: no cell is reached twice.
  PathCover cover(0.02);
  std::vector<Eigen::Vector2d> corners = {{0, 0}};
  for (int k = 0; k < 12; ++k) {
    const double leg = 0.5 * (k / 2 + 1), angle = M_PI / 2 * k;  // 0.5, 0.5, 1, 1, 1.5, ...
    corners.push_back(corners.back() + leg * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
  }
  for (size_t i = 0; i + 1 < corners.size(); ++i) cover.Add(corners[i], corners[i + 1]);
  ASSERT_EQ(cover.runs().size(), 1u);
  EXPECT_NEAR(cover.drawn_length(), cover.given_length(), 1e-9);
  EXPECT_NEAR(Length(cover.runs()), cover.given_length(), 1e-9);
  ASSERT_EQ(cover.runs()[0].size(), corners.size());
  for (size_t i = 0; i < corners.size(); ++i) EXPECT_LT((cover.runs()[0][i] - corners[i]).norm(), 1e-12);
}

TEST(PathCoverTest, ALineDrivenFiftyTimesIsDrawnAboutOnce) {
  // Back and forth along 5 m at 0.2 m/s and 10 poses a second, the
  // estimate wandering sideways by up to 2 cm between passes and 2 mm from
  // pose to pose, as an EKF's does over hours.
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Eigen::Vector2d> poses;
  for (int pass = 0; pass < 50; ++pass) {
    const double offset = 0.02 * std::sin(0.7 * pass);
    for (int i = 0; i <= 250; ++i) {
      const double x = pass % 2 == 0 ? 0.02 * i : 5.0 - 0.02 * i;
      poses.emplace_back(x + noise(rng), 1.0 + offset + noise(rng));
    }
  }
  const DrawnPath path = Drive(poses);
  const Polylines lines = path.Polylines();
  EXPECT_LE(WorstDeviation(poses, lines), path.bound());
  // Given ~250 m; the first pass draws 5 m, the band the offset sweeps
  // (4 cm wide, two or three cells) a few times more. Before the cover the
  // simplified path was the whole 250 m.
  EXPECT_GT(path.cover().given_length(), 240.0);
  EXPECT_LT(Length(lines), 30.0);
  EXPECT_GT(Length(lines), 5.0);
}

TEST(PathCoverTest, ACircleDrivenThreeTimesIsDrawnOnce) {
  const double r = 1.5;
  std::vector<Eigen::Vector2d> poses;
  for (int i = 0; i <= 3 * 900; ++i) {
    const double t = 2 * M_PI * i / 900.0;
    poses.emplace_back(r * std::cos(t), r * std::sin(t));
  }
  const DrawnPath path = Drive(poses);
  const Polylines lines = path.Polylines();
  EXPECT_LE(WorstDeviation(poses, lines), path.bound());
  const double circumference = 2 * M_PI * r;
  EXPECT_GT(Length(lines), 0.99 * circumference);
  EXPECT_LT(Length(lines), 1.1 * circumference);
}

TEST(PathCoverTest, ARandomWalkStaysWithinTheBound) {
  // Turns on the spot, crossings at every angle and short legs: the bound
  // is the only claim, and it must hold pose by pose.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> turn(-0.6, 0.6);
  std::vector<Eigen::Vector2d> poses = {{0, 0}};
  double heading = 0.0;
  for (int i = 0; i < 20000; ++i) {
    heading += turn(rng);
    Eigen::Vector2d next = poses.back() + 0.02 * Eigen::Vector2d(std::cos(heading), std::sin(heading));
    next = next.cwiseMax(-1.0).cwiseMin(1.0);  // A 2 m room: driven over many times.
    poses.push_back(next);
  }
  const DrawnPath path = Drive(poses);
  const Polylines lines = path.Polylines();
  EXPECT_LE(WorstDeviation(poses, lines), path.bound());
  EXPECT_LT(Length(lines), 0.5 * path.cover().given_length());
}

TEST(PathCoverTest, TheOpenEndFollowsTheLatestPose) {
  DrawnPath path(0.005, 0.02);
  path.Add({0, 0});
  ASSERT_EQ(path.Polylines().size(), 1u);
  EXPECT_EQ(path.Polylines()[0].size(), 1u);
  for (int i = 1; i <= 100; ++i) path.Add({0.01 * i, 0.0});
  Polylines lines = path.Polylines();
  EXPECT_EQ(lines.back().back(), Eigen::Vector2d(1.0, 0.0));
  path.Add({1.0, 0.5});  // A turn fixes the straight leg.
  lines = path.Polylines();
  EXPECT_EQ(lines.back().back(), Eigen::Vector2d(1.0, 0.5));
  EXPECT_NEAR(Length(lines), 1.5, 1e-9);
  path.Clear();
  EXPECT_TRUE(path.Polylines().empty());
  EXPECT_EQ(path.cover().given_length(), 0.0);
}

}  // namespace
}  // namespace sweepscan
