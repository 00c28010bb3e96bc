// sweepscan-cli under faults and bad input (issue 16), as the real binary:
// one exit-code rule for every command (0 ok, 1 failed while working, 2 bad
// input), always one error line, never an abort; outputs that are complete
// or absent on a full file system; sessions that survive a damaged frames.bin.
//
// "Full disk" is a real failed write: the CLI runs with a file size limit
// (ulimit -f, SIGXFSZ ignored), so write() fails with EFBIG exactly as it
// fails with ENOSPC on a full disk; CheckedFileTest covers a full tmpfs.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/testing/cli_files.h"
#include "tests/testing/held_ioctl_process.h"
#include "tests/testing/remove_at_exit.h"
#include "tests/testing/run_command.h"

namespace {

using sweepscan::testing::CommandRun;

std::string Dir() {
  static const std::string dir = [] {
    const std::string d = ::testing::TempDir() + "/sweepscan_cli_robust_" + std::to_string(::getpid());
    sweepscan::testing::ShellOrFail("rm -rf '" + d + "' && mkdir -p '" + d + "'");
    return sweepscan::testing::RemoveAtExit(d);
  }();
  return dir;
}
std::string Tmp(const std::string& name) { return Dir() + "/" + name; }
std::string Scenario(const std::string& name) {
  return std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + name + ".json";
}

CommandRun Cli(const std::string& args) {
  return sweepscan::testing::RunCommand(std::string(SWEEPSCAN_CLI) + " " + args);
}
// The CLI with files limited to `kib` KiB: writes beyond fail (EFBIG).
CommandRun CliWithFullDisk(const std::string& args, int kib = 32) {
  return sweepscan::testing::RunCommand("sh -c \"trap '' XFSZ; ulimit -f " +
                                        std::to_string(kib * 2) + "; exec " + SWEEPSCAN_CLI +
                                        " " + args + "\"");
}

// Exactly one line, an error line, naming `what`.
void ExpectOneErrorLine(const CommandRun& r, const std::string& what) {
  EXPECT_EQ(r.out.rfind("sweepscan-cli: error: ", 0), 0u) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
}

bool Exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

std::string LsA(const std::string& dir) {
  return sweepscan::testing::RunCommand("ls -A '" + dir + "'").out;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// One simulated session shared by the tests (1-2 s to make).
class CliRobustnessTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const CommandRun r = Cli("simulate --scenario " + Scenario("lab") + " --out " + Tmp("lab.ply") +
                             " --overwrite");
    ASSERT_EQ(r.code, 0) << r.out;
  }
  static std::string Session() { return Tmp("lab.sweepscan"); }
  // A copy of the session with byte `offset` of frames.bin flipped (or, with
  // offset < 0, at the middle of the file).
  static std::string DamagedCopy(const std::string& name, long offset = -1) {
    const std::string dir = Tmp(name);
    sweepscan::testing::ShellOrFail("rm -rf '" + dir + "' && cp -r '" + Session() + "' '" + dir + "'");
    std::fstream f(dir + "/frames.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(0, std::ios::end);
    const long size = static_cast<long>(f.tellg());
    const long at = offset >= 0 ? offset : size / 2;
    f.seekg(at);
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ 0xFF);
    f.seekp(at);
    f.write(&c, 1);
    return dir;
  }
};

