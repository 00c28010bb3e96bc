#include "core/cloud/cube_budget.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sweepscan {
namespace {

constexpr double kMinDistance2 = 0.25;  // (0.5 m)^2: one cube's side.

double Distance2(const CubeDemand& c) { return std::max(c.distance2, kMinDistance2); }

// Equation (2) of the header: the least power of two >= n d^2 / lambda.
int ShiftFor(const CubeDemand& c, double lambda) {
  const double need = c.count * Distance2(c) / lambda;
  if (!(need > 1.0)) return 0;
  return std::min(kMaxCubeShift, static_cast<int>(std::ceil(std::log2(need))));
}

double Kept(const std::vector<CubeDemand>& cubes, double lambda) {
  double kept = 0.0;
  for (const CubeDemand& c : cubes) kept += std::ldexp(c.count, -ShiftFor(c, lambda));
  return kept;
}

}  // namespace

std::vector<uint8_t> CubeShifts(const std::vector<CubeDemand>& cubes, size_t budget,
                                double* kept_out) {
  std::vector<uint8_t> shifts(cubes.size(), 0);
  double total = 0.0, lambda_all = 0.0;  // lambda_all: every stride 1
  for (const CubeDemand& c : cubes) {
    total += c.count;
    lambda_all = std::max(lambda_all, c.count * Distance2(c));
  }
  const double b = static_cast<double>(budget);
  if (total <= b || lambda_all <= 0.0) {
    if (kept_out != nullptr) *kept_out = total;
    return shifts;
  }
  // Bisection in log lambda between every stride at its largest and every
  // stride 1: Kept() grows with lambda.
  double lo = std::log2(lambda_all) - kMaxCubeShift - 1.0, hi = std::log2(lambda_all);
  for (int it = 0; it < 48 && hi - lo > 1e-3; ++it) {
    const double mid = 0.5 * (lo + hi);
    (Kept(cubes, std::exp2(mid)) <= b ? lo : hi) = mid;
  }
  const double lambda = std::exp2(lo);
  double kept = 0.0;
  for (size_t i = 0; i < cubes.size(); ++i) {
    shifts[i] = static_cast<uint8_t>(ShiftFor(cubes[i], lambda));
    kept += std::ldexp(cubes[i].count, -shifts[i]);
  }
  // What the rounding up left, to the nearest cubes: halving a cube's stride
  // adds n / stride points.
  std::vector<size_t> order(cubes.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t c) { return cubes[a].distance2 < cubes[c].distance2; });
  // One halving a cube a round, nearest first, so that cubes alike end
  // within one halving of each other.
  for (bool halved = true; halved;) {
    halved = false;
    for (size_t i : order) {
      const double more = std::ldexp(cubes[i].count, -shifts[i]);
      if (shifts[i] == 0 || kept + more > b) continue;
      kept += more;
      --shifts[i];
      halved = true;
    }
  }
  if (kept_out != nullptr) *kept_out = kept;
  return shifts;
}

}  // namespace sweepscan
