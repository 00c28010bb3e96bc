// `sweepscan-cli project` end to end, as an operator or a script runs it, on
// the simulated office floor (core/sim/scene.h OfficeFloorScene): three
// sessions recorded through the byte-exact device emulations, each starting
// where the operator put the robot down. The truth of every registration is
// the scenarios' start poses (resources/scenarios/building_*.json), which the
// project never uses to place anything.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/geometry/transform.h"
#include "core/project/project.h"
#include "tests/testing/run_command.h"
#include "tests/testing/remove_at_exit.h"

namespace sweepscan {
namespace {

using testing::CommandRun;
using testing::RunCommand;

// One folder a process: ctest runs each test of this file as its own
// process, two at a time, and each process's suite set-up empties it.
std::string Dir() {
  return testing::RemoveAtExit(::testing::TempDir() + "/sweepscan_project_cli_" +
                               std::to_string(::getpid()));
}
std::string P(const std::string& name) { return Dir() + "/" + name; }
CommandRun Cli(const std::string& args) { return RunCommand(std::string(SWEEPSCAN_CLI) + " " + args); }

// The scenarios' start poses: world_from_session.
Rigid3d TrueStart(char drive) {
  if (drive == 'a') return Rigid3d::FromPose(2.45, 5.0, 0, 0, 0, -M_PI / 2);
  if (drive == 'b') return Rigid3d::FromPose(7.45, 4.0, 0, 0, 0, -M_PI / 2);
  return Rigid3d::FromPose(1.0, 1.0, 0, 0, 0, 0.0);
}

class ProjectCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::filesystem::remove_all(Dir());
    std::filesystem::create_directories(Dir());
    for (char d : {'a', 'b', 'c'}) {
      const std::string name = std::string("building_") + d;
      const CommandRun r = Cli("simulate --scenario " + std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" +
                               name + ".json --out " + P(name + ".ply") + " --session " + P(name + ".sweepscan"));
      ASSERT_EQ(r.code, 0) << r.out;
    }
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(Dir()); }
  // A fresh project of the given sessions (the first is the anchor).
  static std::string NewProject(const std::string& name, const std::string& sessions) {
    std::filesystem::remove(P(name));
    std::string list;
    for (char d : sessions) list += " building_" + std::string(1, d) + ".sweepscan";
    // Relative paths: the project file's folder is the base.
    const CommandRun r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI + " project new " + name + list);
    EXPECT_EQ(r.code, 0) << r.out;
    return P(name);
  }
};

// Writes a pairs file: the given world points in `source`'s and `target`'s
// session frames, the target's off by up to 8 mm as picks are.
void WritePairs(char source, char target, const std::vector<Eigen::Vector3d>& world, const std::string& name) {
  const double jitter[4][3] = {{0.005, -0.003, 0.002}, {-0.004, 0.006, -0.001}, {0.002, 0.008, 0.003},
                               {-0.006, -0.002, -0.004}};
  nlohmann::json pairs = nlohmann::json::array();
  for (size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector3d s = TrueStart(source).inverse() * world[i];
    const Eigen::Vector3d t = TrueStart(target).inverse() * world[i] + Eigen::Vector3d(jitter[i % 4]);
    pairs.push_back({{"source", {s.x(), s.y(), s.z()}}, {"target", {t.x(), t.y(), t.z()}}});
  }
  std::ofstream(P(name)) << nlohmann::json{{"pairs", pairs}}.dump(2);
}

bool ReadFile(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  text->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return static_cast<bool>(in) || in.eof();
}

double TranslationError(const Rigid3d& estimate, const Rigid3d& truth) {
  return (truth.inverse() * estimate).translation().norm();
}
double RotationErrorDeg(const Rigid3d& estimate, const Rigid3d& truth) {
  return Eigen::AngleAxisd((truth.inverse() * estimate).rotation()).angle() * 180.0 / M_PI;
}

