#include "app/service_notify.h"

#include <poll.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QTimer>
#include <QtGlobal>
#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <utility>

namespace sweepscan::app {
namespace {

// The value's digits as a positive decimal number, or 0.
uint64_t ParsePositive(const QByteArray& value) {
  bool ok = false;
  const qulonglong n = value.toULongLong(&ok, 10);
  return ok ? n : 0;
}

// The first line of a message, for the log ("READY=1").
QString FirstLine(const QByteArray& state) {
  const int end = state.indexOf('\n');
  return QString::fromUtf8(end < 0 ? state : state.left(end));
}

}  // namespace

bool ParseNotifySocket(const QByteArray& value, NotifyAddress* out, QString* error) {
  *out = NotifyAddress{};
  out->address.sun_family = AF_UNIX;
  const size_t room = sizeof(out->address.sun_path);  // 108 on Linux.
  if (value.startsWith("vsock:")) {
    *error = QStringLiteral(
        "is an AF_VSOCK address (a service manager outside this machine's kernel, e.g. a VM's "
        "host), which robotd does not support");
    return false;
  }
  if (value.startsWith('@')) {
    // The abstract namespace: a leading NUL, then the name; the length
    // covers the name exactly (no NUL after it: it would be part of it).
    const QByteArray name = value.mid(1);
    if (name.isEmpty()) {
      *error = QStringLiteral("is an empty abstract socket name");
      return false;
    }
    if (static_cast<size_t>(name.size()) + 1 > room) {
      *error = QStringLiteral("is an abstract socket name of %1 bytes; sun_path has room for %2")
                   .arg(name.size())
                   .arg(room - 1);
      return false;
    }
    out->address.sun_path[0] = '\0';
    std::memcpy(out->address.sun_path + 1, name.constData(), static_cast<size_t>(name.size()));
    out->length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 +
                                         static_cast<size_t>(name.size()));
    return true;
  }
  if (!value.startsWith('/')) {
    *error = QStringLiteral("is neither an absolute path nor an abstract name ('@...')");
    return false;
  }
  if (static_cast<size_t>(value.size()) + 1 > room) {
    *error = QStringLiteral("is a path of %1 bytes; sun_path has room for %2 and its NUL")
                 .arg(value.size())
                 .arg(room - 1);
    return false;
  }
  std::memcpy(out->address.sun_path, value.constData(), static_cast<size_t>(value.size()));
  out->address.sun_path[value.size()] = '\0';
  out->length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) +
                                       static_cast<size_t>(value.size()) + 1);
  return true;
}

ServiceNotifier::Environment ServiceNotifier::Environment::FromProcess() {
  Environment e;
  e.notify_socket = qgetenv("NOTIFY_SOCKET");
  e.watchdog_usec = qgetenv("WATCHDOG_USEC");
  e.watchdog_pid = qgetenv("WATCHDOG_PID");
  return e;
}

ServiceNotifier::ServiceNotifier(QObject* parent)
    : ServiceNotifier(
          Environment::FromProcess(),
          [](const QString& line) {
            const QString program = QCoreApplication::applicationName();
            std::fprintf(
                stderr, "%s: %s\n",
                qPrintable(program.isEmpty() ? QStringLiteral("sweepscan-robotd") : program),
                qPrintable(line));
          },
          parent) {}

ServiceNotifier::ServiceNotifier(const Environment& environment, Log log, QObject* parent)
    : QObject(parent), log_(std::move(log)), socket_name_(environment.notify_socket) {
  if (environment.notify_socket.isEmpty()) return;  // Not under a service manager.
  QString why;
  if (!ParseNotifySocket(environment.notify_socket, &address_, &why)) {
    Say(QStringLiteral("warning: NOTIFY_SOCKET=%1 %2: the service manager will not be told "
                       "anything (not READY=1: a Type=notify unit fails its start at its "
                       "timeout; nor WATCHDOG=1)")
            .arg(QString::fromUtf8(environment.notify_socket), why));
    return;
  }
  active_ = true;
  if (environment.watchdog_usec.isEmpty()) return;
  const uint64_t usec = ParsePositive(environment.watchdog_usec);
  if (usec == 0) {
    Say(QStringLiteral("warning: WATCHDOG_USEC=%1 is not a positive number of microseconds: "
                       "no WATCHDOG=1 pings")
            .arg(QString::fromUtf8(environment.watchdog_usec)));
    return;
  }
  // WATCHDOG_PID, when set, names the process the pings are wanted from
  // (the unit's main process); a child that inherited it stays quiet.
  if (!environment.watchdog_pid.isEmpty() &&
      ParsePositive(environment.watchdog_pid) != static_cast<uint64_t>(::getpid())) {
    return;
  }
  // At half the period, as sd_watchdog_enabled(3) recommends.
  watchdog_interval_ms_ = static_cast<int>(std::clamp<uint64_t>(usec / 2000, 1, INT32_MAX));
}

void ServiceNotifier::Say(const QString& line) const {
  if (log_) log_(line);
}

bool ServiceNotifier::Send(const QByteArray& state, int wait_ms) {
  if (!active_) return false;
  const char* step = "socket";
  int error = 0;
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) {
    error = errno;
  } else {
    // Connected, so that POLLOUT below reflects room in the manager's queue.
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address_.address), address_.length) != 0) {
      step = "connect";
      error = errno;
    } else {
      step = "send";
      QElapsedTimer clock;
      clock.start();
      for (;;) {
        const ssize_t n =
            ::send(fd, state.constData(), static_cast<size_t>(state.size()), MSG_NOSIGNAL);
        if (n == static_cast<ssize_t>(state.size())) break;
        error = n < 0 ? errno : EMSGSIZE;
        if (error == EINTR) continue;
        if (error != EAGAIN && error != EWOULDBLOCK) break;
        const qint64 left = wait_ms - clock.elapsed();
        if (left <= 0) break;
        pollfd p{fd, POLLOUT, 0};
        if (::poll(&p, 1, static_cast<int>(left)) < 0 && errno != EINTR) break;
        error = 0;
      }
    }
    ::close(fd);
  }
  if (error == 0) return true;
  if (!failure_logged_) {
    failure_logged_ = true;
    Say(QStringLiteral("warning: service notification %1 to NOTIFY_SOCKET=%2 not sent (%3: %4); "
                       "running on; further failures are not logged")
            .arg(FirstLine(state), QString::fromUtf8(socket_name_), QString::fromLatin1(step),
                 QString::fromLocal8Bit(std::strerror(error))));
  }
  return false;
}

void ServiceNotifier::Ready(const QString& status) {
  Send(QByteArrayLiteral("READY=1\nSTATUS=") + status.toUtf8(), 1000);
  if (active_ && watchdog_interval_ms_ > 0 && watchdog_timer_ == nullptr) {
    watchdog_timer_ = new QTimer(this);
    connect(watchdog_timer_, &QTimer::timeout, this,
            [this] { Send(QByteArrayLiteral("WATCHDOG=1")); });
    watchdog_timer_->start(watchdog_interval_ms_);
  }
}

void ServiceNotifier::Status(const QString& status) {
  Send(QByteArrayLiteral("STATUS=") + status.toUtf8());
}

void ServiceNotifier::Stopping() {
  if (watchdog_timer_ != nullptr) watchdog_timer_->stop();
  Send(QByteArrayLiteral("STOPPING=1"), 1000);
}

}  // namespace sweepscan::app
