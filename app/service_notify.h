// Tells systemd about sweepscan-robotd (sd_notify(3)) when it runs as a
// Type=notify service: READY=1 once the link is served, STATUS= lines,
// STOPPING=1 on the way out, and WATCHDOG=1 from the event loop at half the
// unit's WatchdogSec, so a hung loop is killed and restarted by systemd.
// That is the service's watchdog; the link watchdog that stops the motors
// when the workstation goes quiet is the agent's own (docs/robot-agent.md).
// Without libsystemd (SWEEPSCAN_HAVE_LIBSYSTEMD unset) or outside systemd
// (no NOTIFY_SOCKET) every call does nothing; the first under systemd is a
// mistake (the Type=notify unit times out waiting for READY=1), which CMake
// warns about when it does not find libsystemd and robotd says at start-up
// (MissingSupportWarning).
#ifndef SWEEPSCAN_APP_SERVICE_NOTIFY_H_
#define SWEEPSCAN_APP_SERVICE_NOTIFY_H_

#include <QObject>
#include <QString>

class QTimer;

namespace sweepscan::app {

class ServiceNotifier : public QObject {
 public:
  explicit ServiceNotifier(QObject* parent = nullptr);
  // READY=1 with a status line, and starts the watchdog pings if the unit
  // asked for them (WATCHDOG_USEC for this process).
  void Ready(const QString& status);
  void Status(const QString& status);
  void Stopping();
  // The watchdog ping interval, 0 when systemd asked for none.
  int watchdog_interval_ms() const { return watchdog_interval_ms_; }
  // Built with libsystemd: the calls above reach systemd.
  static bool Supported();
  // A line for the log when systemd waits for notifications (NOTIFY_SOCKET
  // is set) that this build cannot send; empty otherwise.
  static QString MissingSupportWarning();

 private:
  int watchdog_interval_ms_ = 0;
  QTimer* watchdog_timer_ = nullptr;
};

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_SERVICE_NOTIFY_H_
