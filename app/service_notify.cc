#include "app/service_notify.h"

#include <QTimer>
#include <QtGlobal>
#include <algorithm>
#include <cstdint>

#ifdef SWEEPSCAN_HAVE_LIBSYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace sweepscan::app {
namespace {

void Notify(const QString& state) {
#ifdef SWEEPSCAN_HAVE_LIBSYSTEMD
  sd_notify(0, state.toUtf8().constData());
#else
  (void)state;
#endif
}

}  // namespace

ServiceNotifier::ServiceNotifier(QObject* parent) : QObject(parent) {
#ifdef SWEEPSCAN_HAVE_LIBSYSTEMD
  uint64_t usec = 0;
  // > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID (if set) is us.
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
    // sd_watchdog_enabled(3) recommends pinging at half the period.
    watchdog_interval_ms_ = static_cast<int>(std::max<uint64_t>(1, usec / 2000));
  }
#endif
}

bool ServiceNotifier::Supported() {
#ifdef SWEEPSCAN_HAVE_LIBSYSTEMD
  return true;
#else
  return false;
#endif
}

QString ServiceNotifier::MissingSupportWarning() {
  if (Supported() || qEnvironmentVariableIsEmpty("NOTIFY_SOCKET")) return QString();
  return QStringLiteral(
      "warning: NOTIFY_SOCKET is set (systemd runs this as a Type=notify service) but this "
      "build has no sd_notify support (built without libsystemd): systemd will not hear "
      "READY=1 and will fail the start at its timeout, nor WATCHDOG=1; rebuild with "
      "libsystemd-dev installed, or run it as Type=simple without WatchdogSec "
      "(systemctl edit sweepscan-robotd)");
}

void ServiceNotifier::Ready(const QString& status) {
  Notify(QStringLiteral("READY=1\nSTATUS=") + status);
  if (watchdog_interval_ms_ > 0 && watchdog_timer_ == nullptr) {
    watchdog_timer_ = new QTimer(this);
    connect(watchdog_timer_, &QTimer::timeout, this, [] { Notify(QStringLiteral("WATCHDOG=1")); });
    watchdog_timer_->start(watchdog_interval_ms_);
  }
}

void ServiceNotifier::Status(const QString& status) { Notify(QStringLiteral("STATUS=") + status); }

void ServiceNotifier::Stopping() {
  if (watchdog_timer_ != nullptr) watchdog_timer_->stop();
  Notify(QStringLiteral("STOPPING=1"));
}

}  // namespace sweepscan::app
