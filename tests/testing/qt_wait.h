// Waiting in tests that drive Qt objects on the test's own thread: the
// event loop is pumped while waiting, so sockets, timers and queued calls
// run as they would in the app.
#ifndef SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_
#define SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QEventLoop>
#include <QTimer>
#include <functional>

namespace sweepscan::testing {

// Turns the event loop as the app's own loop does: what is pending, or else
// a wait for the next event, at most one tick (5 ms, so that a `done` that
// turns true without an event is still seen). A loop that never waits spins
// the GUI thread at nice 0 and takes the CPU from the app's own background
// jobs at nice 10 (ui/workspace/background_priority.h), which the app's
// idle loop never does: beside two busy processes on two cores, a floor
// plan that takes 1-2 s took 100 s under such a loop.
class EventLoopTurner {
 public:
  EventLoopTurner() { tick_.start(5); }
  void Turn() {
    QCoreApplication::processEvents(QEventLoop::AllEvents | QEventLoop::WaitForMoreEvents);
  }

 private:
  QTimer tick_;
};

// Pumps the event loop until `done` or the timeout; returns done().
inline bool WaitFor(const std::function<bool()>& done, int timeout_ms) {
  QElapsedTimer timer;
  timer.start();
  EventLoopTurner loop;
  while (!done()) {
    if (timer.elapsed() > timeout_ms) return done();
    loop.Turn();
  }
  return true;
}

// Pumps the event loop for `ms` milliseconds.
inline void Pump(int ms) {
  WaitFor([] { return false; }, ms);
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_
