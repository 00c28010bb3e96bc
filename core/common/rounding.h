// Rounding to the nearest integer, halves away from zero, as std::llround,
// inlined.
//
// Why: std::llround is a libm call (about 4.5 ns here), and the open of a
// long session makes seven of them a point: three to put the point on the
// cloud's 1 mm grid (cloud.h), three more to check that it is there as the
// store packs it (packed_chunk.cc), one for the X4 sample's time stamp
// (x4_codec.cc). That was 8 % of the two busy threads' time opening a
// 99.5 M-point session (perf).
//
// Exact: t = trunc(x) is exact, and so is the fraction x - t for
// |x| < 2^53 (both are doubles with the same exponent or less); the result
// is then t, t + 1 or t - 1 by the fraction against +-0.5, which is
// llround's rule. Outside that range, and for NaN and infinities, it is
// llround itself (tests/core/common/rounding_test.cc checks both).
#ifndef SWEEPSCAN_CORE_COMMON_ROUNDING_H_
#define SWEEPSCAN_CORE_COMMON_ROUNDING_H_

#include <cmath>
#include <cstdint>

namespace sweepscan {

inline int64_t RoundHalfAway(double x) {
  if (!(std::abs(x) < 9007199254740992.0)) return std::llround(x);  // 2^53; NaN too.
  const auto t = static_cast<int64_t>(x);                            // Toward zero, exact.
  const double fraction = x - static_cast<double>(t);
  return t + (fraction >= 0.5 ? 1 : 0) - (fraction <= -0.5 ? 1 : 0);
}

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_ROUNDING_H_
