// sweepscan-robotd: the robot agent for the robot's own computer. Opens the
// lidar, IMU and motor-board serial ports, serves the robot link
// (docs/protocol.md) on TCP (loopback unless told otherwise, pre-shared key
// required) or on a serial port, and stops the robot by itself when the link
// goes quiet. Behaviour: docs/robot-agent.md. Thin: parsing and wiring.
#include <QCommandLineParser>
#include <QCoreApplication>
#include <QHash>
#include <cstdio>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <vector>

#include "app/agent_main_common.h"
#include "app/robotd_config.h"
#include "app/service_notify.h"
#include "hardware/agent/robot_agent.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/link/qt_transport.h"

namespace {

using sweepscan::hardware::LinkAddress;
using sweepscan::hardware::RobotAgent;
using sweepscan::hardware::RobotAgentConfig;

int Fail(const QString& message) {
  std::fprintf(stderr, "sweepscan-robotd: %s\n", qPrintable(message));
  return 2;
}

// --stop-motors: a zero command to the motor board, and exit. The service
// runs it after the agent has exited, however it exited (ExecStopPost): a
// crashed agent sends nothing, and the board keeps driving at its last
// command until the next agent has started (RestartSec, then its start-up:
// 2 s or more) unless it has a command timeout of its own.
int StopMotors(const QString& port, qint32 baud) {
  sweepscan::hardware::SerialStream serial;
  QString error;
  if (!serial.Open(port, baud, &error)) {
    std::fprintf(stderr, "sweepscan-robotd: --stop-motors: %s\n", qPrintable(error));
    return 1;
  }
  const std::vector<uint8_t> zero =
      sweepscan::hardware::EncodeMotorCommand(sweepscan::hardware::MotorCommand{});
  // Three times: the board may have been mid-frame when the agent died
  // (its decoder resynchronises on the next frame's header).
  for (int i = 0; i < 3; ++i) serial.Write(zero.data(), zero.size());
  QString why;
  const bool drained = serial.Drain(1000, &why);
  serial.Close();
  if (!drained) {
    std::fprintf(stderr,
                 "sweepscan-robotd: --stop-motors: %s: the zero command did not leave the port "
                 "(%s)\n",
                 qPrintable(port), qPrintable(why));
    return 1;
  }
  std::printf("zero command sent to the motor board on %s\n", qPrintable(port));
  return 0;
}

// A stop asked for during start-up (`systemctl stop` while the file and the
// key are read or the ports open: SIGTERM, or SIGINT, SIGHUP, SIGQUIT): the
// event loop that acts on it has not started yet, so start-up looks for it
// between its steps and leaves there. Until 2026-11-29 it was acted on only
// once the loop ran: the agent finished starting and said it was ready
// (READY=1, "listening on") before it stopped, however slow its start.
bool StopPending() { return sweepscan::app::QuitSignal() != 0; }

int StoppedDuringStartup(const char* what) {
  // glibc's name without its "SIG" (2.32 on; Debian 12 has 2.36).
  const char* name = ::sigabbrev_np(sweepscan::app::QuitSignal());
  std::fprintf(stderr, "sweepscan-robotd: %s%s during start-up: %s; exiting\n",
               name != nullptr ? "SIG" : "", name != nullptr ? name : "a signal", what);
  return 0;
}

}  // namespace

