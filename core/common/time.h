// One time type for the whole project: robot time, nanoseconds since an
// arbitrary robot epoch (the robot agent's monotonic clock). Arrival times on
// the workstation are never used for geometry.
#ifndef SWEEPSCAN_CORE_COMMON_TIME_H_
#define SWEEPSCAN_CORE_COMMON_TIME_H_

#include <chrono>
#include <cstdint>

namespace sweepscan {

struct RobotClock {
  using rep = int64_t;
  using period = std::nano;
  using duration = std::chrono::duration<rep, period>;
  using time_point = std::chrono::time_point<RobotClock>;
  static constexpr bool is_steady = true;
};

using Duration = RobotClock::duration;
using Time = RobotClock::time_point;

inline constexpr Duration FromSeconds(double seconds) {
  return Duration(static_cast<int64_t>(seconds * 1e9 + (seconds >= 0 ? 0.5 : -0.5)));
}
inline constexpr double ToSeconds(Duration d) { return static_cast<double>(d.count()) * 1e-9; }
// Seconds since the robot epoch; fine for geometry (double keeps ns resolution for ~100 days).
inline constexpr double ToSeconds(Time t) { return ToSeconds(t.time_since_epoch()); }
inline constexpr Time TimeFromSeconds(double seconds) { return Time(FromSeconds(seconds)); }
inline constexpr Time TimeFromNanoseconds(int64_t ns) { return Time(Duration(ns)); }
inline constexpr int64_t ToNanoseconds(Time t) { return t.time_since_epoch().count(); }

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_COMMON_TIME_H_
