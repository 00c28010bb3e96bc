#include "core/scenario/scenario.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

nlohmann::json Minimal() {
  return nlohmann::json::parse(R"({
    "format": "sweepscan-scenario", "version": 1,
    "scene": {"preset": "lab"},
    "path": {"start": {"x_m": 1, "y_m": 2, "yaw_rad": 0},
             "segments": [{"v_mps": 0.2, "w_radps": 0, "duration_s": 5}]}
  })");
}

std::string ErrorOf(const nlohmann::json& j) {
  sim::SimConfig c;
  const Status s = ScenarioFromJson(j, "s.json", &c);
  return s.ok() ? "" : s.message();
}

TEST(ScenarioTest, MinimalFileGetsDefaults) {
  sim::SimConfig c;
  ASSERT_TRUE(ScenarioFromJson(Minimal(), "s.json", &c).ok());
  EXPECT_EQ(c.scene.boxes().size(), sim::LabScene().boxes().size());
  EXPECT_DOUBLE_EQ(c.geometry.lidar_height_m, RobotGeometry().lidar_height_m);
  EXPECT_DOUBLE_EQ(c.DurationSeconds(), 5.0);
}

TEST(ScenarioTest, ShippedScenariosLoad) {
  for (const char* name : {"lab", "lab_circle", "lab_circle_two_turns", "lab_circle_diamond",
                           "lab_slip", "stairwell"}) {
    sim::SimConfig c;
    const Status s = LoadScenario(std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + name + ".json", &c);
    EXPECT_TRUE(s.ok()) << s.message();
  }
}

TEST(ScenarioTest, ExplicitFormRoundTrips) {
  nlohmann::json j = Minimal();
  j["mounting_error_rad"] = {{"alpha", -0.0058}, {"beta", 0.0126}, {"gamma", 0.0355}};
  j["slips"] = nlohmann::json::array({{{"start_s", 1}, {"duration_s", 2}, {"wheel", "left"}, {"extra", 0.3}}});
  sim::SimConfig a, b;
  ASSERT_TRUE(ScenarioFromJson(j, "s.json", &a).ok());
  const Status s = ScenarioFromJson(ScenarioToJson(a), "again.json", &b);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(ScenarioToJson(a), ScenarioToJson(b));
  EXPECT_DOUBLE_EQ(b.mounting_error.gamma, 0.0355);
  ASSERT_EQ(b.slips.size(), 1u);
}

TEST(ScenarioTest, LidarEdgeEffectsRoundTrip) {
  nlohmann::json j = Minimal();
  j["lidar"] = {{"range_offset_m", 0.006}, {"range_scale_error", 0.005},
                {"mixed_return_share", 0.4}, {"mixed_blend_share", 0.25},
                {"mixed_footprint_rad", 0.01}, {"mixed_min_jump_m", 0.05}};
  sim::SimConfig a, b;
  ASSERT_TRUE(ScenarioFromJson(j, "s.json", &a).ok());
  ASSERT_TRUE(ScenarioFromJson(ScenarioToJson(a), "again.json", &b).ok());
  EXPECT_DOUBLE_EQ(b.lidar.range_scale_error, 0.005);
  EXPECT_DOUBLE_EQ(b.lidar.mixed_return_share, 0.4);
  EXPECT_DOUBLE_EQ(b.lidar.mixed_blend_share, 0.25);
  EXPECT_DOUBLE_EQ(b.lidar.mixed_footprint_rad, 0.01);
  EXPECT_DOUBLE_EQ(b.lidar.mixed_min_jump_m, 0.05);
  // Off by default: today's drives unchanged.
  sim::SimConfig c;
  ASSERT_TRUE(ScenarioFromJson(Minimal(), "s.json", &c).ok());
  EXPECT_EQ(c.lidar.mixed_return_share, 0.0);
  EXPECT_EQ(c.lidar.range_scale_error, 0.0);
  j["lidar"] = {{"mixed_return_share", 1.5}};
  EXPECT_NE(ErrorOf(j).find("lidar.mixed_return_share"), std::string::npos) << ErrorOf(j);
}

TEST(ScenarioTest, DiamondPresetAndPitchedBoxesRoundTrip) {
  nlohmann::json j = Minimal();
  j["scene"] = {{"preset", "lab-diamond"},
                {"boxes", nlohmann::json::array({{{"label", "tilted"},
                                                  {"center", {1, 1, 1}},
                                                  {"size", {0.5, 0.01, 0.5}},
                                                  {"pitch_rad", 0.3}}})}};
  sim::SimConfig a, b;
  ASSERT_TRUE(ScenarioFromJson(j, "s.json", &a).ok());
  const int target = a.scene.Find("target");
  ASSERT_GE(target, 0);
  EXPECT_NEAR(a.scene.boxes()[target].pitch, M_PI / 4, 1e-12);
  EXPECT_DOUBLE_EQ(a.scene.boxes().back().pitch, 0.3);
  const Status s = ScenarioFromJson(ScenarioToJson(a), "again.json", &b);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_DOUBLE_EQ(b.scene.boxes().back().pitch, 0.3);
  EXPECT_NEAR(b.scene.boxes()[target].pitch, M_PI / 4, 1e-12);
}

