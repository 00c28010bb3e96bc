// The rest budget spread over the census cubes in view (core/cloud/cube_budget.h):
// within the budget, every point where the cubes in view fit it, and an even
// density on screen (points a cube times its distance squared) otherwise,
// nearer cubes never thinner than farther ones.
#include "core/cloud/cube_budget.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace sweepscan {
namespace {

double Kept(const std::vector<CubeDemand>& cubes, const std::vector<uint8_t>& shifts) {
  double kept = 0.0;
  for (size_t i = 0; i < cubes.size(); ++i) kept += std::ldexp(cubes[i].count, -shifts[i]);
  return kept;
}

TEST(CubeBudgetTest, CubesThatFitTheBudgetKeepEveryPoint) {
  const std::vector<CubeDemand> cubes = {{1.0, 500}, {25.0, 20000}, {0.01, 7}};
  double kept = 0.0;
  const std::vector<uint8_t> shifts = CubeShifts(cubes, 20507, &kept);
  EXPECT_EQ(shifts, std::vector<uint8_t>(3, 0));
  EXPECT_EQ(kept, 20507.0);
}

// A wall of equal cubes from 1 to 40 m away, a tenth of its points in the
// budget: at most the budget, most of it used, the strides never finer
// farther away, and the density on screen even: n / stride times d^2 within
// a factor 4 (one for rounding each stride up to a power of two, one for
// the nearest cubes' halving) over the cubes not drawn whole.
TEST(CubeBudgetTest, TheBudgetIsSpreadEvenlyOnScreen) {
  std::vector<CubeDemand> cubes;
  std::mt19937 rng(5);
  std::uniform_int_distribution<uint32_t> count(2000, 4000);
  for (int i = 0; i < 400; ++i) cubes.push_back({std::pow(1.0 + 39.0 * i / 399.0, 2), count(rng)});
  std::shuffle(cubes.begin(), cubes.end(), rng);
  double total = 0.0;
  for (const CubeDemand& c : cubes) total += c.count;
  const size_t budget = static_cast<size_t>(total / 10);
  double kept = 0.0;
  const std::vector<uint8_t> shifts = CubeShifts(cubes, budget, &kept);
  ASSERT_EQ(shifts.size(), cubes.size());
  EXPECT_DOUBLE_EQ(kept, Kept(cubes, shifts));
  EXPECT_LE(kept, static_cast<double>(budget));
  EXPECT_GT(kept, 0.9 * budget);
  double lo = 1e300, hi = 0.0;
  int whole = 0;
  for (size_t i = 0; i < cubes.size(); ++i) {
    for (size_t j = 0; j < cubes.size(); ++j) {
      // Nearer and at least as many points: never a coarser stride (the
      // stride is the least power of two above n d^2 / lambda).
      if (cubes[i].distance2 < cubes[j].distance2 && cubes[i].count <= cubes[j].count) {
        EXPECT_LE(shifts[i], shifts[j]) << i << " " << j;
      }
    }
    if (shifts[i] == 0) {
      ++whole;
      continue;
    }
    const double density = std::ldexp(cubes[i].count, -shifts[i]) * cubes[i].distance2;
    lo = std::min(lo, density);
    hi = std::max(hi, density);
  }
  EXPECT_GT(whole, 0);  // the nearest, within 1-2 m
  EXPECT_LT(whole, 40);
  EXPECT_LE(hi / lo, 4.0);
}

// A cube around the camera counts as one a cube's side away (0.5 m): it
// does not take the whole budget from the cubes a metre off.
TEST(CubeBudgetTest, ACubeAroundTheCameraDoesNotTakeTheWholeBudget) {
  const std::vector<CubeDemand> cubes = {{0.0, 100000}, {1.0, 100000}, {1.0, 100000}};
  double kept = 0.0;
  const std::vector<uint8_t> shifts = CubeShifts(cubes, 30000, &kept);
  EXPECT_LE(kept, 30000.0);
  // 4 times the density on screen at half the distance, 2 or 3 from the
  // rounding; cubes alike within one halving (the budget left goes to the
  // first of them in order).
  const int far = std::max(shifts[1], shifts[2]);
  EXPECT_GE(far - shifts[0], 1);
  EXPECT_LE(far - shifts[0], 3);
  EXPECT_LE(std::abs(shifts[1] - shifts[2]), 1);
}

TEST(CubeBudgetTest, NoBudgetLeavesTheCoarsestStrides) {
  const std::vector<CubeDemand> cubes = {{4.0, 1u << 20}, {9.0, 1000}};
  double kept = 0.0;
  const std::vector<uint8_t> shifts = CubeShifts(cubes, 0, &kept);
  EXPECT_LT(kept, 1.0);
  EXPECT_GE(shifts[0], 20);
  EXPECT_EQ(CubeShifts({}, 100).size(), 0u);
}

}  // namespace
}  // namespace sweepscan
