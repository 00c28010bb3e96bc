// Shared by the two agent executables (sweepscan-robotd, sweepscan-sim).
#ifndef SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_
#define SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_

#include <sys/socket.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QSocketNotifier>
#include <csignal>

#include "hardware/robot_agent.h"

namespace sweepscan::app {

namespace internal {
inline int signal_fds[2] = {-1, -1};
inline void OnSignal(int) {
  const char byte = 1;
  (void)!::write(signal_fds[1], &byte, 1);  // Async-signal-safe; the event loop does the rest.
}
}  // namespace internal

// Runs the event loop until SIGINT or SIGTERM, then shuts the agent down
// through the loop (a self-pipe wakes it), so the motors get their zero
// command before the process exits.
inline int RunAgentUntilSignal(QCoreApplication* app, hardware::RobotAgent* agent) {
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, internal::signal_fds) == 0) {
    auto* notifier = new QSocketNotifier(internal::signal_fds[0], QSocketNotifier::Read, app);
    QObject::connect(notifier, &QSocketNotifier::activated, app, &QCoreApplication::quit);
    ::signal(SIGINT, internal::OnSignal);
    ::signal(SIGTERM, internal::OnSignal);
  }
  const int rc = app->exec();
  agent->Shutdown();
  return rc;
}

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_AGENT_MAIN_COMMON_H_