namespace {
int AgentMain(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  // Before anything starts: a SIGHUP or SIGTERM from here on ends the event
  // loop (at once if it comes before the loop runs), so the agent's
  // shutdown sends the motor board its zero; the default action would kill
  // the process with the board driving at its last command.
  sweepscan::app::QuitOnSignals(&app);
  QCoreApplication::setApplicationName(QStringLiteral("sweepscan-robotd"));
  QCoreApplication::setApplicationVersion(QStringLiteral("0.1.0"));
  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral(
      "Robot agent: streams the lidar, IMU and motor-board bytes to the workstation over the "
      "robot link and applies its drive commands with speed and acceleration limits and a "
      "watchdog. See docs/robot-agent.md."));
  parser.addHelpOption();
  parser.addVersionOption();
  const QCommandLineOption lidar(QStringLiteral("lidar"), "YDLIDAR X4 serial port (128000 baud).",
                                 "PORT");
  const QCommandLineOption imu(QStringLiteral("imu"), "HI219 serial port (115200 baud).", "PORT");
  const QCommandLineOption motor(QStringLiteral("motor"), "Motor board serial port (115200 baud).",
                                 "PORT");
  const QCommandLineOption serial(
      QStringLiteral("serial"),
      "Serve the link on a serial port instead of TCP (PORT[@BAUD], default "
      "921600 baud; no authentication: physical access).",
      "PORT");
  const QCommandLineOption name(QStringLiteral("name"),
                                "Robot name in the Hello (default robot-1).", "NAME");
  const QCommandLineOption stop_motors(
      QStringLiteral("stop-motors"),
      "Send the motor board a zero command and exit (the service runs this after the agent "
      "exits, a crash included: docs/deployment.md).");
  const QCommandLineOption config_file(
      QStringLiteral("config"),
      "Read options from FILE: lines 'key = value', a key being a long option without its "
      "dashes (the packaged service uses /etc/sweepscan/robotd.conf). The command line "
      "overrides the file.",
      "FILE");
  sweepscan::app::AgentCommandLine common;
  common.Add(&parser);
  parser.addOptions({lidar, imu, motor, serial, name, config_file, stop_motors});
  QStringList arguments = QCoreApplication::arguments();
  if (!parser.parse(arguments)) return Fail(parser.errorText());
  QHash<QString, QString> file_origin;  // Option name -> "FILE:LINE: key", for messages.
  if (parser.isSet(config_file) && !parser.isSet(QStringLiteral("help")) &&
      !parser.isSet(QStringLiteral("version"))) {
    // Every option but the file itself, help and version may come from it.
    QStringList keys;
    for (const QCommandLineOption* option : std::initializer_list<const QCommandLineOption*>{
             &lidar, &imu, &motor, &serial, &name, &common.listen, &common.key_file,
             &common.watchdog, &common.v_max, &common.w_max, &common.accel, &common.alpha,
             &common.buffer, &common.lidar_idle}) {
      keys << option->names().first();
    }
    const QString path = parser.value(config_file);
    std::vector<sweepscan::app::AgentConfigSetting> settings;
    QString file_error;
    // --stop-motors must stop the board whatever else the file gets wrong
    // (the service runs it after any exit, a refused configuration's too):
    // it reads leniently, and an unreadable file leaves the command line's.
    const bool stopping = parser.isSet(stop_motors);
    QStringList warnings;
    if (!sweepscan::app::ReadAgentConfigFile(path, keys, &settings, &file_error,
                                             stopping ? &warnings : nullptr)) {
      if (!stopping) return Fail(file_error);
      warnings << file_error;
      settings.clear();
    }
    for (const QString& warning : warnings) {
      std::fprintf(stderr, "sweepscan-robotd: --stop-motors: warning: %s\n", qPrintable(warning));
    }
    // The link is one choice: `--listen` or `--serial` on the command line
    // replaces the file's, whichever of the two that is (the shipped file
    // sets `listen`, and `--serial` used to be refused beside it).
    const bool link_on_command_line = parser.isSet(serial) || parser.isSet(common.listen);
    QStringList from_file;
    for (const sweepscan::app::AgentConfigSetting& setting : settings) {
      const bool link =
          setting.key == QLatin1String("listen") || setting.key == QLatin1String("serial");
      if (link && link_on_command_line) continue;
      from_file << QStringLiteral("--") + setting.key << setting.value;
      if (!parser.isSet(setting.key)) {
        file_origin.insert(
            setting.key, QStringLiteral("%1:%2: %3").arg(path).arg(setting.line).arg(setting.key));
      }
    }
    // The file's options first: QCommandLineParser::value() is the last one given.
    arguments = QStringList{arguments.first()} + from_file + arguments.mid(1);
    if (!parser.parse(arguments) && !stopping) return Fail(parser.errorText());
  }
  // A bad value from the file is reported at its line, with its key as written.
  common.origin = [&file_origin](const QString& name) { return file_origin.value(name); };
  if (parser.isSet(QStringLiteral("help"))) parser.showHelp(0);
  if (parser.isSet(QStringLiteral("version"))) parser.showVersion();
  if (!parser.positionalArguments().isEmpty()) {
    return Fail(QStringLiteral("unexpected argument '%1' (see --help)")
                    .arg(parser.positionalArguments()[0]));
  }

  RobotAgentConfig config;
  QString error;
  const std::string robot_name =
      (parser.isSet(name) ? parser.value(name) : QStringLiteral("robot-1")).toStdString();
  config.agent.name = "sweepscan-robotd 0.1.0 (" + robot_name + ")";
  config.lidar_port = parser.value(lidar);
  config.imu_port = parser.value(imu);
  config.motor_port = parser.value(motor);
  if (config.lidar_port.isEmpty() && config.imu_port.isEmpty() && config.motor_port.isEmpty()) {
    // The stable names the udev rules give (docs/deployment.md); a device
    // not plugged in yet is retried every second.
    config.lidar_port = QStringLiteral("/dev/sweepscan/lidar");
    config.imu_port = QStringLiteral("/dev/sweepscan/imu");
    config.motor_port = QStringLiteral("/dev/sweepscan/motor");
  }
  auto describe = [&](uint8_t device, const QString& port, int baud, const char* what) {
    if (!port.isEmpty()) {
      config.agent.devices.push_back(
          {device, QStringLiteral("%1 %2 @%3").arg(what, port).arg(baud).toStdString()});
    }
  };
  describe(1, config.lidar_port, config.lidar_baud, "YDLIDAR X4");
  describe(2, config.imu_port, config.imu_baud, "HiPNUC HI219");
  describe(3, config.motor_port, config.motor_baud, "motor board");

