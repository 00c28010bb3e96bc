// Per-point values given to the view after the fact (a circle drive's
// pass, a point's deviation from its plane, a lidar's intensity) as the
// view keeps them: 16 bits a point over the values' range (65 535 steps,
// far finer than the lookup table's 256 colours, and half a float).
// Quantize is a pure function of the values, so a large cloud's values are
// prepared on a worker thread and the GUI thread only copies them in
// (10 M intensities: ~35 ms of quantising that is then not the GUI's).
#ifndef SWEEPSCAN_UI_VIEW_POINT_VALUES_H_
#define SWEEPSCAN_UI_VIEW_POINT_VALUES_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace sweepscan::ui {

struct QuantizedValues {
  static constexpr uint16_t kNone = 0xFFFF;  // NaN: no value, drawn grey
  // The finite values' range (both 0 when there are none): value = lo + q step.
  float lo = 0.0f, hi = 0.0f;
  double step = 1.0;
  std::vector<uint16_t> q;  // one per point, in the order the points came

  double Value(uint16_t v) const { return lo + v * step; }
};

inline QuantizedValues Quantize(const std::vector<float>& values) {
  QuantizedValues out;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : values) {
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!std::isfinite(lo)) lo = hi = 0.0f;
  out.lo = lo;
  out.hi = hi;
  out.step = hi > lo ? (static_cast<double>(hi) - lo) / (QuantizedValues::kNone - 1) : 1.0;
  out.q.resize(values.size(), QuantizedValues::kNone);
  for (size_t i = 0; i < values.size(); ++i) {
    if (std::isfinite(values[i])) {
      out.q[i] =
          static_cast<uint16_t>(std::lround((static_cast<double>(values[i]) - lo) / out.step));
    }
  }
  return out;
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_POINT_VALUES_H_
