// Runs a shell command the way an operator or a script would and captures
// its exit code and combined stdout/stderr (for tests of the executables).
#ifndef SWEEPSCAN_TESTS_TESTING_RUN_COMMAND_H_
#define SWEEPSCAN_TESTS_TESTING_RUN_COMMAND_H_

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace sweepscan::testing {

struct CommandRun {
  int code = -1;    // exit code, -1 if killed by a signal
  std::string out;  // stdout and stderr
};

inline CommandRun RunCommand(const std::string& command) {
  CommandRun r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// Runs a setup or clean-up command (mkdir, cp, rm -rf) through the shell; a
// failure is a (non-fatal) test failure, so it also works in destructors and
// static tear-downs.
inline void ShellOrFail(const std::string& command) {
  const int status = std::system(command.c_str());
  if (status != 0) ADD_FAILURE() << "`" << command << "` failed (status " << status << ")";
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_RUN_COMMAND_H_