TEST_F(CliRobustnessTest, UsageErrorsAreExitTwoForEveryCommand) {
  for (const char* command : {"simulate", "info", "reconstruct", "export", "repair", "calibrate",
                              "evaluate"}) {
    const CommandRun r = Cli(std::string(command) + " --no-such-option");
    EXPECT_EQ(r.code, 2) << command << ": " << r.out;
    EXPECT_NE(r.out.find("unknown option --no-such-option"), std::string::npos) << r.out;
  }
  EXPECT_EQ(Cli("no-such-command").code, 2);
  EXPECT_EQ(Cli("").code, 2);
  // `project` alone said nothing on stderr (its usage went to stdout).
  const CommandRun project = sweepscan::testing::RunCommand("sh -c '" + std::string(SWEEPSCAN_CLI) +
                                                            " project 2>&1 >/dev/null'");
  EXPECT_EQ(project.code, 2);
  EXPECT_EQ(
      project.out,
      "sweepscan-cli: error: project needs a subcommand (see `sweepscan-cli help project`)\n");
  // Help on a command there is not was exit 0.
  const CommandRun help = Cli("help bogus");
  EXPECT_EQ(help.code, 2) << help.out;
  EXPECT_EQ(help.out, "sweepscan-cli: error: no command 'bogus' (see `sweepscan-cli help`)\n");
  // `help` is a command too, and every command takes --json (p3l refused it).
  EXPECT_EQ(Cli("help help").code, 0);
  ExpectOneErrorLine(Cli("p3l --json"), "p3l needs one PROBLEM.json");
  // Option errors point at the help too.
  ExpectOneErrorLine(Cli("reconstruct x --bogus"),
                     "unknown option --bogus (see `sweepscan-cli help reconstruct`)");
  ExpectOneErrorLine(Cli("calibrate --bogus"), "(see `sweepscan-cli help calibrate`)");
  // A usage error is one line pointing at the help, not the error followed
  // by all of the help (30 lines, the error scrolled off).
  for (const std::string& args :
       std::vector<std::string>{"no-such-command", "info", "reconstruct", "project frobnicate x",
                                "project new --bogus", "p3l", "sfm"}) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args;
    ExpectOneErrorLine(r, "(see `sweepscan-cli help");
  }
}

// A session with no records (the robot never sent one: meta.json and the
// frames.bin header alone) is an input that cannot be used, exit 2 with
// its name; reconstruct and calibrate said exit 1, "failed while working".
TEST_F(CliRobustnessTest, ASessionWithNoRecordsIsExitTwo) {
  const std::string empty = Tmp("empty.sweepscan");
  sweepscan::testing::ShellOrFail("rm -rf '" + empty + "' && mkdir '" + empty + "' && cp '" +
                                  Session() + "/meta.json' '" + empty + "/' && head -c 16 '" +
                                  Session() + "/frames.bin' > '" + empty + "/frames.bin'");
  for (const std::string& args :
       {"reconstruct " + empty + " --out " + Tmp("empty.ply"),
        "reconstruct " + empty + " --out " + Tmp("empty.ply") + " --loop-closure",
        "calibrate " + empty + " --auto", "evaluate " + empty}) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    ExpectOneErrorLine(r, empty + ": the recording has no wheel odometry records");
  }
  EXPECT_FALSE(Exists(Tmp("empty.ply")));
}

TEST_F(CliRobustnessTest, MissingInputsAreExitTwoWithOneLine) {
  const std::string missing = Tmp("missing.sweepscan");
  for (const std::string& args :
       {"info " + missing, "reconstruct " + missing + " --out " + Tmp("m.ply"),
        "export " + missing + " --out " + Tmp("m-csv"), "repair " + missing + " --out " + Tmp("m2"),
        "calibrate " + missing + " --auto", "evaluate " + missing,
        "evaluate " + Tmp("missing.ply"), "simulate --scenario " + Tmp("missing.json") + " --out " + Tmp("m.ply")}) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    ExpectOneErrorLine(r, "missing");
  }
}

