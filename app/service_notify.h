// Tells the service manager about sweepscan-robotd when it runs as a
// Type=notify service, speaking the notification protocol of sd_notify(3)
// itself (no libsystemd): each message is one AF_UNIX datagram of
// newline-separated KEY=VALUE assignments, no trailing newline, sent to the
// socket named by $NOTIFY_SOCKET (a path, or with a leading '@' a name in
// the abstract namespace). robotd sends READY=1 with a STATUS= line once the
// link is served, STATUS= lines as clients come and go, STOPPING=1 on the
// way out, and WATCHDOG=1 from the event loop at half the unit's
// WatchdogSec, so a hung loop is killed and restarted by systemd. That is
// the service's watchdog; the link watchdog that stops the motors when the
// workstation goes quiet is the agent's own (docs/robot-agent.md, which
// lists the datagrams).
//
// Outside systemd (NOTIFY_SOCKET unset or empty) every call does nothing.
// Nothing here is fatal: an address robotd cannot use (vsock:, a relative
// path, a path too long for sun_path) is said once in the log at start-up
// and nothing is sent; a send that fails is said once (the first failure),
// and the agent runs on. A send never holds the event loop for long: the
// socket is non-blocking, and a manager whose queue is full is waited for
// at most 1 s for READY=1 and STOPPING=1 and not at all for STATUS= and
// WATCHDOG=1, which are dropped (a manager that reads nothing must not stop
// the loop that runs the motors' watchdog).
#ifndef SWEEPSCAN_APP_SERVICE_NOTIFY_H_
#define SWEEPSCAN_APP_SERVICE_NOTIFY_H_

#include <sys/socket.h>
#include <sys/un.h>

#include <QByteArray>
#include <QObject>
#include <QString>
#include <functional>

class QTimer;

namespace sweepscan::app {

// NOTIFY_SOCKET parsed into the AF_UNIX address to send to.
struct NotifyAddress {
  sockaddr_un address{};
  socklen_t length = 0;  // What to pass to connect(): no NUL after an abstract name.
};

// `value` as $NOTIFY_SOCKET holds it: "/path" or "@abstract-name". False
// with the reason (for the log) for anything else: "vsock:CID:PORT" (not
// supported), a relative path, an empty abstract name, or a name or path
// too long for sun_path (a path needs room for its NUL: 107 bytes at most;
// an abstract name 107 after its leading NUL).
bool ParseNotifySocket(const QByteArray& value, NotifyAddress* out, QString* error);

class ServiceNotifier : public QObject {
 public:
  // Where the notifier's few log lines go (one line, no trailing newline).
  using Log = std::function<void(const QString&)>;
  // What the service manager put in the environment; FromProcess() reads it.
  struct Environment {
    QByteArray notify_socket;  // Empty: not under a service manager.
    QByteArray watchdog_usec;  // WatchdogSec in microseconds, empty if none.
    QByteArray watchdog_pid;   // The pid the watchdog is for, empty if not said.
    static Environment FromProcess();
  };

  // From this process's environment; the log to stderr ("sweepscan-robotd: ...").
  explicit ServiceNotifier(QObject* parent = nullptr);
  ServiceNotifier(const Environment& environment, Log log, QObject* parent = nullptr);

  // READY=1 with a status line, and starts the watchdog pings if the unit
  // asked for them (WATCHDOG_USEC, WATCHDOG_PID unset or this process).
  void Ready(const QString& status);
  void Status(const QString& status);
  void Stopping();
  // Sends `state` as it is (one datagram); false if it was not sent (or
  // there is no manager to send it to). `wait_ms`: how long a full queue
  // at the manager's end is waited for.
  bool Send(const QByteArray& state, int wait_ms = 0);

  // A manager is there to be told (NOTIFY_SOCKET set and usable).
  bool active() const { return active_; }
  // The watchdog ping interval, 0 when the service manager asked for none.
  int watchdog_interval_ms() const { return watchdog_interval_ms_; }

 private:
  void Say(const QString& line) const;

  Log log_;
  NotifyAddress address_;
  QByteArray socket_name_;  // As given, for the log.
  bool active_ = false;
  bool failure_logged_ = false;
  int watchdog_interval_ms_ = 0;
  QTimer* watchdog_timer_ = nullptr;
};

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_SERVICE_NOTIFY_H_
