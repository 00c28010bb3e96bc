// Files for the tests that run sweepscan-cli as a script would
// (tests/app/cli_ros_test.cc, cli_ros2_test.cc): the repository's files, a
// scratch folder of the test process, whole files read back.
#ifndef SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_
#define SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <fstream>
#include <iterator>
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

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_CLI_FILES_H_