// Usage that used to be taken the wrong way: no input (evaluate segfaulted),
// an option's missing value taking the next option (export wrote into a
// folder named --strict), an output the command cannot write (found only
// after the whole session was read), numbers out of range (a seed saturated
// at 2^64 - 1, a duration past Qt's int milliseconds), a project of a folder
// that is not there. Each is one error line and exit 2, before any work.
TEST_F(CliRobustnessTest, UsageTakenTheWrongWayIsExitTwoBeforeAnyWork) {
  const std::string key = Tmp("robot.key");
  WriteText(key, "a robot's key, long enough to be one");
  ::chmod(key.c_str(), 0600);
  const std::string strict_dir = Tmp("--strict");
  sweepscan::testing::RunCommand("rm -rf -- '" + strict_dir + "'");
  // A session folder whose meta.json does not read: `project new` wrote the
  // project around it, and only the alignment failed.
  const std::string broken = Tmp("broken-meta.sweepscan");
  sweepscan::testing::ShellOrFail("mkdir -p '" + broken + "'");
  WriteText(broken + "/meta.json", "{\"format_version\": 2,");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"evaluate", "expected a SESSION, a cloud file or --scenario"},
      {"project new " + Tmp("p.sweepscan-project") + " " + broken, broken + "/meta.json"},
      {"evaluate " + Session() + " " + Session(),
       "evaluate takes one SESSION or cloud file, got 2"},
      {"export " + Session() + " --out --strict", "option --out needs a value"},
      {"reconstruct " + Session() + " --out " + Tmp("cloud.txt"),
       "not a cloud file (.las, .ply or .pcd)"},
      {"simulate --scenario " + Scenario("lab") + " --out " + Tmp("s.ply") +
           " --seed 99999999999999999999999",
       "--seed expects an integer from 0 to 2^64 - 1"},
      {"record --connect 127.0.0.1:1 --key-file " + key + " --out " + Tmp("r.sweepscan") +
           " --duration 3000000",
       "--duration expects a positive number of seconds below 2000000"},
      // The option's value is said first, not the key file's error.
      {"record --connect 127.0.0.1:1 --key-file " + Tmp("no.key") + " --out " + Tmp("r.sweepscan") +
           " --duration ten",
       "--duration expects a positive number of seconds"},
      {"project new " + Tmp("p.sweepscan-project") + " " + Tmp("missing.sweepscan"),
       "not a session folder"},
      {"project new " + Tmp("p.sweepscan-project") + " " + Session() + " --out " + Tmp("y.las"),
       "option --out does not apply to `project new`"},
      {"project info " + Tmp("p.sweepscan-project") + " --no-icp",
       "option --no-icp does not apply to `project info`"},
      // Counts cast to int: --points inf crashed (SIGSEGV), --trials inf
      // "succeeded" with -2147483648 trials, --noise-max inf and --trials
      // 1e9 ran on for hours.
      {"p3l --protocol --csv " + Tmp("p.csv") + " --points inf",
       "option --points expects a whole number from 2 to 10000, got 'inf'"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --points 1e20",
       "option --points expects a whole number from 2 to 10000, got '1e20'"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --trials 99999999999999999999",
       "option --trials expects a whole number from 1 to 1000000"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --trials 2.7",
       "option --trials expects a whole number"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --steps 0x10",
       "option --steps expects a whole number"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --noise-max inf",
       "option --noise-max expects a number, got 'inf'"},
      {"p3l --protocol --csv " + Tmp("p.csv") + " --noise-max 5",
       "--noise-max is a width in metres"},
      {"sfm --rig-scenario room --out " + Tmp("r.ply") + " --frames 2.5",
       "option --frames expects a whole number from 2 to 1000000"},
  };
  for (const auto& [args, expect] : cases) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    EXPECT_NE(r.out.find(expect), std::string::npos) << args << ": " << r.out;
  }
  EXPECT_FALSE(std::filesystem::exists(strict_dir));
  EXPECT_FALSE(std::filesystem::exists(Tmp("p.sweepscan-project")));
  EXPECT_FALSE(std::filesystem::exists(Tmp("cloud.txt")));
  EXPECT_FALSE(std::filesystem::exists(Tmp("p.csv")));
}

