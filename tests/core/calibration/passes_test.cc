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

}  // namespace
}  // namespace sweepscan
