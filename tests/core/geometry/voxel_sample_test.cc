// The spatially even sample against brute force: offered a room's surfaces
// scanned unevenly, its representatives must be exactly the first point
// offered in each occupied cell of its final grid, within the budget, spread
// per area rather than per point, and nested from one merge to the next.
#include "core/geometry/voxel_sample.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

namespace sweepscan {
namespace {

struct Offered {
  uint32_t source;
  uint32_t index;
  float xyz[3];
};

// A 6 x 4 x 2.5 m room's floor and four walls, sampled as a drive does: the
// floor strip 0.5 m wide along y = 2 (the lane) about 50 times denser than
// the rest. Split into sources ("chunks") of 4 096 points in order.
std::vector<Offered> UnevenRoom(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Offered> out;
  for (size_t i = 0; i < n; ++i) {
    float p[3];
    const float pick = u(rng);
    if (pick < 0.6f) {  // the lane
      p[0] = 6.0f * u(rng), p[1] = 1.75f + 0.5f * u(rng), p[2] = 0.0f;
    } else if (pick < 0.7f) {  // the whole floor, 50 times thinner a m^2
      p[0] = 6.0f * u(rng), p[1] = 4.0f * u(rng), p[2] = 0.0f;
    } else {  // the walls, thinner still
      const float t = u(rng) * 20.0f;
      p[2] = 2.5f * u(rng);
      if (t < 6.0f) p[0] = t, p[1] = 0.0f;
      else if (t < 10.0f) p[0] = 6.0f, p[1] = t - 6.0f;
      else if (t < 16.0f) p[0] = t - 10.0f, p[1] = 4.0f;
      else p[0] = 0.0f, p[1] = t - 16.0f;
    }
    out.push_back({static_cast<uint32_t>(i / 4096), static_cast<uint32_t>(i % 4096), {p[0], p[1], p[2]}});
  }
  return out;
}

void OfferAll(VoxelSample* sample, const std::vector<Offered>& points, size_t from, size_t to) {
  for (size_t first = from; first < to;) {
    size_t end = first;
    while (end < to && points[end].source == points[first].source) ++end;
    std::vector<float> xyz;
    std::vector<uint32_t> index;
    for (size_t i = first; i < end; ++i) {
      xyz.insert(xyz.end(), points[i].xyz, points[i].xyz + 3);
      index.push_back(points[i].index);
    }
    std::vector<uint32_t> taken;
    sample->Offer(points[first].source, xyz.data(), index.data(), index.size(), &taken);
    sample->Fit();
    first = end;
  }
}

using Cell = std::tuple<int64_t, int64_t, int64_t>;
// As the sample computes it (times the inverse, which may round unlike a
// division at a cell's border).
Cell CellOf(const float* p, const std::array<double, 3>& h) {
  const auto at = [&](int a) { return static_cast<int64_t>(std::floor(static_cast<double>(p[a]) * (1.0 / h[a]))); };
  return {at(0), at(1), at(2)};
}

std::set<size_t> Held(const VoxelSample& sample, const std::vector<Offered>& points, size_t to) {
  std::set<size_t> held;
  for (size_t i = 0; i < to; ++i) {
    if (sample.Holds(points[i].source, points[i].index, points[i].xyz)) held.insert(i);
  }
  return held;
}

TEST(VoxelSampleTest, HoldsTheFirstPointOfEachOccupiedCellWithinTheBudget) {
  const std::vector<Offered> points = UnevenRoom(200000, 1);
  VoxelSample sample(5000);
  OfferAll(&sample, points, 0, points.size());
  ASSERT_LE(sample.size(), 5000u);
  // Doubling one axis at a time keeps it above a quarter of the budget.
  EXPECT_GT(sample.size(), 5000u / 4);
  // Brute force at the final grid: the first point offered in each cell.
  std::map<Cell, size_t> first;
  for (size_t i = 0; i < points.size(); ++i) first.try_emplace(CellOf(points[i].xyz, sample.cell()), i);
  std::set<size_t> expected;
  for (const auto& [cell, i] : first) expected.insert(i);
  EXPECT_EQ(Held(sample, points, points.size()), expected);
  EXPECT_EQ(sample.size(), expected.size());
  // Cells stay within a factor two of cubes.
  const auto [lo, hi] = std::minmax_element(sample.cell().begin(), sample.cell().end());
  EXPECT_LE(*hi, 2.0 * *lo + 1e-12);
}

TEST(VoxelSampleTest, SpendsTheBudgetPerAreaNotPerPoint) {
  // 60 % of the points lie on the lane's 3 m^2 of floor, 10 % on the whole
  // 24 m^2: every 40th point in time gives the lane about 50 times the
  // density of the rest of the floor. One point a cell gives them the same.
  const std::vector<Offered> points = UnevenRoom(400000, 2);
  VoxelSample sample(8000);
  OfferAll(&sample, points, 0, points.size());
  // Counted away from the lane's borders, where a cell straddling one takes
  // its representative from the dense side: the lane's middle 0.4 m, and the
  // floor more than 0.15 m from the lane.
  size_t lane = 0, rest = 0, every_nth_lane = 0, every_nth_rest = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const float* p = points[i].xyz;
    if (p[2] != 0.0f) continue;
    const bool in_lane = p[1] >= 1.8f && p[1] <= 2.2f;
    if (!in_lane && p[1] >= 1.6f && p[1] <= 2.4f) continue;
    if (sample.Holds(points[i].source, points[i].index, p)) ++(in_lane ? lane : rest);
    if (i % 40 == 0) ++(in_lane ? every_nth_lane : every_nth_rest);
  }
  const double lane_area = 6.0 * 0.4, rest_area = 6.0 * (4.0 - 0.8);
  EXPECT_NEAR((lane / lane_area) / (rest / rest_area), 1.0, 0.15) << lane << " " << rest;
  EXPECT_GT((every_nth_lane / lane_area) / (every_nth_rest / rest_area), 30.0);
}

TEST(VoxelSampleTest, EachSampleIsASubsetOfTheOneBeforeAndWhatWasOfferedSince) {
  const std::vector<Offered> points = UnevenRoom(120000, 3);
  VoxelSample sample(3000);
  std::set<size_t> before;
  size_t merges_seen = 0;
  for (size_t to = 20480; to <= points.size(); to += 20480) {
    const uint64_t generation = sample.generation();
    OfferAll(&sample, points, to - 20480, to);
    if (sample.generation() != generation) ++merges_seen;
    const std::set<size_t> now = Held(sample, points, to);
    for (size_t i : now) {
      EXPECT_TRUE(before.count(i) == 1 || i >= to - 20480) << "point " << i << " came back";
    }
    before = now;
  }
  EXPECT_GE(merges_seen, 1u);
  // A smaller budget merges at once, keeping a subset.
  sample.SetBudget(500);
  EXPECT_LE(sample.size(), 500u);
  const std::set<size_t> after = Held(sample, points, points.size());
  EXPECT_TRUE(std::includes(before.begin(), before.end(), after.begin(), after.end()));
}

TEST(VoxelSampleTest, OffersReportTheNewRepresentativesAndSkipNonFinitePoints) {
  VoxelSample sample(100, 0.1);
  const float xyz[] = {0.01f, 0.01f, 0.01f,  0.02f, 0.02f, 0.02f,  NAN, 0.0f, 0.0f,  0.5f, 0.0f, 0.0f};
  const uint32_t index[] = {0, 1, 2, 3};
  std::vector<uint32_t> taken;
  sample.Offer(7, xyz, index, 4, &taken);
  EXPECT_EQ(taken, (std::vector<uint32_t>{0, 3}));
  EXPECT_TRUE(sample.Holds(7, 0, xyz));
  EXPECT_FALSE(sample.Holds(7, 1, xyz + 3));  // same cell, offered later
  EXPECT_EQ(sample.size(), 2u);
  sample.Clear();
  EXPECT_EQ(sample.size(), 0u);
  EXPECT_DOUBLE_EQ(sample.cell()[0], 0.1);
}

}  // namespace
}  // namespace sweepscan