TEST_F(CliRobustnessTest, FullDiskIsExitOneAndLeavesNoFileBehind) {
  // Before: reconstruct and simulate exited 0 leaving a short PLY whose
  // header promised every vertex; --out X.pcd aborted (exit 134) and left
  // X.pcd.tmp-PID behind.
  const std::string out = Tmp("full");
  sweepscan::testing::ShellOrFail("mkdir -p '" + out + "'");
  for (const char* ext : {"ply", "pcd"}) {
    const std::string cloud = out + "/cloud." + ext;
    CommandRun r = CliWithFullDisk("reconstruct " + Session() + " --out " + cloud);
    EXPECT_EQ(r.code, 1) << r.out;
    ExpectOneErrorLine(r, cloud + ": write failed: File too large");
    r = CliWithFullDisk("simulate --scenario " + Scenario("lab") + " --out " + cloud +
                        " --session " + Tmp("full-sim.sweepscan") + " --overwrite",
                        4096);
    EXPECT_EQ(r.code, 1) << r.out;
    ExpectOneErrorLine(r, cloud + ": write failed: File too large");
  }
  const CommandRun r = CliWithFullDisk("export " + Session() + " --out " + out + "/csv");
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectOneErrorLine(r, out + "/csv/lidar.csv: write failed: File too large");
  // No cloud, no temporary, and no folder of CSV files: the export made
  // it, and left it empty.
  EXPECT_EQ(LsA(out), "");
  // A repair and a simulated drive cut short by the full disk: the new
  // session folder left behind (its frames.bin torn, or only meta.json) went
  // for a recording, and the next run needed --overwrite.
  CommandRun torn = CliWithFullDisk("repair " + Session() + " --out " + out + "/repaired");
  EXPECT_EQ(torn.code, 1) << torn.out;
  ExpectOneErrorLine(torn, out + "/repaired/frames.bin");
  torn = CliWithFullDisk("simulate --scenario " + Scenario("lab") + " --out " + out +
                         "/torn.ply --session " + out + "/torn.sweepscan");
  EXPECT_EQ(torn.code, 1) << torn.out;
  ExpectOneErrorLine(torn, out + "/torn.sweepscan/frames.bin");
  EXPECT_EQ(LsA(out), "");
  // The floor plan's drawings (60-70 kB of the lab) over older ones: those
  // stay as they were.
  for (const char* drawing : {"--svg plan.svg", "--dxf plan.dxf"}) {
    const std::string name = std::string(drawing).substr(6);
    sweepscan::testing::ShellOrFail("cd '" + out + "' && echo older > " + name);
    const CommandRun p = CliWithFullDisk("plan --scenario " + Scenario("lab") + " " +
                                             std::string(drawing).substr(0, 6) + out + "/" + name,
                                         16);
    EXPECT_EQ(p.code, 1) << p.out;
    ExpectOneErrorLine(p, out + "/" + name + ": write failed: File too large");
    EXPECT_EQ(sweepscan::testing::RunCommand("cat '" + out + "/" + name + "'").out, "older\n");
    sweepscan::testing::ShellOrFail("rm '" + out + "/" + name + "'");
  }
  // A ROS 1 bag: rosbag's ~Bag closed the bag again after a failed write,
  // threw from the destructor (std::terminate, exit 134) and left
  // cloud.bag.tmp-PID behind.
  for (int kib : {16, 200}) {
    const CommandRun b = CliWithFullDisk(
        "export " + Session() + " --format rosbag --out " + out + "/cloud.bag", kib);
    EXPECT_EQ(b.code, 1) << kib << " KiB: " << b.out;
    ExpectOneErrorLine(b, out + "/cloud.bag: cannot write the ROS 1 bag");
  }
  EXPECT_EQ(LsA(out), "");  // No temporary either.
}

// A cloud's suffix in capitals is the same format in every command
// (simulate refused --out X.PLY, and plan and evaluate took X.PLY for a
// session folder, while reconstruct and export accepted it).
TEST_F(CliRobustnessTest, CloudSuffixesInCapitalsAreTheSameFormatsEverywhere) {
  const std::string cloud = Tmp("CAPS.PLY");
  CommandRun r = Cli("simulate --scenario " + Scenario("lab") + " --out " + cloud + " --session " +
                     Tmp("caps.sweepscan") + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("plan " + cloud + " --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"walls\""), std::string::npos) << r.out;
  r = Cli("evaluate " + cloud + " --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"planes\""), std::string::npos) << r.out.substr(0, 400);
}

