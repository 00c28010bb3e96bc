// SIGINT, SIGTERM, SIGHUP and SIGQUIT end a Qt event loop cleanly: the
// handler only writes a byte to a self-pipe (async-signal-safe), and the
// loop quits when it reads it, so whatever runs after exec() (stopping the
// motors, closing a session) runs on the loop's thread as usual. Shared by
// sweepscan-robotd, sweepscan-sim and `sweepscan-cli record`.
//
// SIGHUP (the ssh session or terminal that started it closed) and SIGQUIT
// (Ctrl+\) are taken too: their default action ends the process at once,
// which left a robot driving at its last command and a recording without
// its last records and summary. A signal already ignored (nohup) is left so.
#ifndef SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_
#define SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QSocketNotifier>
#include <cerrno>
#include <csignal>

namespace sweepscan::app {

namespace internal {
inline int signal_fds[2] = {-1, -1};
inline volatile std::sig_atomic_t last_signal = 0;
inline void OnSignal(int signal) {
  const int saved_errno = errno;  // A handler must not change the errno it interrupted.
  if (last_signal == 0) last_signal = signal;
  const char byte = 1;
  (void)!::write(signal_fds[1], &byte, 1);  // Non-blocking: a full pipe already says quit.
  errno = saved_errno;
}
}  // namespace internal

inline constexpr int kQuitSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};

// Installs the handlers (once; later calls do nothing); `app` quits on the
// first of kQuitSignals. Call it before anything that must be undone on the
// way out starts (the agent opening the motor board's port), so there is no
// window in which a signal kills the process outright.
inline void QuitOnSignals(QCoreApplication* app) {
  if (internal::signal_fds[0] >= 0) return;
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, internal::signal_fds) != 0) return;
  ::fcntl(internal::signal_fds[1], F_SETFL, ::fcntl(internal::signal_fds[1], F_GETFL) | O_NONBLOCK);
  auto* notifier = new QSocketNotifier(internal::signal_fds[0], QSocketNotifier::Read, app);
  QObject::connect(notifier, &QSocketNotifier::activated, app, &QCoreApplication::quit);
  struct sigaction action {};
  action.sa_handler = internal::OnSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  for (const int signal : kQuitSignals) {
    // A signal the caller set to be ignored stays ignored: `nohup robotd`
    // asks to outlive the terminal, and a handler for SIGHUP would stop it
    // when the ssh session closes (SIGINT is ignored for `cmd &` in a
    // non-interactive shell, alike).
    struct sigaction old {};
    if (::sigaction(signal, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    ::sigaction(signal, &action, nullptr);
  }
}

// The signal that ended the loop (one of kQuitSignals), 0 if none.
inline int QuitSignal() { return internal::last_signal; }

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_QUIT_ON_SIGNAL_H_
