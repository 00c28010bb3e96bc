// sweepscan-cli: the headless front end. Thin: parses arguments, calls core,
// prints text or JSON. Exit codes: 0 success, 1 failure while working
// (e.g. cannot write the output), 2 bad input (usage, invalid files).
// One file per command: cli_simulate.cc, cli_session.cc (info, reconstruct,
// export), cli_calibrate.cc, cli_evaluate.cc.
#include <iostream>
#include <string>

#include "app/cli_common.h"

namespace sweepscan::app {
namespace {

const char* kUsage =
    "usage: sweepscan-cli <command> [options]\n"
    "\n"
    "Commands:\n"
    "  simulate   record a simulated scan (scenario file) as a session and reconstruct it\n"
    "  info       describe a recorded session or a ROS bag\n"
    "  reconstruct  build the cloud of a recorded session\n"
    "  export     a session's cloud (LAS, PLY, PCD), its sensor records (CSV) or a ROS 1 bag\n"
    "  import     turn a ROS 1 or ROS 2 bag (2D lidar, odometry, IMU, tf) into a session\n"
    "  record     record a session from a robot agent (robotd or the simulator), headless\n"
    "  project    a building in many sessions: new, add, align (registration), export\n"
    "  repair     write a clean copy of a damaged session (intact records only)\n"
    "  calibrate  solve the lidar's mounting error from a circle drive (pairs or automatic)\n"
    "  evaluate   planes, deviation histograms, room dimensions and density of a cloud\n"
    "  p3l        6-DoF pose from three scan lines on three known planes (lidar-only SfM)\n"
    "  sfm        lidar-only structure from motion (a session, a scenario or a simulated rig)\n"
    "  plan       floor plan of a cloud: walls, openings, room dimensions; SVG and DXF drawings\n"
    "  help       show this text, or `help <command>` for one command\n"
    "  --version  print the version\n"
    "\n"
    "Every command accepts --json (machine-readable output on stdout) and --help.\n"
    "Exit codes: 0 ok, 1 failed while working (cannot write an output, out of memory),\n"
    "2 bad input (usage, missing/invalid/corrupt input files); always one error line.\n";

}  // namespace

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kUsage;
    return kExitBadInput;
  }
  const std::string command = argv[1];
  if (command == "help" || command == "--help" || command == "-h") {
    const std::string topic = argc > 2 ? argv[2] : "";
    if (topic == "simulate") {
      std::cout << kSimulateUsage;
    } else if (topic == "calibrate") {
      std::cout << kCalibrateUsage;
    } else if (topic == "evaluate") {
      std::cout << kEvaluateUsage;
    } else if (topic == "info") {
      std::cout << kInfoUsage;
    } else if (topic == "reconstruct") {
      std::cout << kReconstructUsage;
    } else if (topic == "export") {
      std::cout << kExportUsage;
    } else if (topic == "p3l") {
      std::cout << kP3lUsage;
    } else if (topic == "plan") {
      std::cout << kPlanUsage;
    } else if (topic == "sfm") {
      std::cout << kSfmUsage;
    } else if (topic == "import") {
      std::cout << kImportUsage;
    } else if (topic == "record") {
      std::cout << kRecordUsage;
    } else if (topic == "project") {
      std::cout << kProjectUsage;
    } else if (topic == "repair") {
      std::cout << kRepairUsage;
    } else if (topic.empty() || topic == "help") {
      std::cout << kUsage;
    } else {
      // Asked about a command there is not: a usage error, said on stderr.
      PrintError(SeeHelp("no command '" + topic + "'", ""));
      return kExitBadInput;
    }
    return kExitOk;
  }
  if (command == "--version" || command == "version") {
    std::cout << "sweepscan-cli 0.1.0\n";
    return kExitOk;
  }
  if (command == "simulate") return RunSimulate(argc, argv);
  if (command == "record") return RunRecord(argc, argv);
  if (command == "info") return RunInfo(argc, argv);
  if (command == "reconstruct") return RunReconstruct(argc, argv);
  if (command == "export") return RunExport(argc, argv);
  if (command == "repair") return RunRepair(argc, argv);
  if (command == "project") return RunProject(argc, argv);
  if (command == "import") return RunImport(argc, argv);
  if (command == "calibrate") return RunCalibrate(argc, argv);
  if (command == "evaluate") return RunEvaluate(argc, argv);
  if (command == "p3l") return RunP3l(argc, argv);
  if (command == "sfm") return RunSfm(argc, argv);
  if (command == "plan") return RunPlan(argc, argv);
  PrintError(SeeHelp("unknown command '" + command + "'", ""));
  return kExitBadInput;
}

}  // namespace sweepscan::app

int main(int argc, char** argv) {
  return sweepscan::app::RunGuarded([&] { return sweepscan::app::Main(argc, argv); });
}