TEST_F(CliRobustnessTest, UnwritableOutputIsExitOneInEveryCommand) {
  // Before: exit 1 in reconstruct but exit 2 in simulate.
  const std::string folder = Tmp("a-folder.ply");
  sweepscan::testing::ShellOrFail("mkdir -p '" + folder + "'");
  WriteText(Tmp("not-a-folder"), "a file");
  for (const std::string& args :
       {"reconstruct " + Session() + " --out " + folder,
        "simulate --scenario " + Scenario("lab") + " --out " + folder + " --session " +
            Tmp("u.sweepscan") + " --overwrite",
        "export " + Session() + " --out " + folder,  // A cloud (.ply) where a folder is.
        "export " + Session() + " --out " + Tmp("not-a-folder"),  // CSV folder where a file is.
        "repair " + Session() + " --out " + Tmp("lab.ply/x"),
        "repair " + Session() + " --out " + Session(),  // a folder that is not empty
        "record --serial /dev/null --out " + folder,    // record writes a new session folder
        "calibrate --scenario " + Scenario("lab_circle") + " --auto --out " + folder}) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 1) << args << ": " << r.out;
    ExpectOneErrorLine(r, "");
  }
}

// An option a command takes but that has no use for the input or mode
// given is refused with exit 2, not ignored (before, each of these ran to
// exit 0 without it: the plan drawn uncorrected, the CSV in no frame, the
// scenario's seed applied to nothing).
TEST_F(CliRobustnessTest, AnOptionThatDoesNotApplyIsRefusedNotIgnored) {
  const std::string cloud = Tmp("lab.ply");  // written by the fixture
  const std::string calibration = Tmp("zero-calibration.json");
  WriteText(calibration, R"({"alpha_rad": 0, "beta_rad": 0, "gamma_rad": 0})");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"plan " + cloud + " --calibration " + calibration,
       "--calibration does not apply to a cloud file"},
      {"plan " + cloud + " --pose-source odometry", "--pose-source does not apply to a cloud file"},
      {"plan " + Session() + " --sessions a,b", "--sessions does not apply to a session"},
      {"plan " + Session() + " --seed 3", "--seed does not apply to a session"},
      {"evaluate " + cloud + " --strict", "--strict does not apply to a cloud file"},
      {"evaluate " + Session() + " --seed 3", "--seed does not apply to a session"},
      {"calibrate " + Session() + " --auto --seed 3", "--seed does not apply to a session"},
      {"calibrate --scenario " + Scenario("lab_circle") + " --auto --strict",
       "--strict does not apply to --scenario"},
      {"export " + Session() + " --out " + Tmp("csv-frame") + " --frame map",
       "--frame does not apply to a CSV export"},
      {"export " + Session() + " --out " + Tmp("csv-cal") + " --calibration " + calibration,
       "--calibration does not apply to a CSV export"},
      {"simulate --scenario " + Scenario("lab") + " --out " + Tmp("d.ply") +
           " --direct --session " + Tmp("d.sweepscan"),
       "--session does not apply to --direct"},
      {"sfm --rig-scenario room --strict", "--strict does not apply to --rig-scenario"},
      {"sfm " + Session() + " --out " + Tmp("s.ply") + " --frames 3",
       "--frames does not apply to the wheeled scanner"},
      {"record --serial /dev/null --key-file " + calibration + " --out " + Tmp("never.sweepscan"),
       "--key-file does not apply to --serial"},
  };
  for (const auto& [args, why] : cases) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    ExpectOneErrorLine(r, "option " + why);
  }
  EXPECT_FALSE(Exists(Tmp("csv-frame")));
  EXPECT_FALSE(Exists(Tmp("d.ply")));
}

TEST_F(CliRobustnessTest, ForgedPlyHeadersAreExitTwoNotAnAbort) {
  // Before: std::bad_alloc (exit 134) for -5 and 2^64-1; exit 0 with
  // nonsense figures for 10 vertices followed by 1.2 MB of junk.
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex ";
  const std::string props = "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  WriteText(Tmp("neg.ply"), header + "-5" + props);
  WriteText(Tmp("huge.ply"), header + "18446744073709551615" + props + std::string(64, '\0'));
  WriteText(Tmp("junk.ply"), header + "10" + props + std::string(1200000, 'j'));
  for (const char* name : {"neg.ply", "huge.ply", "junk.ply"}) {
    const CommandRun r = Cli("evaluate " + Tmp(name));
    EXPECT_EQ(r.code, 2) << name << ": " << r.out;
    ExpectOneErrorLine(r, std::string(name) + ": not a readable point cloud");
  }
}

