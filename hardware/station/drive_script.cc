#include "hardware/station/drive_script.h"

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <utility>

namespace sweepscan {
namespace hardware {
namespace {

int64_t ClockNs(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", s);
  return text;
}

}  // namespace

ScriptClocks ScriptClocks::Now() { return {ClockNs(CLOCK_MONOTONIC), ClockNs(CLOCK_BOOTTIME)}; }

DriveScript::DriveScript(std::vector<sim::DriveSegment> path, const DriveScriptOptions& options)
    : path_(std::move(path)), options_(options) {
  for (const sim::DriveSegment& s : path_) duration_s_ += s.duration_s;
}

void DriveScript::Start(const ScriptClocks& now) {
  started_ = true;
  over_ = false;
  start_ = now;
  last_ = now;
  elapsed_s_ = 0.0;
  have_trips_ = false;
  abort_reason_.clear();
}

void DriveScript::Abort(const std::string& reason) {
  if (!running()) return;
  over_ = true;
  abort_reason_ = reason;
}

DriveScript::Step DriveScript::Fail(const std::string& reason) {
  Abort(reason);
  Step step;
  step.action = Action::kAbort;
  step.reason = abort_reason_;
  return step;
}

DriveScript::Step DriveScript::Tick(const ScriptClocks& now, const LinkStatus* status) {
  Step step;
  if (!started_ || over_) {
    step.action = aborted() ? Action::kAbort : Action::kDone;
    step.reason = abort_reason_;
    return step;
  }
  const int64_t gap_monotonic = now.monotonic_ns - last_.monotonic_ns;
  const int64_t gap_boottime = now.boottime_ns - last_.boottime_ns;
  last_ = now;
  const int64_t gap = std::max(gap_monotonic, gap_boottime);
  if (gap > options_.max_loop_gap_ns) {
    const double watchdog_s = options_.max_loop_gap_ns * 1e-9;
    // More than a tick's worth of difference between the clocks: asleep.
    const bool slept = gap_boottime - gap_monotonic > 100'000'000;
    return Fail((slept ? "the computer was suspended for " + Seconds(gap_boottime * 1e-9) + " s"
                       : "this process did not run for " + Seconds(gap * 1e-9) +
                             " s (stopped, or starved)") +
                ", longer than the robot's link watchdog (" + Seconds(watchdog_s) +
                " s): the robot stopped, and the path would jump ahead");
  }
  if (status != nullptr) {
    if (status->emergency_stop_latched) return Fail("the robot's emergency stop is latched");
    if (!have_trips_) {
      have_trips_ = true;
      trips_ = status->watchdog_trips;
    } else if (status->watchdog_trips != trips_) {
      return Fail(status->watchdog_trips > trips_
                      ? "the robot's link watchdog stopped it (trip " +
                            std::to_string(status->watchdog_trips) + ")"
                      : "the robot agent restarted (its watchdog count went back)");
    }
  }
  double t = (now.monotonic_ns - start_.monotonic_ns) * 1e-9;
  elapsed_s_ = t;
  for (const sim::DriveSegment& s : path_) {
    if (t < s.duration_s) {
      step.v = s.v;
      step.w = s.w;
      return step;
    }
    t -= s.duration_s;
  }
  over_ = true;
  elapsed_s_ = duration_s_;
  step.action = Action::kDone;
  return step;
}

}  // namespace hardware
}  // namespace sweepscan
