// A scenario of resources/scenarios/ loaded for a test (the test target
// defines SWEEPSCAN_SOURCE_DIR); a scenario that does not load fails the test.
#ifndef SWEEPSCAN_TESTS_TESTING_SCENARIO_FILE_H_
#define SWEEPSCAN_TESTS_TESTING_SCENARIO_FILE_H_

#include <gtest/gtest.h>

#include <string>

#include "core/scenario/scenario.h"

namespace sweepscan::testing {

inline sim::SimConfig ScenarioFile(const std::string& name) {
  sim::SimConfig config;
  const Status status =
      LoadScenario(std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + name, &config);
  EXPECT_TRUE(status.ok()) << status.message();
  return config;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_SCENARIO_FILE_H_
