// Workspace, by concern: the robot link. Connect prepares the link's
// options (the built-in simulator started here, TCP with its key file, a
// serial port), creates the RobotConnection on the I/O thread and relays
// its state, health, outages and failures to the GUI thread; a live cloud
// replaces the session shown. Disconnect shuts the connection down there.
#include <QMetaObject>
#include <QTimer>

#include "core/scenario/scenario.h"
#include "hardware/link/qt_transport.h"
#include "ui/workspace/live_processor.h"
#include "ui/workspace/sim_robot.h"
#include "ui/workspace/thread_call.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

constexpr int kHealthMs = 250;

}  // namespace

// The link's options and the live frame for `options`: the simulator (started
// here, with its scenario's geometry and start pose), TCP (key file) or serial.
bool Workspace::PrepareLink(const ConnectOptions& options,
                            hardware::RobotConnectionOptions* link_out, QString* error) {
  hardware::RobotConnectionOptions& link = *link_out;
  live_geometry_ = options.geometry;
  live_start_ = Pose2d();
  live_meta_ = SessionMeta();
  switch (options.kind) {
    case LinkKind::kSimulator: {
      sim::SimConfig scenario;
      const Status s = LoadScenario(options.scenario_path.toStdString(), &scenario);
      if (!s.ok()) {
        *error = QString::fromStdString(s.message());
        return false;
      }
      sim_ = std::make_unique<SimRobot>();
      if (!sim_->Start(scenario, error)) {
        sim_.reset();
        return false;
      }
      link.address = sim_->address();
      link.key = sim_->key();
      live_geometry_ = scenario.geometry;
      live_start_ = scenario.start;
      live_meta_.lidar_angle_convention = scenario.lidar.angle_convention;
      // The scenario travels with the recording: reopening places the cloud
      // in the same world frame (SessionStartPose).
      live_meta_.settings["scenario"] = ScenarioToJson(scenario);
      break;
    }
    case LinkKind::kTcp:
      link.address = QStringLiteral("tcp:%1:%2").arg(options.host).arg(options.port);
      if (options.key_file.isEmpty()) {
        *error = QStringLiteral("A TCP link needs the robot's key file (the agent's --key-file).");
        return false;
      }
      if (!hardware::ReadKeyFile(options.key_file, &link.key, error)) return false;
      break;
    case LinkKind::kSerial:
      if (options.serial_port.isEmpty()) {
        *error = QStringLiteral("Choose a serial port.");
        return false;
      }
      link.address = QStringLiteral("serial:%1:%2").arg(options.serial_port).arg(options.baud);
      break;
  }
  live_meta_.geometry = live_geometry_;
  // The robot's saved calibration applies to everything recorded from now on.
  live_meta_.calibration = robot_calibration_;
  link.session_meta = live_meta_;
  link.decoder.wheel_distance_m = live_geometry_.wheel_distance_m;
  link.decoder.lidar_angle_convention = live_meta_.lidar_angle_convention;
  return link.IsValid(error);
}

