// The pairs solver on synthetic pairs (its refusals: too few pairs, one
// pass only, NaN, duplicates, bad options) and the two files the
// calibration writes (the pairs file, the calibration file): round trips
// and strictness. The solves on simulated drives are in calibration_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "core/calibration/calibration.h"
#include "core/calibration/internal.h"

namespace sweepscan {
namespace {

LidarObservation Obs(double x, double y, double z, int64_t t_ns, uint32_t scan) {
  LidarObservation o;
  o.ref = {scan, 0};
  o.time_ns = t_ns;
  o.p_lidar = Eigen::Vector3d(0.0, y, z);
  o.world_from_body = Rigid3d::FromPose(x, 0, 0, 0, 0, 0);
  return o;
}

std::vector<ObservationPair> SyntheticPairs(int n) {
  std::vector<ObservationPair> pairs;
  for (int k = 0; k < n; ++k) {
    pairs.push_back({Obs(0, -0.7, 0.5 + 0.2 * k, 1'000'000'000 + k, k),
                     Obs(0, 2.3, 0.5 + 0.2 * k, 20'000'000'000 + k, 100 + k)});
  }
  return pairs;
}

TEST(SolvePairsTest, TooFewPairs) {
  CalibrationSummary s;
  const Status st = SolvePairs(SyntheticPairs(3), RobotGeometry(), {}, CalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("at least 4 pairs"), std::string::npos) << st.message();
}

TEST(SolvePairsTest, PairFromOnePassOnly) {
  auto pairs = SyntheticPairs(4);
  pairs[2].pass2.time_ns = pairs[2].pass1.time_ns + 100'000'000;
  CalibrationSummary s;
  const Status st = SolvePairs(pairs, RobotGeometry(), {}, CalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("pair 3 (pairs[2]): both picks are from one pass"), std::string::npos)
      << st.message();
}

TEST(SolvePairsTest, NaNIsRefused) {
  auto pairs = SyntheticPairs(4);
  pairs[1].pass1.p_lidar.y() = std::nan("");
  CalibrationSummary s;
  Status st = SolvePairs(pairs, RobotGeometry(), {}, CalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("pair 2"), std::string::npos) << st.message();
  st = SolvePairs(SyntheticPairs(4), RobotGeometry(), {std::nan(""), 0, 0}, CalibrationOptions(),
                  &s);
  EXPECT_FALSE(st.ok());
}

TEST(SolvePairsTest, DuplicatePairsAreRefused) {
  auto pairs = SyntheticPairs(4);
  pairs[3] = pairs[0];
  CalibrationSummary s;
  const Status st = SolvePairs(pairs, RobotGeometry(), {}, CalibrationOptions(), &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("same samples as pair 1 (pairs[0])"), std::string::npos)
      << st.message();
}

TEST(SolvePairsTest, InvalidOptions) {
  CalibrationOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.loss = RobustLoss::kHuber;
  o.loss_scale_m = 0.0;
  EXPECT_FALSE(o.IsValid(&error));
  CalibrationSummary s;
  EXPECT_FALSE(SolvePairs(SyntheticPairs(4), RobotGeometry(), {}, o, &s).ok());
}

TEST(PairsFileTest, RoundTripAndStrictness) {
  std::vector<PickPair> pairs(4);
  for (int k = 0; k < 4; ++k) {
    pairs[k].pass1.has_sample = true;
    pairs[k].pass1.sample.time_ns = 1'000'000'123'456'789 + 200'000 * k;
    pairs[k].pass1.sample.range_m = 1.25f + 0.001f * static_cast<float>(k);  // float, as decoded
    pairs[k].pass1.sample.theta_rad = -0.75f;
    pairs[k].pass2.world = Eigen::Vector3d(5.0, 0.16, 1.0 + 0.1 * k);
  }
  pairs[2].pass2 = PositionPick({12, 345});  // An older file's pick, kept as it was.
  std::vector<PickPair> back;
  ASSERT_TRUE(ParsePairs(PairsToJson(pairs), "mem", &back).ok());
  ASSERT_EQ(back.size(), 4u);
  EXPECT_TRUE(back[3].pass1.has_sample && !back[3].pass1.by_position);
  EXPECT_EQ(back[3].pass1.sample.time_ns, 1'000'000'124'056'789);
  EXPECT_EQ(back[3].pass1.sample.range_m, pairs[3].pass1.sample.range_m);
  EXPECT_EQ(back[3].pass1.sample.theta_rad, -0.75);
  EXPECT_FALSE(back[3].pass2.has_sample);
  EXPECT_DOUBLE_EQ(back[3].pass2.world.z(), 1.3);
  EXPECT_TRUE(back[2].pass2.has_sample && back[2].pass2.by_position);
  EXPECT_EQ(back[2].pass2.position, (SampleRef{12, 345}));

  // A version-1 file by (scan, beam), as written before picks were named
  // by time, loads as such; a pick by time alone (no checks) too.
  ASSERT_TRUE(ParsePairs(R"({"format":"sweepscan-pairs","version":1,"pairs":[
      {"pass1":{"scan":41,"beam":512},"pass2":{"time_ns":7}}]})",
                         "old.json", &back)
                  .ok());
  ASSERT_EQ(back.size(), 1u);
  EXPECT_TRUE(back[0].pass1.has_sample && back[0].pass1.by_position);
  EXPECT_EQ(back[0].pass1.position, (SampleRef{41, 512}));
  EXPECT_TRUE(back[0].pass2.has_sample && !back[0].pass2.by_position);
  EXPECT_EQ(back[0].pass2.sample.time_ns, 7);
  EXPECT_TRUE(std::isnan(back[0].pass2.sample.range_m));

  const auto fails = [](const std::string& text, const std::string& expect) {
    std::vector<PickPair> p;
    const Status st = ParsePairs(text, "p.json", &p);
    EXPECT_FALSE(st.ok()) << text;
    EXPECT_NE(st.message().find(expect), std::string::npos) << st.message();
  };
  const std::string head = R"({"format":"sweepscan-pairs","version":1,"pairs":[)";
  fails(R"({"format":"x","version":1,"pairs":[]})", "format");
  fails(R"({"format":"sweepscan-pairs","version":2,"pairs":[]})", "version");
  fails(head + R"({"pass1":{"scan":1,"beam":2}}]})", "pass2: missing");
  fails(head + R"({"pass1":{"scan":1},"pass2":{"scan":1,"beam":2}}]})", "beam: missing");
  fails(head + R"({"pass1":{"scan":1,"beam":70000},"pass2":{"scan":1,"beam":2}}]})",
        "out of range");
  fails(head + R"({"pass1":{"scan":-1,"beam":7},"pass2":{"scan":1,"beam":2}}]})", "out of range");
  fails(head + R"({"pass1":{"scan":1.5,"beam":7},"pass2":{"scan":1,"beam":2}}]})", "integer");
  fails(head + R"({"pass1":{"world":[1,2]},"pass2":{"scan":1,"beam":2}}]})", "[x, y, z]");
  fails(head + R"({"pass1":{"world":[1,2,NaN]},"pass2":{"scan":1,"beam":2}}]})", "not valid JSON");
  fails(head + R"({"pass1":{"world":[1,2,"a"]},"pass2":{"scan":1,"beam":2}}]})", "element 2");
  fails(head + R"({"pass1":{"world":[1,2,3],"scan":1,"beam":1},"pass2":{"scan":1,"beam":2}}]})",
        "not several");
  fails(head + R"({"pass1":{"time_ns":5,"scan":1,"beam":1},"pass2":{"scan":1,"beam":2}}]})",
        "not several");
  fails(head + R"({"pass1":{"scan":1,"beam":1,"range_m":2},"pass2":{"scan":1,"beam":2}}]})",
        "range_m: only checks a pick by time_ns");
  fails(head + R"({"pass1":{"time_ns":1.5},"pass2":{"scan":1,"beam":2}}]})", "integer");
  fails(head + R"({"pass1":{},"pass2":{"scan":1,"beam":2}}]})", "not none");
  fails(head + R"({"pass1":{"scan":1,"beam":7,"x":1},"pass2":{"scan":1,"beam":2}}]})",
        "unknown key");
  fails(head + R"({"pass1":{"world":[1,2,1e999]},"pass2":{"scan":1,"beam":2}}]})", "");
}

TEST(CalibrationFileTest, SaveLoadAndStrictness) {
  const std::string path = std::string(SWEEPSCAN_BINARY_DIR) + "/calibration_test_calib.json";
  CalibrationSummary s;
  s.method = "auto-planes";
  s.converged = true;
  s.sigma_rad = Eigen::Vector3d(1e-4, 2e-4, 3e-4);
  const MountingError c{-0.0058, 0.0126, 0.0355};
  ASSERT_TRUE(SaveCalibrationFile(path, c, &s).ok());
  MountingError back;
  ASSERT_TRUE(LoadCalibrationFile(path, &back).ok());
  EXPECT_DOUBLE_EQ(back.alpha, c.alpha);
  EXPECT_DOUBLE_EQ(back.beta, c.beta);
  EXPECT_DOUBLE_EQ(back.gamma, c.gamma);
  std::remove(path.c_str());
  // Nothing is written that the reader would refuse: not a NaN, not an
  // angle beyond its 0.5 rad (a wrong picks solve once wrote 3.66 rad).
  EXPECT_FALSE(SaveCalibrationFile(path, {std::nan(""), 0, 0}, nullptr).ok());
  EXPECT_FALSE(std::ifstream(path).good());
  EXPECT_FALSE(SaveCalibrationFile(path, {0.0, 0.0, 0.5001}, nullptr).ok());
  EXPECT_FALSE(std::ifstream(path).good());
  ASSERT_TRUE(SaveCalibrationFile(path, {-0.5, 0.5, 0.0}, nullptr).ok());
  ASSERT_TRUE(LoadCalibrationFile(path, &back).ok());
  EXPECT_EQ(back.alpha, -0.5);
  std::remove(path.c_str());
  // Each file given as the other says what it is.
  {
    MountingError unused;
    const Status as_calibration = ParseCalibration(
        R"({"format":"sweepscan-pairs","version":1,"pairs":[]})", "p.json", &unused);
    ASSERT_FALSE(as_calibration.ok());
    EXPECT_NE(as_calibration.message().find(
                  "expected \"sweepscan-calibration\", got \"sweepscan-pairs\""),
              std::string::npos)
        << as_calibration.message();
    std::vector<PickPair> pairs;
    const Status as_pairs = ParsePairs(
        R"({"format":"sweepscan-calibration","version":1,"mounting_error_rad":{"alpha":0,"beta":0,"gamma":0}})",
        "c.json", &pairs);
    ASSERT_FALSE(as_pairs.ok());
    EXPECT_NE(
        as_pairs.message().find("expected \"sweepscan-pairs\", got \"sweepscan-calibration\""),
        std::string::npos)
        << as_pairs.message();
  }
  const std::string head = R"({"format":"sweepscan-calibration","version":1,)";
  EXPECT_FALSE(
      ParseCalibration(head + R"("mounting_error_rad":{"alpha":0,"beta":0}})", "c", &back).ok());
  EXPECT_FALSE(
      ParseCalibration(head + R"("mounting_error_rad":{"alpha":0,"beta":0,"gamma":2}})", "c", &back)
          .ok());
  const Status st = ParseCalibration(
      head + R"("mounting_error_rad":{"alpha":0,"beta":0,"gamma":0},"x":1})", "c", &back);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("x: unknown key"), std::string::npos) << st.message();
}

}  // namespace
}  // namespace sweepscan
