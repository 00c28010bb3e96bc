// SIGINT and SIGTERM end a Qt event loop cleanly: the handler only writes a
// byte to a self-pipe (async-signal-safe), and the loop quits when it reads
// it, so whatever runs after exec() (stopping the motors, closing a session)
// runs on the loop's thread as usual. Shared by sweepscan-robotd,
// sweepscan-sim and `sweepscan-cli record`.
#ifndef SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_
#define SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_

#include <sys/socket.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QSocketNotifier>
#include <csignal>

namespace sweepscan::app {

namespace internal {
inline int signal_fds[2] = {-1, -1};
inline volatile std::sig_atomic_t last_signal = 0;
inline void OnSignal(int signal) {
  last_signal = signal;
  const char byte = 1;
  (void)!::write(signal_fds[1], &byte, 1);
}
}  // namespace internal

// Installs the handlers; `app` quits on the first SIGINT or SIGTERM.
inline void QuitOnSignals(QCoreApplication* app) {
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, internal::signal_fds) != 0) return;
  auto* notifier = new QSocketNotifier(internal::signal_fds[0], QSocketNotifier::Read, app);
  QObject::connect(notifier, &QSocketNotifier::activated, app, &QCoreApplication::quit);
  ::signal(SIGINT, internal::OnSignal);
  ::signal(SIGTERM, internal::OnSignal);
}

// The signal that ended the loop (SIGINT, SIGTERM), 0 if none.
inline int QuitSignal() { return internal::last_signal; }

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_
