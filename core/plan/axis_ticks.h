// Where a drawn section's scales carry a tick and a label: every metre, or
// every 2, 5, 10, 20, 50 ... m when the extent would otherwise need more
// than kMaxAxisTicks of them. A stray point far off (an imported cloud's
// outlier) once made a tick and a label per metre of its whole extent: a
// point at z = 1e5 wrote a 25 MB DXF, and from 2^53 m on `z += 1` stopped
// advancing. Each tick is k * step for a whole k, never a running sum, and
// never -0 (a floor just below zero labelled "-0").
//
// Pure function; any thread.
#ifndef SWEEPSCAN_CORE_PLAN_AXIS_TICKS_H_
#define SWEEPSCAN_CORE_PLAN_AXIS_TICKS_H_

#include <cmath>
#include <string>
#include <vector>

#include "core/common/format_number.h"

namespace sweepscan::plan {

inline constexpr int kMaxAxisTicks = 50;

// The ticks in [lo, hi] (finite, lo <= hi), in order.
inline std::vector<double> AxisTicks(double lo, double hi) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi < lo) return ticks;
  double step = 1.0;
  for (int i = 0; (hi - lo) / step > kMaxAxisTicks - 1; ++i)
    step *= (i % 3 == 1) ? 2.5 : 2.0;  // 2, 5, 10, 20, 50...
  const double first = std::ceil(lo / step), last = std::floor(hi / step);
  // A counted loop: far from the origin first + 1 may round to first.
  for (int i = 0; i <= last - first && i < kMaxAxisTicks; ++i) {
    ticks.push_back((first + i) * step + 0.0);  // + 0.0: -0 -> 0
  }
  return ticks;
}

// A tick's label, the same in both drawings: "3" for a whole number of
// metres (every tick AxisTicks gives), else three decimals.
inline std::string AxisLabel(double v) {
  return FormatFixed(v, std::abs(v - std::round(v)) < 1e-9 ? 0 : 3);
}

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_AXIS_TICKS_H_
