#include "core/calibration/passes.h"

#include <gtest/gtest.h>

#include <random>

namespace sweepscan {
namespace {

TEST(SplitByTimeGapsTest, SplitsAtGapsInAnyOrder) {
  std::vector<int64_t> t;
  for (int i = 0; i < 50; ++i) t.push_back(1'000'000'000 + i * 1'000'000);  // 1.00-1.05 s
  for (int i = 0; i < 30; ++i) t.push_back(5'000'000'000 + i * 1'000'000);  // 5.00-5.03 s
  std::mt19937 rng(3);
  std::shuffle(t.begin(), t.end(), rng);
  const auto w = SplitByTimeGaps(t, 1.0);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].count, 50u);
  EXPECT_EQ(w[1].count, 30u);
  EXPECT_EQ(w[0].begin_ns, 1'000'000'000);
  EXPECT_EQ(w[1].end_ns, 5'029'000'000);
  EXPECT_EQ(PassOfTime(w, 1'020'000'000), 0);
  EXPECT_EQ(PassOfTime(w, 5'010'000'000), 1);
  EXPECT_EQ(PassOfTime(w, 3'000'000'000), -1);
}

TEST(SplitByTimeGapsTest, DropsStraysAndHandlesEmpty) {
  EXPECT_TRUE(SplitByTimeGaps({}, 1.0).empty());
  std::vector<int64_t> t = {0, 1, 2, 10'000'000'000};  // a stray return 10 s later
  const auto w = SplitByTimeGaps(t, 1.0, 2);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].count, 3u);
}

TEST(SplitRegionIntoPassesTest, KeepsOnlyRegionAndOrdersByTime) {
  std::vector<CloudPoint> pts;
  auto add = [&](float x, int64_t t) {
    CloudPoint p;
    p.x = x;
    p.time_ns = t;
    pts.push_back(p);
  };
  for (int i = 0; i < 25; ++i) add(0.5f, 9'000'000'000 - i * 1'000'000);  // second pass, reversed
  for (int i = 0; i < 25; ++i) add(0.5f, 1'000'000'000 + i * 1'000'000);  // first pass
  for (int i = 0; i < 25; ++i) add(5.0f, 3'000'000'000 + i * 1'000'000);  // outside the region
  const Eigen::AlignedBox3d region(Eigen::Vector3d(0, -1, -1), Eigen::Vector3d(1, 1, 1));
  const auto passes = SplitRegionIntoPasses(pts, region, 1.0, 20);
  ASSERT_EQ(passes.size(), 2u);
  ASSERT_EQ(passes[0].size(), 25u);
  ASSERT_EQ(passes[1].size(), 25u);
  EXPECT_EQ(passes[0].front(), 25u);  // earliest of the first pass
  for (size_t i = 1; i < passes[1].size(); ++i) {
    EXPECT_LT(pts[passes[1][i - 1]].time_ns, pts[passes[1][i]].time_ns);
  }
}

TEST(CircleDriveTest, NearAndFarSides) {
  CircleDrive circle{{5.0, 1.7}, 0.83};
  const Eigen::Vector2d target(5.0, 0.16);
  EXPECT_EQ(circle.PassOf({5.0, 0.87}, target), CirclePass::kNear);
  EXPECT_EQ(circle.PassOf({5.0, 2.53}, target), CirclePass::kFar);
  EXPECT_EQ(circle.PassOf({4.3, 1.2}, target), CirclePass::kNear);
  PoseBuffer poses;
  poses.Add(TimeFromNanoseconds(0), Rigid3d::FromPose(5.0, 0.87, 0, 0, 0, 0));
  poses.Add(TimeFromNanoseconds(1'000'000'000), Rigid3d::FromPose(5.0, 2.53, 0, 0, 0, M_PI));
  CirclePass pass;
  ASSERT_TRUE(circle.PassAtTime(poses, TimeFromNanoseconds(100'000'000), target, &pass));
  EXPECT_EQ(pass, CirclePass::kNear);
  ASSERT_TRUE(circle.PassAtTime(poses, TimeFromNanoseconds(900'000'000), target, &pass));
  EXPECT_EQ(pass, CirclePass::kFar);
  EXPECT_FALSE(circle.PassAtTime(poses, TimeFromNanoseconds(2'000'000'000), target, &pass));
}

// A drive round a known circle: the fit finds it, labels every point by the
// side of the centre it was seen from, and refuses drives that are not
// circles (a straight line, a part turn).
TEST(FitCircleDriveTest, FindsTheCircleAndLabelsPasses) {
  const Eigen::Vector2d centre(5.0, 1.7);
  const double radius = 0.83;
  PoseBuffer poses;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.005);
  const int n = 2000;  // two turns, 10 Hz over 200 s
  for (int i = 0; i < n; ++i) {
    const double phi = 4.0 * M_PI * i / n;
    poses.Add(TimeFromNanoseconds(int64_t{100'000'000} * i),
              Rigid3d::FromPose(centre.x() + radius * std::cos(phi) + noise(rng),
                                centre.y() + radius * std::sin(phi) + noise(rng), 0, 0, 0,
                                phi + M_PI / 2));
  }
  CircleDrive circle;
  std::string why;
  ASSERT_TRUE(FitCircleDrive(poses, &circle, &why)) << why;
  EXPECT_NEAR(circle.centre.x(), centre.x(), 0.002);
  EXPECT_NEAR(circle.centre.y(), centre.y(), 0.002);
  EXPECT_NEAR(circle.radius_m, radius, 0.002);

  // A target at (5, 0.16), below the centre: seen from the near side while
  // the robot is in the lower half of the circle (phi in (pi, 2 pi)).
  std::vector<CloudPoint> points;
  for (int i = 0; i < n; i += 10) {
    CloudPoint p;
    p.x = 5.0f;
    p.y = 0.16f;
    p.time_ns = int64_t{100'000'000} * i + 50'000'000;
    points.push_back(p);
  }
  CloudPoint late;
  late.time_ns = int64_t{100'000'000} * (n + 5);  // after the last pose
  points.push_back(late);
  const std::vector<uint8_t> labels = LabelCirclePasses(points, poses, circle);
  ASSERT_EQ(labels.size(), points.size());
  for (size_t k = 0; k + 1 < points.size(); ++k) {
    const double phi = 4.0 * M_PI * (points[k].time_ns * 1e-8) / n;
    const double s = std::sin(phi);
    if (std::abs(s) < 0.05) continue;  // on the boundary, either side
    EXPECT_EQ(labels[k], s < 0 ? 0 : 1) << k << " phi " << phi;
  }
  EXPECT_EQ(labels.back(), kNoPass);

  PoseBuffer straight;
  for (int i = 0; i < 200; ++i) {
    straight.Add(TimeFromNanoseconds(int64_t{100'000'000} * i),
                 Rigid3d::FromPose(0.01 * i, 0.0, 0, 0, 0, 0));
  }
  EXPECT_FALSE(FitCircleDrive(straight, &circle, &why));
  EXPECT_FALSE(why.empty());
  PoseBuffer quarter;
  for (int i = 0; i < 200; ++i) {
    const double phi = 0.5 * M_PI * i / 200;
    quarter.Add(TimeFromNanoseconds(int64_t{100'000'000} * i),
                Rigid3d::FromPose(radius * std::cos(phi), radius * std::sin(phi), 0, 0, 0, 0));
  }
  EXPECT_FALSE(FitCircleDrive(quarter, &circle, &why));
  EXPECT_NE(why.find("turns"), std::string::npos) << why;
  EXPECT_NE(why.find("0.25 turns"), std::string::npos) << why;  // "%.2f", not 0.250000

  // Forward one turn, then backward along the same circle: one turn
  // covered (the span of the polar angle), not zero (the net angle).
  PoseBuffer back_and_forth;
  for (int i = 0; i <= 400; ++i) {
    const double phi = 2.0 * M_PI * (i <= 200 ? i : 400 - i) / 200;
    back_and_forth.Add(TimeFromNanoseconds(int64_t{100'000'000} * i),
                       Rigid3d::FromPose(centre.x() + radius * std::cos(phi),
                                         centre.y() + radius * std::sin(phi), 0, 0, 0,
                                         phi + M_PI / 2));
  }
  EXPECT_TRUE(FitCircleDrive(back_and_forth, &circle, &why)) << why;
}

// Two headings over one drive: the same turns, one source turning 2 % more
// (unequal wheel radii) and offset by a constant (a different start): the
// departure is 2 % of the total turn, the offset does not count, and the
// +-pi wrap of atan2 does not either.
TEST(MaxHeadingDepartureTest, MeasuresTheTurnOneSourceAddsOverTheDrive) {
  PoseBuffer a, reference;
  const int n = 1000;
  const double total = 4.0 * M_PI;  // two turns
  for (int i = 0; i < n; ++i) {
    const double psi = total * i / (n - 1);
    const Time t = TimeFromNanoseconds(int64_t{50'000'000} * i);
    reference.Add(t, Rigid3d::FromPose(0, 0, 0, 0, 0, psi));
    a.Add(t, Rigid3d::FromPose(0, 0, 0, 0, 0, 1.0 + 1.02 * psi));
  }
  EXPECT_NEAR(MaxHeadingDeparture(a, reference), 0.02 * total, 1e-9);
  EXPECT_NEAR(MaxHeadingDeparture(reference, reference), 0.0, 1e-12);
  PoseBuffer later;  // no common time
  later.Add(TimeFromNanoseconds(int64_t{1'000'000'000'000}), Rigid3d());
  EXPECT_EQ(MaxHeadingDeparture(later, reference), -1.0);
}

}  // namespace
}  // namespace sweepscan