bool Workspace::Connect(const ConnectOptions& options, QString* error) {
  Disconnect();
  connect_options_ = options;
  hardware::RobotConnectionOptions link;
  if (!PrepareLink(options, &link, error)) {
    sim_.reset();
    return false;
  }
  ResetCloud(live_start_, live_geometry_);
  opened_.reset();
  opened_samples_released_ = false;
  opened_source_.reset();
  replay_loaded_ = false;
  replaying_ = false;
  // The live cloud replaces the session shown, as New Session does (a
  // recording's folder stays on disk): its name, its results and the
  // panels showing them go with it.
  session_dir_.clear();
  unsaved_ = false;
  ForgetSessionResults();
  emit sessionChanged(QString());
  health_ = hardware::LinkHealth();
  authenticated_ = false;

  // The connection is created, started and destroyed on the I/O thread.
  bool started = false;
  QString start_error;
  hardware::RobotConnection* connection = nullptr;
  LiveProcessor* processor = processor_;
  live_feed_ = std::make_shared<std::atomic<bool>>(true);  // Live preview until a recording stops.
  std::shared_ptr<std::atomic<bool>> feed = live_feed_;
  CallOnThread(&io_thread_, [&] {
    connection = new hardware::RobotConnection(link);
    // Decoded records leave the I/O thread at once, for the processing thread.
    QObject::connect(connection, &hardware::RobotConnection::telemetryDecoded, connection,
                     [connection, processor, feed] {
                       if (!*feed) {
                         connection->mutable_log()->wheels.clear();
                         connection->mutable_log()->imu.clear();
                         connection->mutable_log()->scans.clear();
                         return;
                       }
                       auto batch = std::make_shared<SensorLog>();
                       std::swap(*batch, *connection->mutable_log());
                       QMetaObject::invokeMethod(
                           processor, [processor, batch] { processor->AddRecords(*batch); });
                     });
    auto* health_timer = new QTimer(connection);
    QObject::connect(health_timer, &QTimer::timeout, connection, [this, connection] {
      const hardware::LinkHealth h = connection->health();
      QMetaObject::invokeMethod(this, [this, h] {
        health_ = h;
        emit healthUpdated();
      });
    });
    health_timer->start(kHealthMs);
    // Signals to the GUI thread are connected before Start(): on
    // loopback the agent may authenticate us before this call returns.
    QObject::connect(
        connection, &hardware::RobotConnection::stateChanged, this,
        [this](int state) {
          health_.state = static_cast<hardware::LinkHealth::State>(state);
          emit linkStateChanged(state);
        },
        Qt::QueuedConnection);
    QObject::connect(
        connection, &hardware::RobotConnection::authenticatedChanged, this,
        [this](bool a) {
          authenticated_ = a;
          // The lidar spins (and scans) as the operator last asked: on by default.
          if (a) SetLidarMotor(lidar_on_);
          emit authenticatedChanged(a);
        },
        Qt::QueuedConnection);
    // Outages (issue 31): the connection reconnects by itself; the operator
    // sees it in the status bar and may Disconnect to stop trying.
    QObject::connect(
        connection, &hardware::RobotConnection::linkLost, this,
        [this](const QString& reason) {
          health_.outage_open = true;
          // The agent's watchdog stopped the robot; nothing here may set it
          // moving again after the reconnection: the operator drives.
          AbortScriptedDrive();
          commanded_ = Twist2d();
          emit linkOutage(true, 0.0, reason);
        },
        Qt::QueuedConnection);
    QObject::connect(
        connection, &hardware::RobotConnection::linkRestored, this,
        [this](double seconds, const QString& details) {
          health_.outage_open = false;
          emit linkOutage(false, seconds, details);
        },
        Qt::QueuedConnection);
    QObject::connect(
        connection, &hardware::RobotConnection::recordingFailed, this,
        [this](const QString& error) {
          if (!recording_) return;
          QString closed;
          StopRecording(&closed);
          emit recordingFailed(
              tr("Writing the session failed: %1\n\nRecording has stopped; what was recorded "
                 "before is kept in %2.")
                  .arg(error, session_dir_));
        },
        Qt::QueuedConnection);
    QObject::connect(
        connection, &hardware::RobotConnection::authenticationFailed, this,
        [this](const QString& reason) {
          emit authenticationFailed(reason);
          emit message(QStringLiteral("The robot refused the connection: %1").arg(reason));
        },
        Qt::QueuedConnection);
    started = connection->Start(&start_error);
  });
  if (!started) {
    QMetaObject::invokeMethod(
        connection, [connection] { delete connection; }, Qt::BlockingQueuedConnection);
    sim_.reset();
    *error = start_error;
    return false;
  }
  connection_ = connection;
  return true;
}

void Workspace::Disconnect() {
  AbortScriptedDrive();
  if (connection_ != nullptr) {
    StopRecordingOrSay();
    hardware::RobotConnection* connection = connection_;
    connection_ = nullptr;
    connection->disconnect(this);
    QMetaObject::invokeMethod(
        connection,
        [connection] {
          connection->Shutdown();
          delete connection;
        },
        Qt::BlockingQueuedConnection);
    // Place the scans still waiting for poses.
    QMetaObject::invokeMethod(processor_, [p = processor_] { p->Finish(); });
  }
  sim_.reset();
  authenticated_ = false;
  if (health_.outage_open) {
    health_.outage_open = false;
    emit message(QStringLiteral("Disconnected: no longer reconnecting"));
  }
  health_.state = hardware::LinkHealth::State::kIdle;
  commanded_ = Twist2d();
  emit linkStateChanged(static_cast<int>(health_.state));
  emit authenticatedChanged(false);
}

void Workspace::InvokeOnConnection(std::function<void(hardware::RobotConnection*)> call) {
  if (connection_ == nullptr) return;
  hardware::RobotConnection* connection = connection_;
  QMetaObject::invokeMethod(connection, [connection, call] { call(connection); });
}

}  // namespace sweepscan::ui