TEST_F(ProjectCliTest, PlacesTheSecondRoomAgainstTruthAndExportsOneLas) {
  const std::string project = NewProject("floor.sweepscan-project", "ab");
  CommandRun r = Cli("project align " + project + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 2u);
  const ProjectSession& b = p.sessions[1];
  ASSERT_TRUE(b.project_from_session.has_value());
  EXPECT_EQ(b.registration.method, "planes+icp");
  EXPECT_EQ(b.registration.reference, "building_a");
  // The truth: a_from_b = world_from_a^-1 * world_from_b. Each cloud is
  // built from its own EKF poses, whose drift over a 2-minute drive (6 mm
  // and 0.06 deg at the end of building_a, `simulate`'s report) bounds what
  // any registration of the two clouds can reach.
  const Rigid3d truth = TrueStart('a').inverse() * TrueStart('b');
  const double dt = TranslationError(*b.project_from_session, truth);
  const double dr = RotationErrorDeg(*b.project_from_session, truth);
  RecordProperty("translation_error_mm", std::to_string(dt * 1000));
  RecordProperty("rotation_error_deg", std::to_string(dr));
  EXPECT_LT(dt, 0.02) << r.out;
  EXPECT_LT(dr, 0.2) << r.out;
  // The evidence is kept and says the same as the report.
  const nlohmann::json report = nlohmann::json::parse(r.out.substr(r.out.find("{\n")));
  ASSERT_EQ(report["placed"].size(), 1u);
  EXPECT_NEAR(report["placed"][0]["truth_error_m"].get<double>(), dt, 1e-6);
  EXPECT_GT(b.registration.overlap, 0.2);
  EXPECT_GT(b.registration.correspondences, 1000u);
  EXPECT_GT(b.registration.SigmaTranslation(), 0.0);
  EXPECT_LT(b.registration.rms_m, 0.01);

  // info shows it.
  r = Cli("project info " + project + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_TRUE(info["sessions"][1]["placed"].get<bool>());
  EXPECT_EQ(info["sessions"][1]["method"], "planes+icp");
  // The same 1-sigma as align reported (the worst direction's, both).
  EXPECT_NEAR(info["sessions"][1]["sigma_translation_m"].get<double>(),
              report["placed"][0]["sigma_translation_m"].get<double>(), 1e-12);
  EXPECT_NEAR(info["sessions"][1]["sigma_rotation_deg"].get<double>(),
              report["placed"][0]["sigma_rotation_deg"].get<double>(), 1e-9);

  // One LAS of both, read by loaders.gl and copc.js, is the PLY export of
  // the same project (same points, same order) to half a 0.1 mm step, and
  // every record says which session it is (Point Source ID 1, 2).
  r = Cli("project export " + project + " --out " + P("floor.las") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(Cli("project export " + project + " --out " + P("floor.ply")).code, 0);
  std::vector<CloudPoint> ply;
  ASSERT_TRUE(LoadCloud(P("floor.ply"), &ply).ok());
  const nlohmann::json exported = nlohmann::json::parse(r.out);
  const size_t n_a = exported["sessions"][0]["points"].get<size_t>();
  ASSERT_EQ(exported["points"].get<size_t>(), ply.size());
  EXPECT_EQ(n_a + exported["sessions"][1]["points"].get<size_t>(), ply.size());
  EXPECT_EQ(exported["non_finite_skipped"].get<uint64_t>(), 0u);
  r = RunCommand(std::string(SWEEPSCAN_NODE) + " " + SWEEPSCAN_SOURCE_DIR + "/tests/tools/read_las.mjs " +
                 P("floor.las") + " 20 4999");
  ASSERT_EQ(r.code, 0) << r.out << "\n(tests/tools/node_modules missing? run scripts/install-test-tools.sh)";
  const nlohmann::json las = nlohmann::json::parse(r.out);
  EXPECT_EQ(las["loaders_gl"]["count"].get<size_t>(), ply.size());
  EXPECT_EQ(las["copc"]["wkt"], std::string(kSweepscanProjectWkt) + '\0');
  EXPECT_EQ(las["copc"]["header"]["globalEncoding"], 0x11);  // GPS time from each session's start
  size_t checked_a = 0, checked_b = 0;
  for (const nlohmann::json& pt : las["points"]) {
    const size_t i = pt["index"].get<size_t>();
    const CloudPoint& q = ply[i];
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(pt["position"][k].get<double>(), (&q.x)[k], 0.00005 + 1e-6) << i;
    }
    EXPECT_EQ(pt["copc"]["PointSourceId"].get<int>(), i < n_a ? 1 : 2) << i;
    (i < n_a ? checked_a : checked_b) += 1;
  }
  EXPECT_GT(checked_a, 50u);
  EXPECT_GT(checked_b, 50u);

  // The floor plan of the project: room B is seen by both sessions, so its
  // inner width (5.5 m) and depth (5.9 m) measure the registration too;
  // the corridor is 2.0 m wide; the doors are 0.9 m.
  r = Cli("project export " + project + " --out " + P("unused.txt"));
  EXPECT_EQ(r.code, 2) << r.out;  // an unknown suffix is refused, nothing written
  // A suffix in capitals is the same format, as for a session's export
  // (it was refused with exit 2).
  ASSERT_EQ(Cli("project export " + project + " --out " + P("FLOOR.LAS")).code, 0);
  EXPECT_EQ(RunCommand("cmp " + P("floor.las") + " " + P("FLOOR.LAS")).code, 0);
  r = Cli("plan " + project + " --json --svg " + P("floor.svg") + " --dxf " + P("floor.dxf"));
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json plan = nlohmann::json::parse(r.out);
  const auto has = [&](const char* list, const char* key, double value, double tolerance) {
    for (const nlohmann::json& e : plan[list]) {
      if (std::abs(e[key].get<double>() - value) <= tolerance) return true;
    }
    return false;
  };
  EXPECT_TRUE(has("dimensions", "distance_m", 5.5, 0.01)) << plan["dimensions"].dump();
  EXPECT_TRUE(has("dimensions", "distance_m", 5.9, 0.01)) << plan["dimensions"].dump();
  EXPECT_TRUE(has("dimensions", "distance_m", 2.0, 0.01)) << plan["dimensions"].dump();
  EXPECT_TRUE(has("openings", "width_m", 0.9, 0.03)) << plan["openings"].dump();
  EXPECT_TRUE(has("walls", "thickness_m", 0.1, 0.01)) << plan["walls"].dump();
  // Room B's outline: 5.5 x 5.9 m, its area within 5 mm along its 22.8 m
  // perimeter, four corners.
  EXPECT_TRUE(has("rooms", "area_m2", 5.5 * 5.9, 0.005 * 22.8)) << plan["rooms"].dump();
  for (const nlohmann::json& room : plan["rooms"]) {
    if (std::abs(room["area_m2"].get<double>() - 5.5 * 5.9) < 0.2) {
      EXPECT_EQ(room["outline"].size(), 4u);
    }
    // Each room's name and area (about 0.66 x 0.4 m at the default text
    // height) clear of every dimension's line and value: the corridor's
    // label sat on its 16 m dimension, which runs down its middle.
    const Eigen::Vector2d label(room["label"][0].get<double>(), room["label"][1].get<double>());
    for (const nlohmann::json& dim : plan["dimensions"]) {
      const Eigen::Vector2d a(dim["a"][0].get<double>(), dim["a"][1].get<double>()),
          b(dim["b"][0].get<double>(), dim["b"][1].get<double>());
      double nearest = 1e9;
      for (int k = 0; k <= 2000; ++k) {
        const Eigen::Vector2d off =
            (a + (b - a) * (k / 2000.0) - label).cwiseAbs() - Eigen::Vector2d(0.33, 0.2);
        nearest = std::min(nearest, off.cwiseMax(0.0).norm());
      }
      EXPECT_GT(nearest, 0.18) << room["name"] << " at " << label.transpose() << ", dimension "
                               << dim.dump();
    }
  }
  EXPECT_GT(std::filesystem::file_size(P("floor.svg")), 1000u);
  EXPECT_GT(std::filesystem::file_size(P("floor.dxf")), 1000u);
}

// Placing b starts another pass for the sessions still unplaced, which
// tried c against a and b again with the same clouds: each registration
// (minutes on a real building) runs once, and its reason is still given.
TEST_F(ProjectCliTest, ARegistrationThatFailedIsNotRunAgain) {
  const std::string project = NewProject("three.sweepscan-project", "abc");
  const CommandRun r = Cli("project align " + project);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("placed 'building_b' against 'building_a'"), std::string::npos) << r.out;
  const auto count = [&](const std::string& what) {
    size_t n = 0;
    for (size_t at = r.out.find(what); at != std::string::npos; at = r.out.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("aligning 'building_c' to 'building_a'"), 1u) << r.out;
  EXPECT_EQ(count("aligning 'building_c' to 'building_b'"), 1u) << r.out;
  EXPECT_NE(r.out.find("could not place:\n'building_c':\n  against 'building_a': "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("\n  against 'building_b': "), std::string::npos) << r.out;
}

TEST_F(ProjectCliTest, ACorridorIsRefusedByThePlanesAndPlacedFromPairsAcrossIt) {
  const std::string project = NewProject("corridor.sweepscan-project", "ac");
  CommandRun r = Cli("project align " + project);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("could not place:\n'building_c':"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("free"), std::string::npos) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_FALSE(p.sessions[1].project_from_session.has_value());  // nothing written for it
  r = Cli("project align " + project + " --hold-free");  // no pairs: no position along it to hold
  EXPECT_EQ(r.code, 1) << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_FALSE(p.sessions[1].project_from_session.has_value());

  // Pairs picked across it (door jambs, a point on the far wall) give the
  // position along it. ICP then refines it with the pairs kept as a prior:
  // along the corridor only the door jambs (0.1 m faces) constrain it, too
  // weakly to outweigh the picks (without the prior, ICP from the exact
  // pose drifted 34 mm along it). A corridor without jambs is refused by
  // ICP too, or held with --hold-free: core/registration's
  // CorridorRegistration test.
  const Rigid3d truth = TrueStart('a').inverse() * TrueStart('c');
  WritePairs('c', 'a', {{2.0, 2.0, 1.0}, {2.9, 2.0, 1.2}, {7.0, 2.0, 1.0}, {5.0, 0.0, 1.8}}, "corridor-pairs.json");
  r = Cli("project align " + project + " --session building_c --to building_a --pairs " + P("corridor-pairs.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  const ProjectSession& c = p.sessions[1];
  ASSERT_TRUE(c.project_from_session.has_value());
  EXPECT_EQ(c.registration.method, "pairs+icp");
  const Eigen::Vector3d error = c.project_from_session->translation() - truth.translation();
  // Across the corridor (a's x, the world's y) and in height the walls fix
  // it; along it the picks (each off by up to 8 mm) do.
  EXPECT_LT(std::abs(error.x()), 0.01) << error.transpose();
  EXPECT_LT(std::abs(error.z()), 0.01) << error.transpose();
  EXPECT_LT(std::abs(error.y()), 0.01) << error.transpose();
  EXPECT_LT(RotationErrorDeg(*c.project_from_session, truth), 0.3);
}

TEST_F(ProjectCliTest, PickedPairsPlaceASessionAndIcpRefinesIt) {
  const std::string project = NewProject("pairs.sweepscan-project", "ab");
  // Four corners of room B where the operator would click them.
  WritePairs('b', 'a', {{5.1, 2.1, 1.0}, {10.6, 2.1, 1.0}, {10.6, 8.0, 1.0}, {5.1, 8.0, 1.5}}, "pairs.json");
  const Rigid3d truth = TrueStart('a').inverse() * TrueStart('b');

  CommandRun r = Cli("project align " + project + " --session building_b --to building_a --pairs " +
                     P("pairs.json") + " --no-icp");
  ASSERT_EQ(r.code, 0) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_EQ(p.sessions[1].registration.method, "pairs");
  ASSERT_EQ(p.sessions[1].registration.pairs.size(), 4u);
  EXPECT_LT(TranslationError(*p.sessions[1].project_from_session, truth), 0.03);
  EXPECT_LT(RotationErrorDeg(*p.sessions[1].project_from_session, truth), 0.5);

  r = Cli("project align " + project + " --session building_b --to building_a --pairs " + P("pairs.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_EQ(p.sessions[1].registration.method, "pairs+icp");
  EXPECT_LT(TranslationError(*p.sessions[1].project_from_session, truth), 0.02);
  EXPECT_LT(RotationErrorDeg(*p.sessions[1].project_from_session, truth), 0.2);
}

// Placing a session again: a refused attempt keeps the placement it had;
// a new one moves the sessions placed against it along, since they were
// measured relative to it. A session others are placed against is not
// removed, and info gives a yaw below zero as such.
TEST_F(ProjectCliTest, PlacingASessionAgainKeepsOrMovesWhatDependsOnIt) {
  const std::string project = NewProject("again.sweepscan-project", "abc");
  WritePairs('b', 'a', {{5.1, 2.1, 1.0}, {10.6, 2.1, 1.0}, {10.6, 8.0, 1.0}, {5.1, 8.0, 1.5}},
             "again-ba.json");
  WritePairs('c', 'b', {{2.0, 2.0, 1.0}, {2.9, 2.0, 1.2}, {7.0, 2.0, 1.0}, {5.0, 0.0, 1.8}},
             "again-cb.json");
  WritePairs('b', 'a', {{5.0, 2.0, 1.0}, {6.0, 3.0, 1.0}, {7.0, 4.0, 1.0}}, "again-collinear.json");
  CommandRun r =
      Cli("project align " + project + " --session building_b --to building_a --no-icp --pairs " +
          P("again-ba.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("project align " + project + " --session building_c --to building_b --no-icp --pairs " +
          P("again-cb.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  Project before;
  ASSERT_TRUE(LoadProject(project, &before).ok());
  const Rigid3d b0 = *before.sessions[1].project_from_session;
  const Rigid3d c0 = *before.sessions[2].project_from_session;
  ASSERT_EQ(before.sessions[2].registration.reference, "building_b");

  // b cannot be placed against c, which rests on b: c would move with b,
  // by an amount nothing measured, and the two would refer to each other.
  r = Cli("project align " + project + " --session building_b --to building_c --no-icp --pairs " +
          P("again-cb.json"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'building_c' is placed against 'building_b'"), std::string::npos) << r.out;
  {
    Project same;
    ASSERT_TRUE(LoadProject(project, &same).ok());
    EXPECT_EQ(ProjectToJson(same), ProjectToJson(before));
  }

  // Collinear picks are refused: b keeps its pose and evidence.
  r = Cli("project align " + project + " --session building_b --to building_a --no-icp --pairs " +
          P("again-collinear.json"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("'building_b' keeps its placement"), std::string::npos) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_TRUE(p.sessions[1].project_from_session.has_value());
  EXPECT_TRUE(p.sessions[1].project_from_session->translation().isApprox(b0.translation(), 1e-12));
  EXPECT_EQ(p.sessions[1].registration.method, "pairs");
  EXPECT_EQ(p.sessions[1].registration.pairs.size(), 4u);

  // ICP moves b by a few mm; c moves with it, its pose relative to b unchanged.
  r = Cli("project align " + project + " --session building_b --to building_a --pairs " +
          P("again-ba.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("moved 'building_c' with 'building_b'"), std::string::npos) << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  const Rigid3d b1 = *p.sessions[1].project_from_session;
  const Rigid3d c1 = *p.sessions[2].project_from_session;
  EXPECT_GT(TranslationError(b1, b0), 1e-4) << "ICP left b where the picks put it";
  EXPECT_LT(TranslationError(b1.inverse() * c1, b0.inverse() * c0), 1e-9);
  EXPECT_LT(RotationErrorDeg(b1.inverse() * c1, b0.inverse() * c0), 1e-7);

  r = Cli("project remove " + project + " building_b");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'building_c' placed against 'building_b'"), std::string::npos) << r.out;

  p.sessions[1].project_from_session =
      Rigid3d::FromPose(1.0, 2.0, 0.0, 0.0, 0.0, -30.0 * M_PI / 180.0);
  ASSERT_TRUE(SaveProject(project, p).ok());
  r = Cli("project info " + project + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["sessions"][1]["yaw_deg"].get<double>(), -30.0, 1e-9);
}

// One unreadable session costs only its own placement: the others are
// placed and saved (each may take minutes), and the report says which
// failed and why.
TEST_F(ProjectCliTest, AnUnreadableSessionCostsOnlyItsOwnPlacement) {
  const std::string project = NewProject("unreadable.sweepscan-project", "ab");
  // A session folder (it has a meta.json) whose recording is gone.
  std::filesystem::create_directories(P("empty.sweepscan"));
  std::filesystem::copy_file(P("building_a.sweepscan/meta.json"), P("empty.sweepscan/meta.json"),
                             std::filesystem::copy_options::overwrite_existing);
  ASSERT_EQ(RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI +
                       " project add unreadable.sweepscan-project empty.sweepscan")
                .code,
            0);
  const CommandRun r = Cli("project align " + project + " --json");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("placed 'building_b' against 'building_a'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'empty':\n  its cloud cannot be built: "), std::string::npos) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 3u);
  EXPECT_TRUE(p.sessions[1].project_from_session.has_value()) << "b's placement was not saved";
  EXPECT_FALSE(p.sessions[2].project_from_session.has_value());
}

// The room recorded again into the same folder (another recording, its
// meta.json's created_utc another time): the placement was measured on the
// first, so its cloud is refused where it is built, with both times and
// what to do; removed and added again, it is aligned as the new one.
TEST_F(ProjectCliTest, ARoomRecordedAgainUnderItsNameIsNotDrawnInTheOldPlace) {
  const std::string project = NewProject("again.sweepscan-project", "ab");
  ASSERT_EQ(Cli("project align " + project).code, 0);
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  nlohmann::json meta;
  std::string text;
  ASSERT_TRUE(ReadFile(P("building_b.sweepscan/meta.json"), &text));
  meta = nlohmann::json::parse(text);
  EXPECT_EQ(p.sessions[1].recorded_utc, meta["created_utc"].get<std::string>());
  EXPECT_FALSE(p.sessions[1].recorded_utc.empty());
  // Recorded again: a new created_utc (the frames do not matter here).
  meta["created_utc"] = "2030-01-02T03:04:05Z";
  std::ofstream(P("building_b.sweepscan/meta.json")) << meta.dump(2);
  CommandRun r = Cli("project export " + project + " --out " + P("again.las"));
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("building_b.sweepscan now holds another recording (begun "
                       "2030-01-02T03:04:05Z) than the one added to the project (begun " +
                       p.sessions[1].recorded_utc + ")"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("remove the session from the project and add it again"), std::string::npos)
      << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("again.las")));
  // Removed and added again: the new recording, aligned afresh.
  ASSERT_EQ(Cli("project remove " + project + " building_b").code, 0);
  r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI +
                 " project add again.sweepscan-project building_b.sweepscan");
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_EQ(p.sessions[1].recorded_utc, "2030-01-02T03:04:05Z");
  r = Cli("project align " + project);
  ASSERT_EQ(r.code, 0) << r.out;
  r = Cli("project export " + project + " --out " + P("again.las"));
  EXPECT_EQ(r.code, 0) << r.out;
}

TEST_F(ProjectCliTest, BadInputIsRefusedWithWhereAndWhy) {
  const std::string project = NewProject("bad.sweepscan-project", "a");
  // Exists already.
  CommandRun r = Cli("project new " + project);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("exists already"), std::string::npos) << r.out;
  // Not a session folder.
  r = Cli("project add " + project + " " + P("nowhere.sweepscan"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("not a session folder"), std::string::npos) << r.out;
  // The same folder again, however written: refused, named.
  for (const std::string& same :
       {std::string("building_a.sweepscan/"), P("building_a.sweepscan")}) {
    r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI + " project add bad.sweepscan-project " +
                   same);
    EXPECT_EQ(r.code, 2) << same;
    EXPECT_NE(r.out.find("already in the project as 'building_a'"), std::string::npos) << r.out;
  }
  // Pairs without the two sessions they belong to.
  r = Cli("project align " + project + " --pairs " + P("pairs.json"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--pairs needs --session ID and --to ID"), std::string::npos) << r.out;
  // Nothing placed but the anchor: exporting another session is refused.
  ASSERT_EQ(RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI + " project add bad.sweepscan-project building_b.sweepscan").code, 0);
  r = Cli("project export " + project + " --out " + P("x.las") + " --sessions building_b");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("'building_b' is not placed yet"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("x.las")));
  // An output that cannot be written is said before any cloud is built (a
  // building's take minutes): here before the session's folder, moved
  // away, is even looked for.
  std::filesystem::rename(P("building_a.sweepscan"), P("moved.sweepscan"));
  r = Cli("project export " + project + " --out " + P("missing/x.las") + " --sessions building_a");
  std::filesystem::rename(P("moved.sweepscan"), P("building_a.sweepscan"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot create x.las.tmp-"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("building_a.sweepscan"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("missing")));
  // A damaged project file: the place and the reason, and nothing else happens.
  std::ofstream(P("broken.sweepscan-project")) << "{\"format\": \"sweepscan-project\", \"version\": 1, \"sessions\": [{\"id\": \"x\"}]}";
  r = Cli("project align " + P("broken.sweepscan-project"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("broken.sweepscan-project: sessions[0].path"), std::string::npos) << r.out;
  r = Cli("project frobnicate " + project);
  EXPECT_EQ(r.code, 2);
  // A reference loop (which an older align could save) opens, repaired and said.
  Project loop;
  ASSERT_TRUE(LoadProject(project, &loop).ok());
  loop.sessions[0].registration.method = "manual";  // a the anchor no more: b placed against a,
  loop.sessions[1].project_from_session = Rigid3d::Identity();  // a against b
  loop.sessions[1].registration.method = "manual";
  loop.sessions[1].registration.reference = "building_a";
  loop.sessions[0].registration.reference = "building_b";
  ASSERT_TRUE(SaveProject(P("loop.sweepscan-project"), loop).ok());
  r = Cli("project info " + P("loop.sweepscan-project"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("warning: " + P("loop.sweepscan-project") + ": the references form a loop"),
            std::string::npos)
      << r.out;
}

// What a script may get wrong is refused, not half-done: a second word
// after PROJECT (`project align P building_b` aligned every session), an
// empty --sessions (it meant all), a folder that cannot be looked at
// (it threw "unexpected failure"). A session typed with its absolute path
// is kept relative to the project's folder, as the app keeps it, so that
// the project moves with its sessions.
TEST_F(ProjectCliTest, ScriptMistakesAreRefusedAndPathsAreKeptRelative) {
  const std::string project = NewProject("script.sweepscan-project", "a");
  CommandRun r = Cli("project add " + project + " " + P("building_b.sweepscan"));
  ASSERT_EQ(r.code, 0) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 2u);
  EXPECT_EQ(p.sessions[1].path, "building_b.sweepscan");
  EXPECT_EQ(ResolveSessionPath(project, p.sessions[1]),
            std::filesystem::path(P("building_b.sweepscan")).lexically_normal().string());
  // Outside the project's folder: relative still, through "..".
  const std::string sub = P("sub");
  std::filesystem::create_directories(sub);
  r = Cli("project new " + sub + "/up.sweepscan-project " + P("building_c.sweepscan"));
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(LoadProject(sub + "/up.sweepscan-project", &p).ok());
  EXPECT_EQ(p.sessions[0].path, "../building_c.sweepscan");

  for (const std::string& extra : {"align " + project + " building_b",
                                   "export " + project + " building_b --out " + P("s.las"),
                                   "info " + project + " building_b"}) {
    r = Cli("project " + extra);
    EXPECT_EQ(r.code, 2) << extra;
    EXPECT_NE(r.out.find("unexpected argument 'building_b': project "), std::string::npos)
        << extra << ": " << r.out;
  }
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_FALSE(p.sessions[1].project_from_session.has_value());  // nothing was aligned
  r = Cli("project export " + project + " --out " + P("s.las") + " --sessions ''");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--sessions: no session ID given"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("s.las")));
  // A name longer than a folder's can be (ENAMETOOLONG, not "no such file").
  const std::string too_long = P(std::string(300, 'x') + ".sweepscan");
  r = Cli("project add " + project + " " + too_long);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("cannot be looked at: File name too long"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("unexpected"), std::string::npos) << r.out;
  r = Cli("project new " + too_long + "/p.sweepscan-project");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot be looked at: File name too long"), std::string::npos) << r.out;
  // A name typed in Latin-1 ("Büro"): JSON holds UTF-8 only.
  r = Cli("project new " + P("latin1.sweepscan-project") + " --name \"$(printf 'B\\374ro')\"");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--name: not UTF-8 text"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("latin1.sweepscan-project")));
  // Saving one never throws either (the app's names are UTF-8 already).
  Project latin1;
  latin1.name = "B\xfcro";
  const Status saved = SaveProject(P("latin1.sweepscan-project"), latin1);
  EXPECT_FALSE(saved.ok());
  EXPECT_NE(saved.message().find("name is not UTF-8"), std::string::npos) << saved.message();
}

// Runs `project align ARGS` in the background and, once it has read the
// project (it says so as it builds the first cloud, seconds before it
// saves), `meanwhile`; returns align's output and exit code.
CommandRun AlignWhile(const std::string& align_args, const std::string& meanwhile) {
  const std::string log = P("align-while.log");
  std::filesystem::remove(log);
  const CommandRun r = RunCommand(
      "cd " + Dir() + " && (" + SWEEPSCAN_CLI + " project align " + align_args + " > " + log +
      " 2>&1; echo \"rc=$?\" >> " + log + ") & until grep -q 'building the cloud' " + log +
      " 2>/dev/null; do sleep 0.02; done; cd " + Dir() + " && " + meanwhile + "; wait");
  EXPECT_EQ(r.code, 0) << r.out;
  std::ifstream in(log);
  std::string out((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t rc = out.rfind("rc=");
  EXPECT_NE(rc, std::string::npos) << out;
  return {rc == std::string::npos ? -1 : std::stoi(out.substr(rc + 3)), out};
}

// Align runs for minutes on a building; what another program saves to the
// project meanwhile is kept, and a placement whose session changed there
// is refused by name, not written over it.
TEST_F(ProjectCliTest, AlignKeepsWhatAnotherProgramSavedMeanwhile) {
  const std::string project = NewProject("meanwhile.sweepscan-project", "ab");
  CommandRun r = AlignWhile(
      "meanwhile.sweepscan-project",
      std::string(SWEEPSCAN_CLI) + " project add meanwhile.sweepscan-project building_c.sweepscan");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("was changed by another program while aligning: its changes are kept"),
            std::string::npos)
      << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 3u);
  EXPECT_EQ(p.sessions[2].id, "building_c");                    // the other program's
  ASSERT_TRUE(p.sessions[1].project_from_session.has_value());  // this run's
  EXPECT_EQ(p.sessions[1].registration.pose_source, "ekf");
  const Rigid3d truth = TrueStart('a').inverse() * TrueStart('b');
  EXPECT_LT(TranslationError(*p.sessions[1].project_from_session, truth), 0.02);

  // The session this run placed was taken out meanwhile: refused, named,
  // and the other program's edit stays.
  NewProject("meanwhile.sweepscan-project", "ab");
  r = AlignWhile(
      "meanwhile.sweepscan-project",
      std::string(SWEEPSCAN_CLI) + " project remove meanwhile.sweepscan-project building_b");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("'building_b':\n  placed against 'building_a', not saved: 'building_b' was "
                       "removed from the project meanwhile"),
            std::string::npos)
      << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 1u);

  // Its calibration changed meanwhile: its cloud is not the one registered.
  NewProject("meanwhile.sweepscan-project", "ab");
  std::ofstream(P("cal.json")) << R"({"format": "sweepscan-calibration", "version": 1,
      "mounting_error_rad": {"alpha": 0.01, "beta": 0.0, "gamma": 0.0}})";
  r = AlignWhile("meanwhile.sweepscan-project --json",
                 "rm meanwhile.sweepscan-project && " + std::string(SWEEPSCAN_CLI) +
                     " project new meanwhile.sweepscan-project building_a.sweepscan && " +
                     SWEEPSCAN_CLI +
                     " project add meanwhile.sweepscan-project building_b.sweepscan " +
                     "--calibration cal.json");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("'building_b' was changed meanwhile: its calibration changed"),
            std::string::npos)
      << r.out;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  ASSERT_EQ(p.sessions.size(), 2u);
  EXPECT_FALSE(p.sessions[1].project_from_session.has_value());
  EXPECT_TRUE(p.sessions[1].calibration.has_value());
}

// A folder the project cannot be saved in fails before any cloud is built,
// not after the minutes of aligning.
TEST_F(ProjectCliTest, AlignSaysAProjectItCannotSaveBeforeAligning) {
  NewProject("readonly.sweepscan-project", "ab");
  std::filesystem::create_directories(P("ro"));
  Project p;
  ASSERT_TRUE(LoadProject(P("readonly.sweepscan-project"), &p).ok());
  for (ProjectSession& s : p.sessions) s.path = "../" + s.path;
  ASSERT_TRUE(SaveProject(P("ro/readonly.sweepscan-project"), p).ok());
  std::filesystem::permissions(
      P("ro"), std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec |
                   std::filesystem::perms::others_read | std::filesystem::perms::others_exec);
  // root writes anywhere: run it as nobody.
  const std::string as =
      ::geteuid() == 0 ? "setpriv --reuid=65534 --regid=65534 --clear-groups " : "";
  const CommandRun r =
      RunCommand(as + SWEEPSCAN_CLI + " project align " + P("ro/readonly.sweepscan-project"));
  std::filesystem::permissions(P("ro"), std::filesystem::perms::owner_all);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot create readonly.sweepscan-project.tmp-"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("building the cloud"), std::string::npos) << r.out;
}

// Odometry clouds are warped by wheel slip: align refuses them rather than
// place a bent room on a look-alike one; drawing with them says the
// placements were measured with the EKF's.
TEST_F(ProjectCliTest, OdometryIsNotAlignedAndDrawingWithItWarns) {
  const std::string project = NewProject("odometry.sweepscan-project", "ab");
  CommandRun r = Cli("project align " + project + " --pose-source odometry");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("aligned with the EKF poses only"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("building the cloud"), std::string::npos) << r.out;
  r = Cli("project --help");
  EXPECT_EQ(r.out.find("ekf|odometry"), std::string::npos) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  p.sessions[1].project_from_session = TrueStart('a').inverse() * TrueStart('b');
  p.sessions[1].registration.method = "planes+icp";
  p.sessions[1].registration.reference = "building_a";
  ASSERT_TRUE(SaveProject(project, p).ok());
  r = Cli("plan " + project + " --pose-source odometry");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("warning: 'building_b' was placed with its ekf cloud and is drawn with its "
                       "odometry cloud"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("'building_a' was placed"), std::string::npos) << r.out;  // the anchor
  r = Cli("plan " + project);
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  // Picks given as none are refused, not replaced by the planes.
  std::ofstream(P("no-pairs.json")) << R"({"pairs": []})";
  r = Cli("project align " + project + " --session building_b --to building_a --pairs " +
          P("no-pairs.json"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no-pairs.json: pairs: 0 pair(s) given, at least 3 needed"),
            std::string::npos)
      << r.out;
  // A pose typed in was not measured: no rms, overlap or sigma of zero.
  p.sessions[1].registration = RegistrationEvidence();
  p.sessions[1].registration.method = "manual";
  ASSERT_TRUE(SaveProject(project, p).ok());
  r = Cli("project info " + project);
  EXPECT_NE(r.out.find("manual: not measured"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("rms 0.0 mm"), std::string::npos) << r.out;
  // Nothing placed to draw: said for the plan.
  for (ProjectSession& s : p.sessions) s.visible = false;
  ASSERT_TRUE(SaveProject(project, p).ok());
  r = Cli("plan " + project);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no placed session to draw"), std::string::npos) << r.out;
}

// The anchor removed while the others are unplaced: the first left is the
// anchor, and aligning the removed session again places it against it.
TEST_F(ProjectCliTest, RemovingTheAnchorMakesTheNextSessionTheAnchor) {
  const std::string project = NewProject("anchor.sweepscan-project", "ab");
  CommandRun r = Cli("project remove " + project + " building_a");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'building_b' is the anchor now"), std::string::npos) << r.out;
  r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI +
                 " project add anchor.sweepscan-project building_a.sweepscan");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("added 'building_a', not placed yet"), std::string::npos) << r.out;
  r = Cli("project align " + project);
  ASSERT_EQ(r.code, 0) << r.out;
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_EQ(p.Anchor(), 0);
  const Rigid3d truth = TrueStart('b').inverse() * TrueStart('a');
  EXPECT_LT(TranslationError(*p.sessions[1].project_from_session, truth), 0.02);
  EXPECT_LT(RotationErrorDeg(*p.sessions[1].project_from_session, truth), 0.3);
  // A file an older sweepscan left without an anchor opens with its first
  // session as the anchor, said.
  p.sessions.erase(p.sessions.begin() + 1);
  p.sessions[0].project_from_session.reset();
  p.sessions[0].registration = RegistrationEvidence();
  ASSERT_TRUE(SaveProject(project, p).ok());
  r = Cli("project info " + project);
  EXPECT_NE(r.out.find("no session is the anchor: 'building_b', the first, now is"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("anchor"), std::string::npos) << r.out;
}

// `project anchor`: the building re-expressed in another session's frame.
// Placed by the truth (what align finds, exactly), b against a by pairs and
// c against b, then anchored on c: every pose is the truth seen from c's
// start, the chain c -> b -> a is turned round with its pairs, and the
// exported cloud is the same points moved by the one change of frame.
TEST_F(ProjectCliTest, AnchorMakesAPlacedSessionTheFrameAndKeepsTheBuilding) {
  const std::string project = NewProject("anchored.sweepscan-project", "abc");
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  const auto place = [&](char id, char reference, const std::string& method) {
    ProjectSession& s = p.sessions[id - 'a'];
    s.project_from_session = TrueStart('a').inverse() * TrueStart(id);
    s.registration.method = method;
    s.registration.reference = std::string("building_") + reference;
    for (int i = 0; i < 6; ++i) s.registration.covariance[i * 7] = i < 3 ? 1e-8 : 1e-6;
    const Rigid3d reference_from_session = TrueStart(reference).inverse() * TrueStart(id);
    for (const Eigen::Vector3d& source :
         {Eigen::Vector3d(1, 0, 0.5), Eigen::Vector3d(0, 2, 1), Eigen::Vector3d(-1, 1, 2)}) {
      s.registration.pairs.push_back({source, reference_from_session * source});
    }
  };
  place('b', 'a', "pairs");
  place('c', 'b', "pairs+icp");
  ASSERT_TRUE(SaveProject(project, p).ok());
  CommandRun r = Cli("project export " + project + " --out " + P("anchored_before.ply"));
  ASSERT_EQ(r.code, 0) << r.out;

  r = Cli("project anchor " + project + " building_c --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'building_c' is the anchor now: the project's frame is its start pose; 2 "
                       "placement(s) re-expressed in it"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("turned round: 'building_b' is placed against 'building_c'"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("turned round: 'building_a' is placed against 'building_b'"),
            std::string::npos)
      << r.out;
  const nlohmann::json said = nlohmann::json::parse(r.out.substr(r.out.find("{\n")));
  EXPECT_EQ(said["anchor"], "building_c");
  EXPECT_EQ(said["old_anchor"], "building_a");
  EXPECT_TRUE(said["changed"].get<bool>());
  EXPECT_EQ(said["reversed"], nlohmann::json({"building_b", "building_a"}));

  Project q;
  ASSERT_TRUE(LoadProject(project, &q).ok());
  ASSERT_EQ(q.Anchor(), 2);
  for (char id : {'a', 'b', 'c'}) {
    const ProjectSession& s = q.sessions[id - 'a'];
    ASSERT_TRUE(s.project_from_session.has_value()) << id;
    const Rigid3d truth = TrueStart('c').inverse() * TrueStart(id);
    EXPECT_LT(TranslationError(*s.project_from_session, truth), 1e-9) << id;
    EXPECT_LT(RotationErrorDeg(*s.project_from_session, truth), 1e-7) << id;
  }
  EXPECT_EQ(q.sessions[1].registration.reference, "building_c");
  EXPECT_EQ(q.sessions[1].registration.method, "pairs+icp");
  EXPECT_EQ(q.sessions[0].registration.reference, "building_b");
  EXPECT_EQ(q.sessions[0].registration.method, "pairs");
  for (const ProjectSession& s : q.sessions) {
    if (s.registration.reference.empty()) continue;
    const Rigid3d reference_from_session =
        q.sessions[q.Find(s.registration.reference)].project_from_session->inverse() *
        *s.project_from_session;
    for (const PickedPair& pair : s.registration.pairs) {
      EXPECT_LT((reference_from_session * pair.source - pair.target).norm(), 1e-9) << s.id;
    }
  }
  r = Cli("project export " + project + " --out " + P("anchored_after.ply"));
  ASSERT_EQ(r.code, 0) << r.out;
  std::vector<CloudPoint> before, after;
  ASSERT_TRUE(LoadCloud(P("anchored_before.ply"), &before).ok());
  ASSERT_TRUE(LoadCloud(P("anchored_after.ply"), &after).ok());
  ASSERT_EQ(before.size(), after.size());
  ASSERT_GT(before.size(), 1000u);
  const Rigid3d c_from_a = TrueStart('c').inverse() * TrueStart('a');
  double worst = 0.0;
  for (size_t i = 0; i < before.size(); ++i) {
    const Eigen::Vector3d was(before[i].x, before[i].y, before[i].z);
    const Eigen::Vector3d now(after[i].x, after[i].y, after[i].z);
    worst = std::max(worst, (c_from_a * was - now).norm());
  }
  EXPECT_LT(worst, 1e-4);  // float positions within a few tens of metres
  r = Cli("project info " + project);
  EXPECT_NE(r.out.find("; anchor"), std::string::npos) << r.out;

  // The anchor already: said, and the file is not written again.
  std::string bytes, again;
  ASSERT_TRUE(ReadFile(project, &bytes));
  r = Cli("project anchor " + project + " building_c");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'building_c' is the anchor already; nothing changed"), std::string::npos)
      << r.out;
  ASSERT_TRUE(ReadFile(project, &again));
  EXPECT_EQ(again, bytes);
  // Unknown, and the usage.
  r = Cli("project anchor " + project + " nothing");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no session 'nothing' in the project"), std::string::npos) << r.out;
  EXPECT_EQ(Cli("project anchor " + project).code, 2);
  EXPECT_EQ(Cli("project anchor " + project + " building_c --out x.las").code, 2);

  // An unplaced session while others are placed: refused, the file as it was.
  q.sessions[0].project_from_session.reset();
  q.sessions[0].registration = RegistrationEvidence();
  ASSERT_TRUE(SaveProject(project, q).ok());
  ASSERT_TRUE(ReadFile(project, &bytes));
  r = Cli("project anchor " + project + " building_a");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'building_a' is not placed: align it first"), std::string::npos) << r.out;
  ASSERT_TRUE(ReadFile(project, &again));
  EXPECT_EQ(again, bytes);
  // Nothing placed but the anchor: the old anchor is unplaced, said.
  const std::string fresh = NewProject("anchored_fresh.sweepscan-project", "ab");
  r = Cli("project anchor " + fresh + " building_b");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'building_a', the old anchor, is not placed now"), std::string::npos)
      << r.out;
  ASSERT_TRUE(LoadProject(fresh, &q).ok());
  EXPECT_EQ(q.Anchor(), 1);
  EXPECT_FALSE(q.sessions[0].project_from_session.has_value());
}

// A folder without meta.json is no session, as in the app.
TEST_F(ProjectCliTest, AFolderWithoutMetaJsonIsNotASession) {
  std::filesystem::create_directories(P("nometa.sweepscan"));
  std::filesystem::remove(P("nometa.sweepscan-project"));
  CommandRun r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI +
                            " project new nometa.sweepscan-project building_a.sweepscan "
                            "nometa.sweepscan");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("nometa.sweepscan: not a session folder (no meta.json)"), std::string::npos)
      << r.out;
  EXPECT_FALSE(std::filesystem::exists(P("nometa.sweepscan-project")));
  const std::string project = NewProject("nometa.sweepscan-project", "a");
  for (const std::string& folder : {std::string("."), std::string("nometa.sweepscan")}) {
    r = RunCommand("cd " + Dir() + " && " + SWEEPSCAN_CLI +
                   " project add nometa.sweepscan-project " + folder);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(folder + ": not a session folder (no meta.json)"), std::string::npos)
        << r.out;
  }
  Project p;
  ASSERT_TRUE(LoadProject(project, &p).ok());
  EXPECT_EQ(p.sessions.size(), 1u);
}

}  // namespace
}  // namespace sweepscan