TEST(ScenarioTest, CircleSegment) {
  const sim::DriveSegment s = CircleSegment(0.83, 0.2, 1.0, false);
  EXPECT_NEAR(s.w, -0.2 / 0.83, 1e-12);
  EXPECT_NEAR(s.duration_s, 2 * M_PI * 0.83 / 0.2, 1e-9);
}

struct BadCase {
  const char* what;
  std::function<void(nlohmann::json*)> mutate;
  const char* expected;  // a substring of the one-line error
};

TEST(ScenarioTest, BadFilesGiveOneClearError) {
  const std::vector<BadCase> cases = {
      {"missing path", [](nlohmann::json* j) { j->erase("path"); }, "s.json: path: missing"},
      {"missing scene", [](nlohmann::json* j) { j->erase("scene"); }, "scene: missing"},
      {"wrong format", [](nlohmann::json* j) { (*j)["format"] = "ply"; }, "format: must be"},
      {"wrong version", [](nlohmann::json* j) { (*j)["version"] = 7; }, "unsupported version 7"},
      {"wrong type",
       [](nlohmann::json* j) {
         (*j)["robot"] = {{"lidar_height_m", "high"}};
       },
       "robot.lidar_height_m: expected a number, got a string"},
      {"negative size",
       [](nlohmann::json* j) {
         (*j)["scene"]["boxes"] = {{{"center", {0, 0, 0}}, {"size", {1, -2, 1}}}};
       },
       "scene.boxes[0].size[1]: must be > 0"},
      {"negative wheel distance",
       [](nlohmann::json* j) {
         (*j)["robot"] = {{"wheel_distance_m", -0.1}};
       },
       "robot.wheel_distance_m: must be > 0, got -0.1"},
      {"zero duration", [](nlohmann::json* j) { (*j)["path"]["segments"][0]["duration_s"] = 0; },
       "path.segments[0].duration_s: must be > 0"},
      {"unknown key", [](nlohmann::json* j) { (*j)["robott"] = 1; }, "robott: unknown key"},
      {"unknown preset", [](nlohmann::json* j) { (*j)["scene"]["preset"] = "moon"; },
       "unknown preset 'moon'"},
      {"bad wheel",
       [](nlohmann::json* j) {
         (*j)["slips"] = {{{"duration_s", 1}, {"wheel", "middle"}, {"extra", 0.1}}};
       },
       "slips[0].wheel"},
      {"huge mounting error",
       [](nlohmann::json* j) {
         (*j)["mounting_error_rad"] = {{"gamma", 3.0}};
       },
       "mounting_error_rad.gamma: must be within"},
      {"not an object", [](nlohmann::json* j) { *j = nlohmann::json::array(); },
       "expected an object"},
      // 2^32 s was a recording that grew until the disk was full; 1e308 s a
      // session of a header alone.
      {"a path of 136 years",
       [](nlohmann::json* j) { (*j)["path"]["segments"][0]["duration_s"] = 4294967296.0; },
       "path.segments: the path lasts 4294967296"},
      {"a path longer than a week in pieces",
       [](nlohmann::json* j) {
         (*j)["path"]["segments"] = {{{"v_mps", 0}, {"w_radps", 0}, {"duration_s", 400000}},
                                     {{"v_mps", 0.1}, {"w_radps", 0}, {"duration_s", 400000}}};
       },
       "at most a week (604800 s)"},
      {"a start beyond 8 km", [](nlohmann::json* j) { (*j)["path"]["start"]["x_m"] = -1e308; },
       "path.start.x_m: the start must be within 8000 m"},
  };
  for (const BadCase& c : cases) {
    nlohmann::json j = Minimal();
    c.mutate(&j);
    const std::string error = ErrorOf(j);
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.what << ": got '" << error << "'";
    EXPECT_EQ(error.find('\n'), std::string::npos) << c.what;
  }
}

TEST(ScenarioTest, NanAndSyntaxErrorsAreRefused) {
  const std::string path = ::testing::TempDir() + "/sweepscan_nan.json";
  FILE* f = std::fopen(path.c_str(), "w");
  std::fputs("{\"format\": \"sweepscan-scenario\", \"version\": 1, \"seed\": NaN}", f);
  std::fclose(f);
  sim::SimConfig c;
  const Status s = LoadScenario(path, &c);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not valid JSON"), std::string::npos) << s.message();
  EXPECT_FALSE(LoadScenario("/nonexistent/scenario.json", &c).ok());
}

}  // namespace
}  // namespace sweepscan
