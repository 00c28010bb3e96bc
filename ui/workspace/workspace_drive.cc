// Workspace, by concern: driving the robot (teleop, emergency stop, the
// lidar motor, scripted drives such as the calibration circle) and the
// bench check of a device plugged straight into the computer.
#include <QStringList>
#include <QTimer>
#include <algorithm>

#include "hardware/link/qt_transport.h"
#include "ui/workspace/thread_call.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

constexpr int kScriptTickMs = 100;  // Drive commands at 10 Hz, as the keyboard sends them.

}  // namespace

// ---------------------------------------------------------------------------
// Bench check

namespace {

QString DeviceReport(const hardware::DirectDevice& d, double seconds, bool* ok) {
  QStringList lines;
  const hardware::DecoderStats& stats = d.stats();
  if (d.kind() == hardware::DirectDevice::Kind::kX4) {
    const hardware::X4DeviceInfo& info = d.device_info();
    const bool have_info = info.model != 0;
    lines << (have_info ? QStringLiteral("YDLIDAR model %1 (X4 = 6), firmware %2.%3, hardware %4, "
                                         "serial %5")
                              .arg(info.model)
                              .arg(info.firmware >> 8)
                              .arg(info.firmware & 0xff)
                              .arg(info.hardware)
                              .arg(QString::fromStdString(info.SerialString()))
                        : QStringLiteral("No device-info reply: is this an X4, at 128000 baud?"));
    const char* health[] = {"good", "warning", "error"};
    lines << QStringLiteral("Health: %1 (error code %2)")
                 .arg(QString::fromLatin1(health[std::min<int>(d.health().status, 2)]))
                 .arg(d.health().error_code);
    lines << QStringLiteral("%1 revolutions in %2 s (%3 Hz)")
                 .arg(d.scans_received())
                 .arg(seconds, 0, 'f', 1)
                 .arg(d.scans_received() / seconds, 0, 'f', 1);
    *ok = have_info && d.scans_received() > 0 && d.health().status == 0;
  } else {
    lines << QStringLiteral("%1 HI219 samples in %2 s (%3 Hz)")
                 .arg(d.imu_samples_received())
                 .arg(seconds, 0, 'f', 1)
                 .arg(d.imu_samples_received() / seconds, 0, 'f', 1);
    *ok = d.imu_samples_received() > 0;
  }
  lines << QStringLiteral("Frames: %1 good, %2 checksum errors, %3 bytes skipped")
               .arg(stats.frames_ok)
               .arg(stats.checksum_errors)
               .arg(stats.bytes_skipped);
  if (stats.checksum_errors > 0) {
    lines << QStringLiteral("Checksum errors: check the cable and the baud rate.");
  }
  return lines.join(QLatin1Char('\n'));
}

}  // namespace

void Workspace::CheckDevice(hardware::DirectDevice::Kind kind, const QString& port,
                            double seconds) {
  CallOnThread(&io_thread_, [this, kind, port, seconds] {
    auto* device = new hardware::DirectDevice(kind, port);
    QString error;
    if (!device->Open(&error)) {
      delete device;
      QMetaObject::invokeMethod(this, [this, error] {
        emit deviceCheckFinished(false, QStringLiteral("Cannot open the port: %1").arg(error));
      });
      return;
    }
    if (kind == hardware::DirectDevice::Kind::kX4) {
      device->RequestDeviceInfo();
      device->RequestHealth();
      device->StartScan();
    }
    QTimer::singleShot(static_cast<int>(seconds * 1000), device, [this, device, seconds] {
      bool ok = false;
      const QString report = DeviceReport(*device, seconds, &ok);
      if (device->kind() == hardware::DirectDevice::Kind::kX4) device->StopScan();
      device->Close();
      device->deleteLater();
      QMetaObject::invokeMethod(this, [this, ok, report] { emit deviceCheckFinished(ok, report); });
    });
  });
}

// ---------------------------------------------------------------------------
// Driving

void Workspace::Drive(double v_mps, double w_radps) {
  commanded_.v = std::clamp(v_mps, -limits_.v_max_mps, limits_.v_max_mps);
  commanded_.w = std::clamp(w_radps, -limits_.w_max_radps, limits_.w_max_radps);
  const Twist2d t = commanded_;
  InvokeOnConnection([t](hardware::RobotConnection* c) { c->Drive(t.v, t.w); });
}