  if (parser.isSet(stop_motors)) {
    // A signal meanwhile does not stop this one: it is the stop.
    if (config.motor_port.isEmpty())
      return Fail(QStringLiteral("--stop-motors: no motor board port (--motor)"));
    return StopMotors(config.motor_port, config.motor_baud);
  }
  // The service manager's notification socket (NOTIFY_SOCKET), read now so
  // that an address robotd cannot use (vsock:, a path too long) is said
  // first: under Type=notify the start would time out with no word as to why.
  sweepscan::app::ServiceNotifier service;
  // The configuration is read (a slow file system, a file that is a pipe).
  if (StopPending()) return StoppedDuringStartup("stopped before the ports were opened");
  // Not before --stop-motors: it must stop the board whatever else the
  // configuration gets wrong (the service runs it after any exit).
  if (config.agent.name.size() > sweepscan::hardware::kLinkMaxStringSize) {
    const size_t room =
        sweepscan::hardware::kLinkMaxStringSize - (config.agent.name.size() - robot_name.size());
    return Fail(common.Subject(name) + QStringLiteral(" is over %1 bytes").arg(room));
  }
  if (parser.isSet(serial) && parser.isSet(common.listen)) {
    // Both on the command line, or both in the file.
    return Fail(QStringLiteral("%1 and %2 exclude each other")
                    .arg(common.Subject(common.listen), common.Subject(serial)));
  }
  if (parser.isSet(serial)) {
    LinkAddress address;
    if (!sweepscan::hardware::ParseLinkAddress("serial:" + parser.value(serial), &address,
                                               &error)) {
      return Fail(common.Located(serial, error));
    }
    config.link = RobotAgentConfig::LinkKind::kSerial;
    config.link_serial_port = address.serial_port;
    config.link_baud = address.baud;
    config.agent.require_auth = false;
  }
  if (!common.Apply(parser, !parser.isSet(serial), &config, &error)) return Fail(error);
  // The key is read.
  if (StopPending()) return StoppedDuringStartup("stopped before the ports were opened");

  RobotAgent agent(config);
  sweepscan::app::LogAgentEvents(&agent);
  // Asked between the ports' opens too (each can take seconds on a USB
  // adapter): the motor board's is the first, so its zero goes out whichever
  // open the stop interrupts. Until 2026-11-29 the stop waited for all three.
  if (!agent.Start(&error, StopPending)) return Fail(error);
  // The motor board has had its zero as its port opened; the shutdown sends
  // it again and closes the ports, and the agent never says it is ready.
  if (agent.stopped_during_start()) {
    agent.Shutdown();
    return StoppedDuringStartup(
        "stopped while the ports were opened (the rest not opened); motors stopped, ports closed");
  }
  if (StopPending()) {
    agent.Shutdown();
    return StoppedDuringStartup("the ports were opened; motors stopped, ports closed");
  }
  QString serving;
  if (config.link == RobotAgentConfig::LinkKind::kTcp) {
    serving = QStringLiteral("listening on %1:%2").arg(config.listen_address).arg(agent.tcp_port());
  } else {
    serving = QStringLiteral("serving the link on %1").arg(config.link_serial_port);
  }
  std::printf("%s\n", qPrintable(serving));
  std::fflush(stdout);
  if (config.agent.lidar_idle_off > sweepscan::Duration::zero()) {
    std::fprintf(stderr, "lidar motor off after %.0f s without a client (lidar-idle-s)\n",
                 sweepscan::ToSeconds(config.agent.lidar_idle_off));
  } else {
    std::fprintf(stderr, "lidar motor left on without a client (lidar-idle-s = 0)\n");
  }

  service.Ready(serving);
  QObject::connect(&agent, &RobotAgent::clientConnected, &service, [&](const QString& peer) {
    service.Status(serving + QStringLiteral(", client ") + peer);
  });
  QObject::connect(&agent, &RobotAgent::clientDisconnected, &service,
                   [&](const QString&, const QString&) { service.Status(serving + QStringLiteral(", no client")); });
  QObject::connect(&app, &QCoreApplication::aboutToQuit, &service, [&] { service.Stopping(); });

  return sweepscan::app::RunAgentUntilSignal(&app, &agent);
}
}  // namespace

int main(int argc, char** argv) {
  return sweepscan::app::RunAgentMain("sweepscan-robotd", AgentMain, argc, argv);
}
