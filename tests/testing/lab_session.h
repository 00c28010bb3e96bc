// The streaming tests' session: a 40 s drive of the lab (turns and
// straights, so every pose component moves) simulated through the real
// bytes into the test's temporary folder, once per test process; and
// copies of it with damage in the middle of frames.bin.
#ifndef SWEEPSCAN_TESTS_TESTING_LAB_SESSION_H_
#define SWEEPSCAN_TESTS_TESTING_LAB_SESSION_H_

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "hardware/emulation/simulate_session.h"
#include "tests/testing/run_command.h"
#include "tests/testing/worlds.h"
#include "tests/testing/remove_at_exit.h"

namespace sweepscan::testing {

inline const std::string& LabDriveSession() {
  static const std::string dir = [] {
    const std::string d =
        ::testing::TempDir() + "/sweepscan_lab_drive_" + std::to_string(::getpid()) + ".sweepscan";
    ShellOrFail("rm -rf '" + d + "'");
    RemoveAtExit(d);
    sim::SimConfig config = LabConfig(3);
    config.path = {{0.2, 0.0, 12.0}, {0.0, 0.3, 8.0}, {0.15, 0.1, 10.0}, {0.2, -0.05, 10.0}};
    hardware::SimulateSessionReport report;
    const Status s =
        hardware::SimulateSession(config, d, hardware::SimulateSessionOptions(), &report);
    EXPECT_TRUE(s.ok()) << s.message();
    return d;
  }();
  return dir;
}

// A copy of `session` (as SESSION.damaged) with `bytes` bytes overwritten
// from the middle of frames.bin: 60 000 bytes of the lab drive are about
// 1.5 s of records, a gap in every stream.
inline std::string DamagedCopy(const std::string& session, size_t bytes) {
  const std::string d = RemoveAtExit(session + ".damaged");
  ShellOrFail("rm -rf '" + d + "' && cp -r '" + session + "' '" + d + "'");
  std::fstream f(d + "/frames.bin", std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(0, std::ios::end);
  const std::streamoff size = f.tellg();
  f.seekp(size / 2);
  for (size_t i = 0; i < bytes; ++i) f.put(static_cast<char>(0xA5 ^ (i * 131)));
  return d;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_LAB_SESSION_H_
