// Whether the GUI stayed responsive while a job ran, judged so that a busy
// machine does not look like a frozen GUI. Work done on the GUI thread
// shows whole in the CPU time of the event-loop turn that did it; a turn's
// wall time also grows with whatever else runs on the machine (under
// `ctest -j2` on two cores, gaps of 500-800 ms in CI where the same turns
// took 40-120 ms alone, which failed wall-time bounds three times). So the
// bound is on the GUI thread's CPU time in its longest turn, and a loose
// wall-time bound only catches a blocking wait.
#ifndef SWEEPSCAN_TESTS_TESTING_EVENT_LOOP_TURNS_H_
#define SWEEPSCAN_TESTS_TESTING_EVENT_LOOP_TURNS_H_

#include <gtest/gtest.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <functional>

#include "tests/testing/qt_wait.h"

namespace sweepscan::testing {

struct EventLoopTurns {
  qint64 worst_gap_ms = 0;          // longest wall time between two turns
  double worst_turn_cpu_ms = 0.0;   // most GUI-thread CPU time in one turn
  int turns = 0;
  bool done = false;                // whether `done` held before the timeout
};

inline double ThisThreadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// Pumps the event loop until `done` or the timeout, measuring its turns;
// then runs the last queued calls.
inline EventLoopTurns MeasureTurnsUntil(const std::function<bool()>& done, int timeout_ms) {
  EventLoopTurns t;
  QElapsedTimer clock, gap;
  clock.start();
  gap.start();
  EventLoopTurner loop;
  while (!done() && clock.elapsed() < timeout_ms) {
    const double cpu0 = ThisThreadCpuMs();
    loop.Turn();
    t.worst_turn_cpu_ms = std::max(t.worst_turn_cpu_ms, ThisThreadCpuMs() - cpu0);
    t.worst_gap_ms = std::max(t.worst_gap_ms, gap.restart());
    ++t.turns;
  }
  t.done = done();
  QCoreApplication::processEvents();
  return t;
}

// The GUI thread's longest turn under `cpu_bound_ms` of CPU, no gap above
// `wall_bound_ms` (a blocking wait), printed either way.
inline void ExpectResponsive(const char* what, const EventLoopTurns& t, double cpu_bound_ms,
                             qint64 wall_bound_ms = 2000) {
  std::printf("%s: %d event-loop turns, longest gap %lld ms, longest turn %.0f ms of CPU\n", what,
              t.turns, static_cast<long long>(t.worst_gap_ms), t.worst_turn_cpu_ms);
  EXPECT_LT(t.worst_turn_cpu_ms, cpu_bound_ms) << what;
  EXPECT_LT(t.worst_gap_ms, wall_bound_ms) << what;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_EVENT_LOOP_TURNS_H_
