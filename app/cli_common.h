// Pieces shared by the sweepscan-cli commands.
#ifndef SWEEPSCAN_APP_CLI_COMMON_H_
#define SWEEPSCAN_APP_CLI_COMMON_H_

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>
#include <string>

namespace sweepscan {
struct SensorLog;
struct SessionMeta;
}  // namespace sweepscan

namespace sweepscan::app {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;   // failed while working (cannot write, solver failed)
constexpr int kExitBadInput = 2;  // usage errors, invalid or corrupt input files

inline void PrintError(const std::string& message) {
  std::cerr << "sweepscan-cli: error: " << message << "\n";
}

// A usage error is one line too, which points at the command's help rather
// than printing all of it after the error (a script's log kept 30 lines of
// help for one mistyped word, and the error scrolled off a terminal).
inline std::string SeeHelp(const std::string& message, const std::string& command) {
  return message + " (see `sweepscan-cli help" + (command.empty() ? "" : " " + command) + "`)";
}

// --seed's value: a decimal integer that fits 64 bits (strtoull saturates
// an overflow at 2^64 - 1 and says so only through errno).
inline bool ParseSeed(const std::string& text, uint64_t* seed) {
  if (text.empty() || text[0] < '0' || text[0] > '9') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (*end != '\0' || errno == ERANGE) return false;
  *seed = v;
  return true;
}

// Runs a command so that nothing escapes it: an exception (out of memory,
// an I/O error deep in a library) becomes one error line and exit 1
// ("failed while working"); bad input is found and refused with exit 2
// before that. Used by main() of every command-line tool.
template <typename Fn>
int RunGuarded(Fn&& fn) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
    PrintError("out of memory");
  } catch (const std::exception& e) {
    PrintError(std::string("unexpected failure: ") + e.what());
  } catch (...) {
    PrintError("unexpected failure (unknown exception)");
  }
  return kExitFailure;
}

// Session commands (app/cli_session.cc): `info`, `reconstruct`, `export`.
int RunInfo(int argc, char** argv);
int RunReconstruct(int argc, char** argv);
int RunExport(int argc, char** argv);
int RunRepair(int argc, char** argv);
// cli_ros.cc: ROS bags (docs/ros-bags.md).
extern const char* const kImportUsage;
extern const char* const kBagInfoUsage;
int RunImport(int argc, char** argv);
int RunBagInfo(int argc, char** argv);  // `info BAG`
// `export SESSION --format rosbag --out FILE.bag` (cli_ros.cc).
class Args;
int ExportRosbag(const Args& args, const SensorLog& log, const SessionMeta& meta);
extern const char* const kRepairUsage;
extern const char* const kInfoUsage;
extern const char* const kReconstructUsage;
extern const char* const kExportUsage;

// The other commands, one file each: cli_simulate.cc, cli_calibrate.cc,
// cli_evaluate.cc.
int RunSimulate(int argc, char** argv);
int RunCalibrate(int argc, char** argv);
int RunEvaluate(int argc, char** argv);
extern const char* const kSimulateUsage;
extern const char* const kCalibrateUsage;
extern const char* const kEvaluateUsage;

// Projects of many sessions (app/cli_project*.cc): `project`.
int RunProject(int argc, char** argv);
extern const char* const kProjectUsage;

// The headless recorder (app/cli_record.cc): `record`.
int RunRecord(int argc, char** argv);
extern const char* const kRecordUsage;

// Lidar-only structure from motion (app/cli_sfm.cc): `p3l`, `sfm`.
int RunP3l(int argc, char** argv);
extern const char* const kP3lUsage;
int RunSfm(int argc, char** argv);
extern const char* const kSfmUsage;

// Floor plans and sections of a cloud (app/cli_plan.cc): `plan`.
int RunPlan(int argc, char** argv);
extern const char* const kPlanUsage;

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_CLI_COMMON_H_
