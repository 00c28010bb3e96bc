// sweepscan-sim: the simulated robot. The core's simulated world behind
// byte-exact emulations of the X4, HI219 and motor board (SimDevices), plugged
// into the same agent code as sweepscan-robotd (RobotAgent), in real time.
// The workstation connects exactly as to a robot: TCP on loopback (key
// required) or a pseudo-terminal (--pty prints the slave path, a real serial
// device to open with QSerialPort). Behaviour: docs/robot-agent.md.
// --device-ptys serves the devices themselves on pseudo-terminals instead,
// for a real sweepscan-robotd to open as its device ports.
#include <QCommandLineParser>
#include <QCoreApplication>
#include <cstdio>
#include <exception>
#include <memory>

#include "app/agent_main_common.h"
#include "core/scenario/scenario.h"
#include "core/sim/world.h"
#include "hardware/agent/robot_agent.h"
#include "hardware/emulation/device_ptys.h"
#include "hardware/emulation/sim_devices.h"
#include "hardware/link/qt_transport.h"

namespace {

using sweepscan::hardware::LinkAddress;
using sweepscan::hardware::RobotAgent;
using sweepscan::hardware::RobotAgentConfig;
using sweepscan::hardware::SimDevices;
using sweepscan::hardware::SimDevicesAdapter;
using sweepscan::hardware::TimedBytes;

int Fail(const QString& message) {
  std::fprintf(stderr, "sweepscan-sim: %s\n", qPrintable(message));
  return 2;
}

}  // namespace

namespace {

// --device-ptys: the devices on ptys until SIGINT or SIGTERM. stdout: one
// line per device with its paths, then "started" when the world's clock
// starts (every agent has opened its lidar port).
int ServeDevicePtys(QCoreApplication* app, std::unique_ptr<SimDevices> sim, int copies) {
  sweepscan::hardware::DevicePtys ptys(std::move(sim), copies);
  QString error;
  if (!ptys.Open(&error)) return Fail(error);
  const char* names[3] = {"lidar", "imu", "motor"};
  for (int device = 0; device < 3; ++device) {
    std::printf("%s", names[device]);
    for (int copy = 0; copy < copies; ++copy) std::printf(" %s", qPrintable(ptys.SlavePaths(copy)[device]));
    std::printf("\n");
  }
  std::fflush(stdout);
  QObject::connect(&ptys, &sweepscan::hardware::DevicePtys::worldStarted, [] {
    std::printf("started\n");
    std::fflush(stdout);
  });
  sweepscan::app::QuitOnSignals(app);
  const int rc = app->exec();
  std::fprintf(stderr, "sweepscan-sim: device bytes not taken by a pty: %llu\n",
               static_cast<unsigned long long>(ptys.bytes_dropped()));
  return rc;
}

int AgentMain(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  QCoreApplication::setApplicationName(QStringLiteral("sweepscan-sim"));
  QCoreApplication::setApplicationVersion(QStringLiteral("0.1.0"));
  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral(
      "Simulated robot: the simulated world behind byte-exact device emulations and the real "
      "robot agent, in real time. Drive it from the workstation like a robot."));
  parser.addHelpOption();
  parser.addVersionOption();
  const QCommandLineOption scenario(QStringLiteral("scenario"),
                                    "Scenario file (the world; its path is used only "
                                    "with --scripted).",
                                    "FILE");
  const QCommandLineOption scripted(QStringLiteral("scripted"),
                                    "Follow the scenario's path instead of drive commands.");
  const QCommandLineOption pty(QStringLiteral("pty"),
                               "Serve the link on a new pseudo-terminal; prints its path.");
  const QCommandLineOption device_ptys(
      QStringLiteral("device-ptys"),
      "No agent: serve the X4, HI219 and motor board themselves on new pseudo-terminals, "
      "for sweepscan-robotd's --lidar, --imu and --motor; prints 'lidar PATH', 'imu PATH', "
      "'motor PATH'. With --copies N, N sets fed the same bytes (one line per device, N "
      "paths); only the first set's commands reach the devices.");
  const QCommandLineOption copies(QStringLiteral("copies"), "Sets of device ptys (default 1).", "N");
  const sweepscan::app::AgentCommandLine common;
  common.Add(&parser);
  parser.addOptions({scenario, scripted, pty, device_ptys, copies});
  if (!parser.parse(QCoreApplication::arguments())) return Fail(parser.errorText());
  if (parser.isSet(QStringLiteral("help"))) parser.showHelp(0);
  if (parser.isSet(QStringLiteral("version"))) parser.showVersion();
  if (!parser.positionalArguments().isEmpty()) {
    return Fail(QStringLiteral("unexpected argument '%1' (see --help)")
                    .arg(parser.positionalArguments()[0]));
  }
  if (!parser.isSet(scenario)) return Fail(QStringLiteral("--scenario FILE is required"));

  sweepscan::sim::SimConfig world;
  const sweepscan::Status loaded =
      sweepscan::LoadScenario(parser.value(scenario).toStdString(), &world);
  if (!loaded.ok()) return Fail(QString::fromStdString(loaded.message()));

  const SimDevices::Mode mode =
      parser.isSet(scripted) ? SimDevices::Mode::kScripted : SimDevices::Mode::kCommanded;
  if (parser.isSet(device_ptys)) {
    if (parser.isSet(pty) || parser.isSet(common.listen)) {
      return Fail(QStringLiteral("--device-ptys serves no link: no --pty or --listen"));
    }
    bool ok = true;
    const int n = parser.isSet(copies) ? parser.value(copies).toInt(&ok) : 1;
    if (!ok || n < 1 || n > 8) return Fail(QStringLiteral("--copies expects 1..8"));
    return ServeDevicePtys(&app, std::make_unique<SimDevices>(world, mode), n);
  }

  RobotAgentConfig config;
  QString error;
  config.agent.name = "sweepscan-sim 0.1.0 (" + world.name + ")";
  config.agent.devices = {{1, "YDLIDAR X4 (simulated) @128000"},
                          {2, "HiPNUC HI219 (simulated) @115200"},
                          {3, "motor board (simulated) @115200"}};
  if (parser.isSet(pty) && parser.isSet(common.listen)) {
    return Fail(QStringLiteral("--listen and --pty exclude each other"));
  }
  if (parser.isSet(pty)) {
    config.link = RobotAgentConfig::LinkKind::kPty;
    config.agent.require_auth = false;
  }
  // The simulator only warns about a key file others may read (it is a test
  // and demo tool); sweepscan-robotd refuses one.
  if (!common.Apply(parser, !parser.isSet(pty), &config, &error,
                    sweepscan::hardware::KeyFilePermissions::kWarn)) {
    return Fail(error);
  }

  auto devices = std::make_unique<SimDevices>(world, mode);
  RobotAgent agent(config,
                   std::make_unique<SimDevicesAdapter<SimDevices, TimedBytes>>(std::move(devices)));
  sweepscan::app::LogAgentEvents(&agent);
  if (!agent.Start(&error)) return Fail(error);
  // First line of stdout: where to connect (scripts and tests read it).
  if (config.link == RobotAgentConfig::LinkKind::kPty) {
    std::printf("%s\n", qPrintable(agent.pty_path()));
  } else {
    std::printf("listening on %s:%u\n", qPrintable(config.listen_address), agent.tcp_port());
  }
  std::fflush(stdout);

  return sweepscan::app::RunAgentUntilSignal(&app, &agent);
}
}  // namespace

int main(int argc, char** argv) {
  return sweepscan::app::RunAgentMain("sweepscan-sim", AgentMain, argc, argv);
}