TEST_F(CliRobustnessTest, AFolderWhereAFileIsExpectedIsExitTwo) {
  // Before: info and reconstruct died of an uncaught std::ios_base::failure.
  const std::string dir = Tmp("folder-frames.sweepscan");
  sweepscan::testing::ShellOrFail("rm -rf '" + dir + "' && cp -r '" + Session() + "' '" + dir + "' && rm '" + dir +
               "/frames.bin' && mkdir '" + dir + "/frames.bin'");
  for (const std::string& args : {"info " + dir, "reconstruct " + dir + " --out " + Tmp("f.ply"),
                                  "export " + dir + " --out " + Tmp("f-csv"),
                                  "evaluate " + dir}) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    ExpectOneErrorLine(r, "frames.bin: is a folder");
  }
  sweepscan::testing::ShellOrFail("mkdir -p '" + Tmp("cloud-folder.ply") + "'");
  const CommandRun r = Cli("evaluate " + Tmp("cloud-folder.ply"));
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectOneErrorLine(r, "is a folder");
  const CommandRun c = Cli("reconstruct " + Session() + " --out " + Tmp("f.ply") + " --calibration " + Dir());
  EXPECT_EQ(c.code, 2) << c.out;
  ExpectOneErrorLine(c, "is a folder");
  // A project file that is a folder (was exit 1, "unexpected failure:
  // basic_filebuf::underflow error reading the file").
  const std::string project = Tmp("folder.sweepscan-project");
  sweepscan::testing::ShellOrFail("mkdir -p '" + project + "'");
  for (const std::string& args :
       {"project info " + project, "plan " + project + " --svg " + Tmp("f.svg"),
        "project export " + project + " --out " + Tmp("f.las")}) {
    const CommandRun p = Cli(args);
    EXPECT_EQ(p.code, 2) << args << ": " << p.out;
    ExpectOneErrorLine(p, project + ": is a folder, expected a file");
  }
}

