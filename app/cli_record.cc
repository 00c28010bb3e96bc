// `sweepscan-cli record`: the headless recorder. Connects to a robot agent
// (sweepscan-robotd or sweepscan-sim) over TCP or a serial link with the
// app's own RobotConnection, records a session exactly as the app does
// (same frames, same crash-safe writer: everything older than a second is on
// disk whatever happens to the process), prints the link's health once a
// second, and stops cleanly on Ctrl+C, SIGTERM, SIGHUP (the ssh session
// that ran it closed), SIGQUIT, --duration or the end of a drive script,
// sending Stop first and turning the lidar off.
#include <QCoreApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QTimer>
#include <nlohmann/json.hpp>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/quit_on_signal.h"
#include "core/calibration/calibration_file.h"
#include "core/scenario/scenario.h"
#include "hardware/link/qt_transport.h"
#include "hardware/station/drive_script.h"
#include "hardware/station/robot_connection.h"

namespace sweepscan::app {

const char* const kRecordUsage =
    "usage: sweepscan-cli record --connect HOST:PORT --key-file K --out NAME.sweepscan [options]\n"
    "       sweepscan-cli record --serial PORT[@BAUD] --out NAME.sweepscan [options]\n"
    "\n"
    "Records a session from a robot agent (sweepscan-robotd, or sweepscan-sim) as the\n"
    "app does: every link frame, durable at least once a second, so a crash or a\n"
    "power cut keeps everything older than a second. Prints the link's health on\n"
    "stderr once a second. Ctrl+C, SIGTERM, SIGHUP (the terminal or ssh session closed)\n"
    "or SIGQUIT stops the robot and closes the session.\n"
    "A link that drops or stays silent for --stall-s reconnects by itself with backoff;\n"
    "the session goes on in the same folder with the gap recorded (`info` lists it), and\n"
    "the robot sends what it buffered meanwhile (robotd --buffer-s). A reconnection never\n"
    "drives: a --drive-script is aborted at the first outage, at a watchdog stop the robot\n"
    "reports, or when this process was stopped or suspended for longer than the robot's\n"
    "watchdog (0.5 s); the robot stays stopped and the recording goes on.\n"
    "\n"
    "Options:\n"
    "  --connect HOST:PORT    the agent's TCP address (robotd's --listen)\n"
    "  --key-file K           the agent's pre-shared key (robotd's --key-file)\n"
    "  --serial PORT[@BAUD]   the link on a serial port instead (default 921600 baud)\n"
    "  --out NAME.sweepscan   the new session folder (must not exist)\n"
    "  --duration S           stop after S seconds of recording (default: until Ctrl+C,\n"
    "                         or the end of the drive script)\n"
    "  --drive-script FILE    drive this path while recording: {\"segments\": [...]} with the\n"
    "                         segments of a scenario's path, or a scenario file (its path);\n"
    "                         docs/scenario-format.md \"Drive scripts\"\n"
    "  --scenario FILE        the simulated world behind sweepscan-sim, stored in the session\n"
    "                         so that it reopens in the scenario's frame (as the app does)\n"
    "  --calibration FILE     the robot's mounting error, stored as the session's calibration\n"
    "  --connect-timeout S    give up if no authenticated link within S seconds (default 10)\n"
    "  --stall-s S            a link silent this long is dropped and reconnected (default 2)\n"
    "  --keep-lidar           leave the lidar spinning at the end (another recording follows);\n"
    "                         by default it is turned off\n"
    "  --json                 print the summary as JSON on stdout\n"
    "\n"
    "Exit codes: 0 recorded, 1 the link never came up, the session could not be\n"
    "written, or the drive script was aborted (the session is kept), 2 bad options or\n"
    "the key was refused.\n";

namespace {

struct RecordOptions {
  hardware::RobotConnectionOptions link;
  QString out;
  double duration_s = -1.0;  // < 0: until a signal (or the script's end).
  double connect_timeout_s = 10.0;
  std::vector<sim::DriveSegment> script;
  SessionMeta meta;
};

bool ParsePositive(const Args& args, const std::string& key, double* out) {
  if (!args.Has(key)) return true;
  const std::string v = args.Get(key);
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  // Below 2e6 s (23 days): Qt's timers count milliseconds in an int.
  if (v.empty() || *end != '\0' || !(d > 0.0) || !(d < 2e6)) {
    PrintError("--" + key + " expects a positive number of seconds below 2000000, got '" + v + "'");
    return false;
  }
  *out = d;
  return true;
}

// Returns kExitOk or the exit code of the error it printed.
int ParseRecordOptions(const Args& args, RecordOptions* o) {
  if (!args.positional().empty()) {
    PrintError("unexpected argument '" + args.positional()[0] + "'");
    return kExitBadInput;
  }
  if (args.Has("connect") == args.Has("serial")) {
    PrintError("give either --connect HOST:PORT or --serial PORT");
    return kExitBadInput;
  }
  if (!args.Has("out")) {
    PrintError("record needs --out NAME.sweepscan (a new session folder)");
    return kExitBadInput;
  }
  // The options' values before any file is read: a mistyped number is said
  // as such, not behind a key file's error.
  double stall_s = o->link.stall_ms * 1e-3;
  if (!ParsePositive(args, "duration", &o->duration_s) ||
      !ParsePositive(args, "connect-timeout", &o->connect_timeout_s) ||
      !ParsePositive(args, "stall-s", &stall_s)) {
    return kExitBadInput;
  }
  o->link.stall_ms = static_cast<int>(stall_s * 1e3 + 0.5);
  o->out = QString::fromStdString(args.Get("out"));
  if (QFileInfo::exists(o->out)) {
    PrintError(args.Get("out") + ": exists; record writes a new session folder");
    return kExitFailure;  // an output in the way, as for every command (README)
  }
  QString error;
  hardware::LinkAddress address;
  const QString text = args.Has("connect") ? "tcp:" + QString::fromStdString(args.Get("connect"))
                                           : "serial:" + QString::fromStdString(args.Get("serial"));
  if (!hardware::ParseLinkAddress(text, &address, &error)) {
    PrintError(error.toStdString());
    return kExitBadInput;
  }
  o->link.address = text;
  o->link.client_name = "sweepscan-cli 0.1.0 record";
  if (args.Has("serial")) {
    const int refused = RefuseOptions(
        args, {"key-file"}, "--serial (a serial link is not authenticated: physical access)");
    if (refused != kExitOk) return refused;
  }
  if (args.Has("connect")) {
    if (!args.Has("key-file")) {
      PrintError("--connect needs --key-file K (the robot's key; robotd's --key-file)");
      return kExitBadInput;
    }
    QString warning;
    if (!hardware::ReadKeyFile(QString::fromStdString(args.Get("key-file")), &o->link.key, &error,
                               hardware::KeyFilePermissions::kWarn, &warning)) {
      PrintError(error.toStdString());
      return kExitBadInput;
    }
    if (!warning.isEmpty()) std::cerr << "sweepscan-cli: warning: " << warning.toStdString() << "\n";
  }
  if (args.Has("drive-script")) {
    const Status s = LoadDriveScript(args.Get("drive-script"), &o->script);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  // The session's meta as the app fills it (ui/workspace/workspace.cc,
  // PrepareLink): the simulator's scenario and geometry, the calibration.
  if (args.Has("scenario")) {
    sim::SimConfig scenario;
    const Status s = LoadScenario(args.Get("scenario"), &scenario);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    o->meta.geometry = scenario.geometry;
    o->meta.lidar_angle_convention = scenario.lidar.angle_convention;
    o->meta.settings["scenario"] = ScenarioToJson(scenario);
  }
  if (args.Has("calibration")) {
    const Status s = LoadCalibrationFile(args.Get("calibration"), &o->meta.calibration);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  o->link.session_meta = o->meta;
  o->link.decoder.wheel_distance_m = o->meta.geometry.wheel_distance_m;
  o->link.decoder.lidar_angle_convention = o->meta.lidar_angle_convention;
  if (!o->link.IsValid(&error)) {
    PrintError(error.toStdString());
    return kExitBadInput;
  }
  return kExitOk;
}

// One line a second on stderr: what an operator watches over ssh.
void PrintHealth(double elapsed_s, const hardware::LinkHealth& h, bool recording) {
  std::fprintf(stderr,
               "%7.1f s  %-12s  lidar %5.1f/s  imu %5.1f/s  motor %5.1f/s  %6.1f kB/s  "
               "lost %llu  crc %llu  rtt %.1f ms  records %llu%s\n",
               elapsed_s, hardware::LinkHealth::StateName(h.state), h.devices[0].frames_per_s,
               h.devices[1].frames_per_s, h.devices[2].frames_per_s, h.bytes_per_s / 1e3,
               static_cast<unsigned long long>(h.frames_missing),
               static_cast<unsigned long long>(h.crc_errors), h.latency_last_ms,
               static_cast<unsigned long long>(h.session_records), recording ? "" : "  (not recording)");
  if (h.state != hardware::LinkHealth::State::kConnected && !h.last_error.isEmpty()) {
    std::fprintf(stderr, "          last error: %s\n", qPrintable(h.last_error));
  }
}

}  // namespace

int RunRecord(int argc, char** argv) {
  Args args({"json", "help", "keep-lidar"}, {"connect", "key-file", "serial", "out", "duration", "drive-script",
                               "scenario", "calibration", "connect-timeout", "stall-s"});
  std::string parse_error;
  if (!args.Parse(argc, argv, 2, &parse_error)) {
    PrintError(SeeHelp(parse_error, "record"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kRecordUsage;
    return kExitOk;
  }
  RecordOptions o;
  if (const int code = ParseRecordOptions(args, &o); code != kExitOk) return code;

  int qt_argc = 1;
  QCoreApplication app(qt_argc, argv);
  QuitOnSignals(&app);
  hardware::RobotConnection connection(o.link);
  QString error;
  if (!connection.Start(&error)) {
    PrintError(error.toStdString());
    return kExitBadInput;
  }

  int exit_code = kExitOk;
  QString refused;
  QElapsedTimer clock;  // Since the session started.
  QElapsedTimer since_start;
  since_start.start();
  QTimer script_timer;
  script_timer.setTimerType(Qt::PreciseTimer);
  hardware::DriveScript script(o.script);

  // The session starts when the link is authenticated (as the app's Record
  // button on a connected link) and stays open across reconnections.
  QObject::connect(&connection, &hardware::RobotConnection::authenticatedChanged, &app, [&](bool on) {
    if (!on) return;
    // The lidar's motor on at every (re)connection, as the app does: the
    // agent may have stopped it when the link dropped.
    connection.SetLidarMotor(true);
    if (connection.recording()) return;
    QString start_error;
    if (!connection.StartRecording(o.out, o.meta, &start_error)) {
      PrintError(start_error.toStdString());
      exit_code = kExitFailure;
      app.quit();
      return;
    }
    clock.start();
    std::fprintf(stderr, "recording to %s from %s (%s)\n", qPrintable(o.out), qPrintable(o.link.address),
                 connection.health().agent_name.c_str());
    if (o.duration_s > 0) QTimer::singleShot(static_cast<int>(o.duration_s * 1e3), &app, &QCoreApplication::quit);
    if (!o.script.empty()) {
      script.Start(hardware::ScriptClocks::Now());
      script_timer.start(100);  // 10 Hz, as the app's scripted drives.
    }
  });
  // An aborted script leaves the robot stopped (the recording goes on until
  // Ctrl+C or --duration): nothing here may set it moving again.
  auto say_script_aborted = [&] {
    script_timer.stop();
    connection.StopMotion();
    std::fprintf(stderr,
                 "sweepscan-cli: drive script aborted at %.1f s of %.1f s: %s; the robot stays "
                 "stopped until you drive it; the recording goes on\n",
                 script.elapsed_s(), script.duration_s(), script.abort_reason().c_str());
  };
  QObject::connect(&script_timer, &QTimer::timeout, &app, [&] {
    const hardware::LinkHealth h = connection.health();
    const hardware::DriveScript::Step step =
        script.Tick(hardware::ScriptClocks::Now(), h.have_status ? &h.agent_status : nullptr);
    if (step.action == hardware::DriveScript::Action::kDrive) {
      connection.Drive(step.v, step.w);
    } else if (step.action == hardware::DriveScript::Action::kAbort) {
      say_script_aborted();
    } else {
      script_timer.stop();
      connection.StopMotion();
      std::fprintf(stderr, "drive script done (%.1f s)\n", script.duration_s());
      if (o.duration_s < 0) app.quit();
    }
  });
  QObject::connect(&connection, &hardware::RobotConnection::authenticationFailed, &app,
                   [&](const QString& reason) {
                     // Final only if the connection gave up (a wrong key, a
                     // protocol it does not speak); "busy" is retried. The
                     // state is set after the signal, hence the queued look.
                     QTimer::singleShot(0, &app, [&, reason] {
                       if (connection.health().state != hardware::LinkHealth::State::kFailed) return;
                       refused = reason;
                       app.quit();
                     });
                   });
  // The session cannot be written any more (disk full, a pulled drive):
  // said at once, and the recorder stops (the robot with it) rather than
  // drive on recording nothing; StopRecording() then returns the error.
  QObject::connect(&connection, &hardware::RobotConnection::recordingFailed, &app,
                   [&](const QString& error) {
                     std::fprintf(stderr, "sweepscan-cli: recording failed at %.1f s: %s\n",
                                  clock.elapsed() * 1e-3, qPrintable(error));
                     app.quit();
                   });
  // Outages: said on stderr as they happen. A drive script is aborted at
  // the first one: the agent's watchdog stopped the robot, and a
  // reconnection must not set it moving again without the operator.
  std::vector<double> outages_s;
  QObject::connect(&connection, &hardware::RobotConnection::linkLost, &app, [&](const QString& reason) {
    std::fprintf(stderr, "sweepscan-cli: link lost at %.1f s (%s); reconnecting (Ctrl+C to stop)\n",
                 connection.recording() ? clock.elapsed() * 1e-3 : since_start.elapsed() * 1e-3,
                 qPrintable(reason));
    if (script.running()) {
      script.Abort("the link was lost (" + reason.toStdString() + ")");
      say_script_aborted();
    }
  });
  QObject::connect(&connection, &hardware::RobotConnection::linkRestored, &app,
                   [&](double outage_s, const QString& details) {
                     outages_s.push_back(outage_s);
                     std::fprintf(stderr,
                                  "sweepscan-cli: reconnected after %.1f s (%s); the session goes "
                                  "on\n",
                                  outage_s, qPrintable(details));
                   });
  // Said as each device's first bytes after an outage show it: the agent's
  // buffer (robotd --buffer-s) did not reach back over the whole outage.
  QObject::connect(&connection, &hardware::RobotConnection::dataLost, &app,
                   [&](int device, double seconds) {
                     std::fprintf(stderr,
                                  "sweepscan-cli: %s: %.2f s of data lost in the outage (longer "
                                  "than the robot's buffer, robotd --buffer-s)\n",
                                  hardware::LinkDeviceName(static_cast<uint8_t>(device)), seconds);
                   });
  QTimer health_timer;
  QObject::connect(&health_timer, &QTimer::timeout, &app, [&] {
    const hardware::LinkHealth h = connection.health();
    PrintHealth(connection.recording() ? clock.elapsed() * 1e-3 : since_start.elapsed() * 1e-3, h,
                connection.recording());
    if (!connection.recording() && since_start.elapsed() > o.connect_timeout_s * 1e3) {
      PrintError("no authenticated link to " + o.link.address.toStdString() + " within " +
                 std::to_string(static_cast<int>(o.connect_timeout_s)) + " s" +
                 (h.last_error.isEmpty() ? "" : " (" + h.last_error.toStdString() + ")"));
      exit_code = kExitFailure;
      app.quit();
    }
  });
  health_timer.start(1000);

  app.exec();
  script_timer.stop();
  // Stop first, then close: the robot is told to stop before the session's
  // last write and fsync, which a slow or full disk can make take seconds
  // while a drive script's last command is still in force (until the
  // watchdog). The session was closed first, although this said otherwise.
  connection.StopMotion();  // Nothing when the link is down.
  // The X4 would spin on after we leave (the agent turns it off by itself
  // only after its lidar-idle-s); --keep-lidar for a recording that follows.
  if (!args.Flag("keep-lidar")) connection.SetLidarMotor(false);
  const bool recorded = connection.recording();
  const double seconds = recorded ? clock.elapsed() * 1e-3 : 0.0;
  const hardware::LinkHealth health = connection.health();
  const Status closed = recorded ? connection.StopRecording() : Status::Ok();
  connection.Shutdown();  // Closes the link (with one more Stop).
  if (!refused.isEmpty()) {
    PrintError("refused: " + refused.toStdString() +
               (refused == QLatin1String("authentication failed")
                    ? " (is --key-file the robot's key, robotd's --key-file?)"
                    : ""));
    return kExitBadInput;
  }
  if (!closed.ok()) {
    PrintError(closed.message());
    return kExitFailure;
  }
  if (!recorded) return exit_code == kExitOk ? kExitFailure : exit_code;
  const int signal = QuitSignal();
  if (args.Flag("json")) {
    nlohmann::json summary = {
        {"session", QDir(o.out).absolutePath().toStdString()},
        {"seconds", seconds},
        {"records", health.session_records},
        {"frames_lost", health.frames_missing},
        {"reconnects", health.reconnects},
        {"outages_s", outages_s},
        {"resent_bytes", health.late_bytes},
        {"data_lost_s",
         {{"lidar", health.data_lost_s[0]},
          {"imu", health.data_lost_s[1]},
          {"motor_board", health.data_lost_s[2]}}},
        {"round_trip_ms", {{"mean", health.latency_mean_ms}, {"max", health.latency_max_ms}}},
        {"stopped_by", signal != 0 ? "signal" : (o.duration_s > 0 ? "duration" : "script")}};
    if (!o.script.empty()) {
      summary["drive_script"] = {{"completed", !script.aborted() && !script.running()},
                                 {"aborted", script.aborted()},
                                 {"at_s", script.elapsed_s()},
                                 {"duration_s", script.duration_s()},
                                 {"reason", script.abort_reason()}};
    }
    std::cout << summary.dump() << "\n";
  } else {
    std::printf("%s: %.1f s, %llu records, %llu frames lost in transit, %llu reconnects, "
                "%zu outages\n",
                qPrintable(o.out), seconds, static_cast<unsigned long long>(health.session_records),
                static_cast<unsigned long long>(health.frames_missing),
                static_cast<unsigned long long>(health.reconnects), outages_s.size());
    if (health.data_lost_s[0] + health.data_lost_s[1] + health.data_lost_s[2] > 0.0) {
      std::printf("data lost in outages: lidar %.2f s, imu %.2f s, motor board %.2f s\n",
                  health.data_lost_s[0], health.data_lost_s[1], health.data_lost_s[2]);
    }
    if (script.aborted()) {
      std::printf("drive script aborted at %.1f s of %.1f s: %s\n", script.elapsed_s(),
                  script.duration_s(), script.abort_reason().c_str());
    }
  }
  // The session is complete, but the path was not driven as asked.
  if (script.aborted() && exit_code == kExitOk) exit_code = kExitFailure;
  return exit_code;
}

}  // namespace sweepscan::app
