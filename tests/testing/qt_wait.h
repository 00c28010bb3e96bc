// Waiting in tests that drive Qt objects on the test's own thread: the
// event loop is pumped while waiting, so sockets, timers and queued calls
// run as they would in the app.
#ifndef SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_
#define SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_

#include <QCoreApplication>
#include <QElapsedTimer>
#include <functional>

namespace sweepscan::testing {

// Pumps the event loop until `done` or the timeout; returns done().
inline bool WaitFor(const std::function<bool()>& done, int timeout_ms) {
  QElapsedTimer timer;
  timer.start();
  while (!done()) {
    if (timer.elapsed() > timeout_ms) return done();
    QCoreApplication::processEvents(QEventLoop::AllEvents, 5);
  }
  return true;
}

// Pumps the event loop for `ms` milliseconds.
inline void Pump(int ms) {
  WaitFor([] { return false; }, ms);
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_QT_WAIT_H_
