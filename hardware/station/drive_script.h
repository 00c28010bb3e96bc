// A drive script (a path of timed segments) played against the robot at
// 10 Hz, shared by `sweepscan-cli record --drive-script` and the app's
// scripted drives (the calibration circle). No Qt, no I/O: the caller's
// timer calls Tick() with the clocks and the robot's last Status, and sends
// what it returns.
//
// A script runs only while the robot is known to follow it. It aborts, and
// the caller stops the robot, when:
//  - the caller's own loop did not turn for longer than the robot's link
//    watchdog (the process was stopped with SIGSTOP, a laptop slept, a
//    debugger held it): the robot's watchdog stopped the robot meanwhile,
//    and the path's time ran on, so the next segment would be a jump
//    (docs/robot-agent.md, "Outages and reconnection": a watchdog stop lasts
//    until the operator drives). The gap is measured on CLOCK_MONOTONIC and
//    on CLOCK_BOOTTIME, since Linux's monotonic clock stands still during a
//    suspend and a sleep would pass unnoticed on it alone;
//  - the robot reports a watchdog trip the script has not seen (its Status's
//    trip count changed: a stall on the way that the loop did not see, or a
//    robot agent that restarted), or an emergency stop latched.
// A link outage aborts it too; the caller hears of that from its connection.
#ifndef SWEEPSCAN_HARDWARE_STATION_DRIVE_SCRIPT_H_
#define SWEEPSCAN_HARDWARE_STATION_DRIVE_SCRIPT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "core/sim/world.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

// Both clocks at one instant, in nanoseconds.
struct ScriptClocks {
  int64_t monotonic_ns = 0;  // Stops while the computer is suspended.
  int64_t boottime_ns = 0;   // Counts the suspend.
  static ScriptClocks Now();
};

struct DriveScriptOptions {
  // A loop gap longer than this aborts: the robot agent's default link
  // watchdog (sweepscan-robotd --watchdog-ms). The workstation does not know
  // the robot's own setting; with a shorter one, the trip itself is
  // reported in Status and aborts the script at the next tick.
  int64_t max_loop_gap_ns = 500'000'000;
};

class DriveScript {
 public:
  enum class Action { kDrive, kDone, kAbort };
  struct Step {
    Action action = Action::kDrive;
    double v = 0.0;  // kDrive: the segment's set-point.
    double w = 0.0;
    std::string reason;  // kAbort: why, for the operator.
  };

  DriveScript(std::vector<sim::DriveSegment> path, const DriveScriptOptions& options = {});

  // The script's time starts now.
  void Start(const ScriptClocks& now);
  // One tick of the caller's timer. `status`: the robot's last Status, or
  // null if none arrived yet. After kDone or kAbort the script is over and
  // every later call returns the same.
  Step Tick(const ScriptClocks& now, const LinkStatus* status);
  // Ends the script from outside (a link outage, an emergency stop): `reason`
  // is kept as the abort's.
  void Abort(const std::string& reason);

  bool running() const { return started_ && !over_; }
  bool aborted() const { return !abort_reason_.empty(); }
  const std::string& abort_reason() const { return abort_reason_; }
  double duration_s() const { return duration_s_; }
  // Script time of the last tick (of the abort, once aborted).
  double elapsed_s() const { return elapsed_s_; }

 private:
  Step Fail(const std::string& reason);

  std::vector<sim::DriveSegment> path_;
  DriveScriptOptions options_;
  double duration_s_ = 0.0;
  bool started_ = false;
  bool over_ = false;
  ScriptClocks start_;
  ScriptClocks last_;
  double elapsed_s_ = 0.0;
  bool have_trips_ = false;
  uint32_t trips_ = 0;
  std::string abort_reason_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_STATION_DRIVE_SCRIPT_H_