void Workspace::StopMotion() {
  commanded_ = Twist2d();
  InvokeOnConnection([](hardware::RobotConnection* c) { c->StopMotion(); });
}

void Workspace::EmergencyStop() {
  AbortScriptedDrive();
  commanded_ = Twist2d();
  InvokeOnConnection([](hardware::RobotConnection* c) { c->EmergencyStop(); });
  QString said = QStringLiteral("EMERGENCY STOP: the robot is halted until you clear it.");
  if (connection_ == nullptr) {
    // Not the stop's usual reassurance: nothing received it.
    said = QStringLiteral("No robot connected: nothing to stop.");
  } else if (health_.state == hardware::LinkHealth::State::kFailed) {
    said = QStringLiteral(
               "EMERGENCY STOP, but the link has failed (%1): the stop cannot reach the robot. Its "
               "watchdog stopped it when the link was lost; stop it at the robot.")
               .arg(health_.last_error);
  } else if (!authenticated_) {
    said = QStringLiteral(
        "EMERGENCY STOP while the link is down: the robot's watchdog stopped it when the link was "
        "lost; the stop is sent and latched as soon as the link returns.");
  }
  emit message(said);
  emit emergencyStopped();
}

void Workspace::ClearEmergencyStop() {
  InvokeOnConnection([](hardware::RobotConnection* c) { c->ClearEmergencyStop(); });
}

void Workspace::SetLidarMotor(bool on) {
  lidar_on_ = on;
  InvokeOnConnection([on](hardware::RobotConnection* c) { c->SetLidarMotor(on); });
}

std::vector<sim::DriveSegment> Workspace::CirclePath(double radius_m, double speed_mps,
                                                     double turns) {
  // A circle of radius r at speed v: w = v / r for 2 pi r turns / v seconds,
  // with a second of standstill before (the filter's start) and after.
  std::vector<sim::DriveSegment> path;
  if (radius_m <= 0 || speed_mps <= 0 || turns <= 0) return path;
  path.push_back({0.0, 0.0, 1.0});
  path.push_back({speed_mps, speed_mps / radius_m, 2.0 * M_PI * radius_m * turns / speed_mps});
  path.push_back({0.0, 0.0, 1.0});
  return path;
}

void Workspace::StartScriptedDrive(const std::vector<sim::DriveSegment>& path,
                                   const QString& what) {
  AbortScriptedDrive();
  if (path.empty()) return;
  script_name_ = what;
  // The app's script ticks on the GUI thread, and a GUI hiccup does not
  // stop the robot: the I/O thread keeps its link fed. Only a stall long
  // enough to be the whole process (a suspend, SIGSTOP) aborts on the
  // clocks; a shorter freeze of the whole process trips the robot's
  // watchdog, whose report aborts the script at the next Status.
  hardware::DriveScriptOptions options;
  options.max_loop_gap_ns = 2'000'000'000;
  script_.emplace(path, options);
  script_timer_ = new QTimer(this);
  script_timer_->setTimerType(Qt::PreciseTimer);
  connect(script_timer_, &QTimer::timeout, this, &Workspace::OnScriptTick);
  script_->Start(hardware::ScriptClocks::Now());
  script_timer_->start(kScriptTickMs);
  OnScriptTick();
}

void Workspace::AbortScriptedDrive() {
  if (script_timer_ == nullptr) return;
  script_timer_->stop();
  script_timer_->deleteLater();
  script_timer_ = nullptr;
  StopMotion();
}

void Workspace::OnScriptTick() {
  // health_ is the I/O thread's copy of at most kHealthMs ago; a freeze of
  // the whole process is caught by the script's own clocks first.
  const hardware::DriveScript::Step step = script_->Tick(
      hardware::ScriptClocks::Now(), health_.have_status ? &health_.agent_status : nullptr);
  if (step.action == hardware::DriveScript::Action::kDrive) {
    Drive(step.v, step.w);
    return;
  }
  const double at_s = script_->elapsed_s();
  AbortScriptedDrive();
  if (step.action == hardware::DriveScript::Action::kDone) {
    emit message(QStringLiteral("Scripted drive finished."));
  } else {
    emit message(QStringLiteral("Scripted drive aborted at %1 s: %2. The robot stays stopped "
                                "until you drive it.")
                     .arg(at_s, 0, 'f', 1)
                     .arg(QString::fromStdString(step.reason)));
  }
}


}  // namespace sweepscan::ui
