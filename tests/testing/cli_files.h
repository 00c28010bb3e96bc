// Files for the tests that run sweepscan-cli as a script would
// (tests/app/cli_ros_test.cc, cli_ros2_test.cc): the repository's files, a
// scratch folder of the test process, whole files read back.
#ifndef SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_
#define SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/testing/remove_at_exit.h"

namespace sweepscan::testing {

// PATH in the source tree.
inline std::string SourcePath(const std::string& path) { return std::string(SWEEPSCAN_SOURCE_DIR) + "/" + path; }

// NAME in a folder of this test process's own (CTest runs a file's cases
// side by side, each in its process), made again if a suite's teardown
// removed it and another suite of the same process follows.
inline std::string ProcessTmp(const std::string& name) {
  static const std::string dir = [] {
    std::string t = ::testing::TempDir() + "/sweepscan_test_XXXXXX";
    return RemoveAtExit(std::string(mkdtemp(&t[0])));
  }();
  mkdir(dir.c_str(), 0700);
  return dir + "/" + name;
}

inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// Expects the three angles of `sweepscan-cli calibrate --json` (its output
// `out`, parsed as `calibration`) within three of their sigmas and 1 mrad
// of the mounting error hidden in resources/scenarios/SCENARIO.json.
inline void ExpectScenarioMountingError(const nlohmann::json& calibration,
                                        const std::string& scenario, const std::string& out) {
  const nlohmann::json truth_file =
      nlohmann::json::parse(ReadWholeFile(SourcePath("resources/scenarios/" + scenario + ".json")));
  for (const char* k : {"alpha", "beta", "gamma"}) {
    const double truth = truth_file["mounting_error_rad"][k];
    const double err = calibration["mounting_error_rad"][k].get<double>() - truth;
    EXPECT_LT(std::abs(err), 3.0 * calibration["sigma_rad"][k].get<double>()) << k << "\n" << out;
    EXPECT_LT(std::abs(err), 1e-3) << k;
  }
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_
