// The tie between the robot's clock and the workstation's, from round trips
// (docs/robot-agent.md, "Clock tie and epochs").
//
// Geometry uses robot times only, but a session that spans a robot reboot
// has two robot clocks (CLOCK_MONOTONIC restarts at boot), and the
// workstation's clock (CLOCK_BOOTTIME: it counts a suspend, during which
// the robot's runs on) is what places the second on the first's
// timeline. Each round trip brackets the agent's time stamp: a frame the
// agent stamped r (robot clock) in answer to one we sent at workstation time
// a, received at b, was stamped somewhere in [a, b], so
//   offset = workstation - robot  lies in  [a - r, b - r]:
//   estimate (a + b) / 2 - r,  uncertainty +-(b - a) / 2.
// CommandAcks (every Heartbeat, 10 Hz) give such brackets all along; the
// narrowest recent one is kept, so the estimate follows the clocks' drift
// (tens of ppm: a millisecond over a 20 s outage).
#ifndef SWEEPSCAN_HARDWARE_STATION_CLOCK_TIE_H_
#define SWEEPSCAN_HARDWARE_STATION_CLOCK_TIE_H_

#include <cstdint>

#include "core/common/time.h"

namespace sweepscan {
namespace hardware {

struct ClockTie {
  bool valid = false;
  int64_t offset_ns = 0;        // workstation - robot, midpoint of the bracket.
  int64_t uncertainty_ns = 0;   // Half the bracket's width.
  int64_t measured_at_ns = 0;   // Workstation time of the bracket's end.

  // A frame stamped `robot` by the agent, answering one we sent at `sent`,
  // received at `received` (workstation clock, CLOCK_BOOTTIME, ns). Kept when it is
  // narrower than the current one, or the current one is over `max_age_ns`
  // old, so a slow round trip never replaces a fast one for long.
  void AddBracket(int64_t sent_ns, int64_t received_ns, int64_t robot_ns,
                  int64_t max_age_ns = 2000000000) {
    if (received_ns < sent_ns) return;
    const int64_t half = (received_ns - sent_ns) / 2;
    if (valid && half > uncertainty_ns && received_ns - measured_at_ns < max_age_ns) return;
    valid = true;
    offset_ns = sent_ns + half - robot_ns;
    uncertainty_ns = half;
    measured_at_ns = received_ns;
  }
};

// Whether the robot's clock was reset between two ties (a reboot during an
// outage): its time went back, or the tie moved by more than any delay or
// drift explains (0.5 s beyond both uncertainties: drift is ~1e-4 s/s at
// worst, and a reboot takes seconds).
inline bool NewClockEpoch(const ClockTie& before, int64_t last_robot_ns, const ClockTie& after,
                          int64_t first_robot_ns) {
  if (first_robot_ns < last_robot_ns) return true;
  if (!before.valid || !after.valid) return false;
  const int64_t moved = after.offset_ns - before.offset_ns;
  const int64_t allowed = before.uncertainty_ns + after.uncertainty_ns + 500000000;
  return moved > allowed || moved < -allowed;
}

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_STATION_CLOCK_TIE_H_