TEST_F(CliRobustnessTest, OneFlippedByteLosesOneRecordWithAWarning) {
  // Before: every command refused the whole session ("record 9375 ... CRC
  // mismatch", exit 2) with no remedy.
  const std::string dir = DamagedCopy("rot.sweepscan");
  CommandRun r = Cli("reconstruct " + dir + " --out " + Tmp("rot.ply") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("sweepscan-cli: warning: " + dir + "/frames.bin: 1 damaged record skipped"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("s of data lost"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("sweepscan-cli repair"), std::string::npos) << r.out;
  const CommandRun good = Cli("reconstruct " + Session() + " --out " + Tmp("good.ply") + " --json");
  ASSERT_EQ(good.code, 0) << good.out;
  const auto points = [](const std::string& out) {
    return nlohmann::json::parse(out.substr(out.find('{')))["points"].get<long>();
  };
  // One record (a fraction of one revolution) is all that is lost.
  EXPECT_GT(points(r.out), points(good.out) - 1000);

  // --strict refuses, with the place and the remedy.
  r = Cli("reconstruct " + dir + " --out " + Tmp("rot.ply") + " --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectOneErrorLine(r, "CRC mismatch (run without --strict");

  // info reports the damage.
  r = Cli("info " + dir + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_TRUE(info["damage"]["damaged"].get<bool>());
  EXPECT_EQ(info["damage"]["records_skipped"].get<int>(), 1);
  EXPECT_GT(info["damage"]["places"][0]["byte_offset"].get<long>(), 16);
  r = Cli("info " + Session() + " --json");
  EXPECT_FALSE(nlohmann::json::parse(r.out)["damage"]["damaged"].get<bool>());
  EXPECT_EQ(Cli("info " + dir + " --strict").code, 2);
}

// A repair killed midway (held in its first fsync, frames.bin's, then
// SIGKILL) leaves no NEW that could pass for a repaired session (NEW used
// to be there from the start, its meta.json and side files copied last):
// only the hidden .NEW.repairing-PID. The next repair to NEW succeeds.
TEST_F(CliRobustnessTest, ARepairKilledMidwayLeavesNoSession) {
  const std::string out = Tmp("killed.sweepscan");
  std::filesystem::remove_all(out);
  sweepscan::testing::HeldIoctlProcess repair({SWEEPSCAN_CLI, "repair", Session(), "--out", out},
                                              sweepscan::testing::HeldSyscall{__NR_fsync});
  if (!repair.error.empty()) GTEST_SKIP() << repair.error;
  std::string said;
  for (int i = 0; i < 3000 && !repair.Holding() && !repair.Exited(); ++i) {
    said += repair.Read();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(repair.Holding()) << said << repair.Read();
  const std::string writing = Tmp(".killed.sweepscan.repairing-" + std::to_string(repair.pid));
  EXPECT_TRUE(Exists(writing + "/frames.bin.tmp-" + std::to_string(repair.pid)));
  EXPECT_FALSE(Exists(out));
  ::kill(repair.pid, SIGKILL);
  for (int i = 0; i < 1000 && !repair.Exited(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(repair.Exited());
  EXPECT_FALSE(Exists(out));
  EXPECT_TRUE(Exists(writing));
  const CommandRun again = Cli("repair " + Session() + " --out " + out);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_TRUE(Exists(out + "/meta.json"));
  EXPECT_EQ(sweepscan::testing::ReadWholeFile(out + "/frames.bin"),
            sweepscan::testing::ReadWholeFile(Session() + "/frames.bin"));
}

TEST_F(CliRobustnessTest, RepairWritesACleanCopyThatPassesStrict) {
  const std::string dir = DamagedCopy("rot2.sweepscan");
  const std::string fixed = Tmp("fixed.sweepscan");
  sweepscan::testing::ShellOrFail("rm -rf '" + fixed + "'");
  CommandRun r = Cli("repair " + dir + " --out " + fixed + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["damage"]["records_skipped"].get<int>(), 1);
  r = Cli("info " + fixed + " --strict --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["frames"]["records"].get<long>(),
            report["records_kept"].get<long>());
  EXPECT_TRUE(Exists(fixed + "/meta.json"));
  // The copy holds exactly the intact records: the same cloud as the
  // damaged session read past its damage.
  const auto points = [](const CommandRun& run) {
    return nlohmann::json::parse(run.out.substr(run.out.find('{')))["points"].get<long>();
  };
  const CommandRun fixed_cloud =
      Cli("reconstruct " + fixed + " --out " + Tmp("fixed.ply") + " --json");
  const CommandRun damaged_cloud =
      Cli("reconstruct " + dir + " --out " + Tmp("rot2.ply") + " --json");
  ASSERT_EQ(fixed_cloud.code, 0) << fixed_cloud.out;
  EXPECT_EQ(points(fixed_cloud), points(damaged_cloud));
  // An intact session repairs to the same bytes.
  const std::string same = Tmp("same.sweepscan");
  sweepscan::testing::ShellOrFail("rm -rf '" + same + "'");
  ASSERT_EQ(Cli("repair " + Session() + " --out " + same).code, 0);
  EXPECT_EQ(sweepscan::testing::ReadWholeFile(same + "/frames.bin"),
            sweepscan::testing::ReadWholeFile(Session() + "/frames.bin"));
  // The damaged session is untouched; NEW must be new.
  EXPECT_EQ(Cli("info " + dir + " --strict").code, 2);
  r = Cli("repair " + dir + " --out " + fixed);
  EXPECT_EQ(r.code, 1) << r.out;  // an output in the way, as for every command
  ExpectOneErrorLine(r, "not empty");
  // frames.bin that is not one (its magic gone) is refused, and the new
  // folder it would have gone into is not left behind.
  const std::string unframed = DamagedCopy("unframed.sweepscan", 0);
  const std::string nowhere = Tmp("nowhere.sweepscan");
  sweepscan::testing::ShellOrFail("rm -rf '" + nowhere + "'");
  r = Cli("repair " + unframed + " --out " + nowhere);
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectOneErrorLine(r, "frames.bin");
  EXPECT_FALSE(Exists(nowhere));
}

TEST_F(CliRobustnessTest, CalibrateAndEvaluateAcceptStrictAndWarn) {
  const std::string dir = DamagedCopy("rot3.sweepscan");
  CommandRun r = Cli("evaluate " + dir + " --json");
  EXPECT_EQ(r.code, 0) << r.out.substr(0, 400);
  EXPECT_NE(r.out.find("warning: " + dir + "/frames.bin: 1 damaged record"), std::string::npos);
  r = Cli("evaluate " + dir + " --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("calibrate " + dir + " --auto --strict");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectOneErrorLine(r, "CRC mismatch");
}

// No output replaces what the command reads, or another output: `export S
// --format rosbag --out S/frames.bin` replaced the recording with a bag,
// `simulate --truth` named as the scenario overwrote it, `plan d.ply --svg
// d.ply` overwrote the cloud (all exit 0). Refused before any work.
TEST_F(CliRobustnessTest, AnOutputNeverReplacesAnInput) {
  const std::string session = Session();
  const std::string frames = Read(session + "/frames.bin");
  const std::string scenario = Tmp("mine.json");
  WriteText(scenario, Read(Scenario("lab")));
  const std::string cloud = Tmp("lab.ply");
  const std::string cloud_bytes = Read(cloud);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"export " + session + " --format rosbag --out " + session + "/frames.bin",
       "--out " + session + "/frames.bin is inside the session folder " + session +
           ", which holds the recording: write it elsewhere"},
      {"export " + session + " --out " + session, "is inside the session folder"},
      {"export " + session + " --out " + session + "/cloud.las", "is inside the session folder"},
      {"reconstruct " + session + " --out " + session + "/../lab.sweepscan/x.ply",
       "is inside the session folder"},
      {"simulate --scenario " + scenario + " --out " + Tmp("m.ply") + " --truth " + scenario,
       "--truth " + scenario + " is the --scenario file: it would be replaced"},
      {"plan " + cloud + " --svg " + cloud, "--svg " + cloud + " is the input " + cloud},
      {"plan " + cloud + " --svg " + Tmp("o.svg") + " --dxf " + Tmp("o.svg"),
       "--dxf " + Tmp("o.svg") + " is also --svg's file: give each output its own"},
  };
  for (const auto& [args, expect] : cases) {
    const CommandRun r = Cli(args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    ExpectOneErrorLine(r, expect);
  }
  EXPECT_EQ(Read(session + "/frames.bin"), frames);
  EXPECT_EQ(Read(scenario), Read(Scenario("lab")));
  EXPECT_EQ(Read(cloud), cloud_bytes);
  EXPECT_FALSE(Exists(Tmp("m.sweepscan")));
  EXPECT_FALSE(Exists(Tmp("o.svg")));
  EXPECT_EQ(LsA(session), "frames.bin\nmeta.json\n");

  // An unwritable --truth is said before the drive is simulated (it was
  // said after, the session and cloud left behind).
  WriteText(Tmp("a-file"), "not a folder");
  const CommandRun r = Cli("simulate --scenario " + scenario + " --out " + Tmp("t.ply") +
                           " --truth " + Tmp("a-file") + "/t.json");
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectOneErrorLine(r, Tmp("a-file") + "/t.json");
  EXPECT_FALSE(Exists(Tmp("t.sweepscan")));
  EXPECT_FALSE(Exists(Tmp("t.ply")));
  // sfm's poses likewise (they were tried after the cloud was written).
  const CommandRun sfm = Cli("sfm --rig-scenario room --frames 20 --out " + Tmp("r.ply") +
                             " --poses " + Tmp("a-file") + "/p.csv");
  EXPECT_EQ(sfm.code, 1) << sfm.out;
  ExpectOneErrorLine(sfm, Tmp("a-file") + "/p.csv");
  EXPECT_FALSE(Exists(Tmp("r.ply")));
  const CommandRun same =
      Cli("sfm --rig-scenario room --frames 20 --out " + Tmp("r.ply") + " --poses " + Tmp("r.ply"));
  EXPECT_EQ(same.code, 2) << same.out;
  ExpectOneErrorLine(same, "--poses " + Tmp("r.ply") + " is also --out's file");
}

}  // namespace
