// The project file: a round trip keeps every field; strict loading refuses
// what a hand edit can get wrong, naming the place; ids and the anchor.
#include "core/project/project.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

namespace sweepscan {
namespace {

Project TwoSessions() {
  Project p;
  p.name = "office floor";
  p.description = "3rd floor, east wing";
  EXPECT_TRUE(p.AddSession("scans/room_a.sweepscan", nullptr).ok());
  ProjectSession* b = nullptr;
  EXPECT_TRUE(p.AddSession("scans/room_b.sweepscan/", &b).ok());
  b->calibration = MountingError{0.01, -0.02, 0.003};
  b->project_from_session =
      Rigid3d::FromPose(5.0, -1.0, 0.002, 0.001, -0.002, 1.2);
  b->registration.method = "planes+icp";
  b->registration.reference = "room_a";
  b->registration.rms_m = 0.0041;
  b->registration.overlap = 0.37;
  b->registration.correspondences = 123456;
  b->registration.iterations = 12;
  for (int i = 0; i < 6; ++i) b->registration.covariance[i * 7] = (i < 3 ? 1e-8 : 4e-6) * (i + 1);
  b->registration.pairs = {{{1, 2, 3}, {4, 5, 6}}, {{0.5, 0.25, 1}, {2, 2, 2}}};
  b->registration.time_utc = "2026-11-26T07:00:00Z";
  b->visible = false;
  return p;
}

// TwoSessions and room_c, placed against room_b.
Project ThreeSessions() {
  Project p = TwoSessions();
  ProjectSession* c = nullptr;
  EXPECT_TRUE(p.AddSession("scans/room_c.sweepscan", &c).ok());
  c->project_from_session = Rigid3d::FromPose(9.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  c->registration.method = "pairs";
  c->registration.reference = "room_b";
  return p;
}

TEST(ProjectTest, RoundTripKeepsEverything) {
  const Project p = TwoSessions();
  ASSERT_EQ(p.sessions.size(), 2u);
  EXPECT_EQ(p.sessions[0].id, "room_a");
  EXPECT_EQ(p.sessions[1].id, "room_b");
  EXPECT_EQ(p.Anchor(), 0);
  EXPECT_NE(p.sessions[0].color, p.sessions[1].color);

  Project q;
  const Status s = ProjectFromJson(ProjectToJson(p), "p.json", &q);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(q.sessions.size(), 2u);
  EXPECT_EQ(q.name, p.name);
  EXPECT_EQ(q.description, p.description);
  const ProjectSession& a = q.sessions[1];
  const ProjectSession& b = p.sessions[1];
  EXPECT_EQ(a.path, b.path);
  ASSERT_TRUE(a.calibration.has_value());
  EXPECT_EQ(a.calibration->gamma, b.calibration->gamma);
  ASSERT_TRUE(a.project_from_session.has_value());
  EXPECT_TRUE(a.project_from_session->translation().isApprox(b.project_from_session->translation(), 1e-15));
  EXPECT_NEAR(a.project_from_session->rotation().angularDistance(b.project_from_session->rotation()), 0.0, 1e-12);
  EXPECT_EQ(a.registration.method, "planes+icp");
  EXPECT_EQ(a.registration.reference, "room_a");
  EXPECT_EQ(a.registration.correspondences, 123456u);
  EXPECT_EQ(a.registration.covariance, b.registration.covariance);
  ASSERT_EQ(a.registration.pairs.size(), 2u);
  EXPECT_EQ(a.registration.pairs[1].target, Eigen::Vector3d(2, 2, 2));
  EXPECT_FALSE(a.visible);
  // The worst 1-sigma of each block: sqrt of its largest variance.
  EXPECT_NEAR(a.registration.SigmaRotation(), std::sqrt(3e-8), 1e-15);
  EXPECT_NEAR(a.registration.SigmaTranslation(), std::sqrt(24e-6), 1e-12);
  // And the text is stable: saving what was read gives the same bytes.
  EXPECT_EQ(ProjectToJson(q), ProjectToJson(p));
}

TEST(ProjectTest, IdsAreUniqueAndPathsAreNotAddedTwice) {
  Project p;
  ASSERT_TRUE(p.AddSession("a/room.sweepscan", nullptr).ok());
  ProjectSession* s = nullptr;
  ASSERT_TRUE(p.AddSession("b/room.sweepscan", &s).ok());
  EXPECT_EQ(s->id, "room-2");
  EXPECT_FALSE(s->project_from_session.has_value());  // only the first is placed
  const Status again = p.AddSession("a/./room.sweepscan", nullptr);
  EXPECT_FALSE(again.ok());
  EXPECT_NE(again.message().find("already in the project"), std::string::npos) << again.message();
  // The same folder however it is written: a trailing separator (what tab
  // completion gives), absolute, or through "..", against the project's folder.
  const std::string file = "/srv/scans/floor3/office.sweepscan-project";
  for (const std::string same :
       {"a/room.sweepscan/", "/srv/scans/floor3/a/room.sweepscan", "../floor3/a/room.sweepscan",
        "/srv/scans/floor3/a/room.sweepscan/"}) {
    const Status twice = p.AddSession(same, nullptr, file);
    EXPECT_FALSE(twice.ok()) << same;
    EXPECT_NE(twice.message().find("already in the project as 'room'"), std::string::npos)
        << twice.message();
  }
  EXPECT_TRUE(p.AddSession("/srv/scans/floor2/a/room.sweepscan", nullptr, file).ok());
  // A JSON string is UTF-8: a folder named in Latin-1 is refused, named.
  const Status latin1 = p.AddSession("b\xe2t.sweepscan", nullptr, file);
  ASSERT_FALSE(latin1.ok());
  EXPECT_NE(latin1.message().find("not UTF-8"), std::string::npos) << latin1.message();
  EXPECT_NE(latin1.message().find("t.sweepscan"), std::string::npos) << latin1.message();
  EXPECT_TRUE(p.AddSession("b\xc3\xa9t\xe2\x82\xac.sweepscan", nullptr, file).ok());  // "bét€"
  for (const char* bad : {"\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80", "x\xe2\x82"}) {
    EXPECT_FALSE(p.AddSession(bad, nullptr, file).ok())
        << bad;  // overlong, surrogate, > U+10FFFF, cut
  }
}

// References are a tree rooted at the anchor: a session placed against
// itself, against an unplaced one or in a loop is refused by the loader, and
// PlacedThrough says which sessions rest on which.
TEST(ProjectTest, ReferencesFormATreeRootedAtTheAnchor) {
  Project p = ThreeSessions();
  EXPECT_TRUE(p.PlacedThrough("room_c", "room_b"));
  EXPECT_TRUE(p.PlacedThrough("room_c", "room_a"));
  EXPECT_TRUE(p.PlacedThrough("room_b", "room_a"));
  EXPECT_FALSE(p.PlacedThrough("room_b", "room_c"));
  EXPECT_FALSE(p.PlacedThrough("room_a", "room_b"));
  Project q;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(p), "p", &q).ok());

  const auto refused = [](Project edited, const std::string& expect) {
    Project r;
    const Status s = ProjectFromJson(ProjectToJson(edited), "floor.sweepscan-project", &r);
    EXPECT_FALSE(s.ok()) << expect;
    EXPECT_NE(s.message().find(expect), std::string::npos) << s.message();
  };
  Project self = p;
  self.sessions[1].registration.reference = "room_b";
  refused(self, "'room_b' is placed against itself");
  Project loop = p;
  loop.sessions[1].registration.reference = "room_c";
  refused(loop, "the references form a loop: room_b -> room_c -> room_b");
  EXPECT_TRUE(loop.PlacedThrough("room_b", "room_b"));  // ends, in a loop too
  // Such a loop an older sweepscan could save: with `repairs`, it opens,
  // the reference that closes it dropped, the pose kept, and said.
  std::vector<std::string> repairs;
  Project repaired;
  ASSERT_TRUE(
      ProjectFromJson(ProjectToJson(loop), "floor.sweepscan-project", &repaired, &repairs).ok());
  ASSERT_EQ(repairs.size(), 1u);
  EXPECT_NE(repairs[0].find(
                "the references form a loop: room_b -> room_c -> room_b: 'room_b' keeps its pose"),
            std::string::npos)
      << repairs[0];
  EXPECT_EQ(repaired.sessions[1].registration.method, "manual");
  EXPECT_EQ(repaired.sessions[1].registration.reference, "");
  // Nothing measured it now: the old registration's numbers go with it.
  EXPECT_EQ(repaired.sessions[1].registration.rms_m, 0.0);
  EXPECT_EQ(repaired.sessions[1].registration.overlap, 0.0);
  EXPECT_EQ(repaired.sessions[1].registration.correspondences, 0u);
  EXPECT_EQ(repaired.sessions[1].registration.SigmaTranslation(), 0.0);
  EXPECT_TRUE(repaired.sessions[1].registration.pairs.empty());
  EXPECT_TRUE(repaired.sessions[1].project_from_session->translation().isApprox(
      loop.sessions[1].project_from_session->translation()));
  EXPECT_EQ(repaired.sessions[2].registration.reference, "room_b");
  Project again;
  EXPECT_TRUE(ProjectFromJson(ProjectToJson(repaired), "floor.sweepscan-project", &again).ok());
  Project unplaced = p;
  unplaced.sessions[1].project_from_session.reset();
  unplaced.sessions[1].registration = RegistrationEvidence();
  refused(unplaced, "'room_c' is placed against 'room_b', which is not placed");
}

// The evidence is what a registration reported: a covariance that is not
// one, a count beyond int64 and an anchor with measurements are handled.
TEST(ProjectTest, EvidenceIsCheckedAsWhatARegistrationReports) {
  const auto load = [](const Project& p, Project* out) {
    return ProjectFromJson(ProjectToJson(p), "floor.sweepscan-project", out);
  };
  Project p = TwoSessions();
  Project q;
  // (0, 1) without (1, 0), in the file (the writer symmetrises what it writes).
  nlohmann::json edited = nlohmann::json::parse(ProjectToJson(p));
  edited["sessions"][1]["registration"]["covariance"][1] = 1e-9;
  Status s = ProjectFromJson(edited.dump(2), "floor.sweepscan-project", &q);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("sessions[1].registration.covariance: must be symmetric"),
            std::string::npos)
      << s.message();
  // The writer's symmetrising: a registration's inverse is symmetric only to rounding.
  p.sessions[1].registration.covariance[1] = 1e-9;
  ASSERT_TRUE(load(p, &q).ok());
  EXPECT_EQ(q.sessions[1].registration.covariance[1], 0.5e-9);
  EXPECT_EQ(q.sessions[1].registration.covariance[6], 0.5e-9);
  p.sessions[1].registration.covariance[1] = 0.0;
  p.sessions[1].registration.covariance[7] = -4e-8;  // a negative variance
  s = load(p, &q);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("must be positive semi-definite"), std::string::npos) << s.message();
  p.sessions[1].registration.covariance[7] = 2e-8;
  p.sessions[1].registration.correspondences = 18446744073709551615u;
  ASSERT_TRUE(load(p, &q).ok());
  EXPECT_EQ(q.sessions[1].registration.correspondences, 18446744073709551615u);

  std::string text = ProjectToJson(TwoSessions());
  const std::string count = "\"correspondences\": 123456";
  text.replace(text.find(count), count.size(), "\"correspondences\": -1");
  s = ProjectFromJson(text, "floor.sweepscan-project", &q);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("correspondences: must be >= 0, got -1"), std::string::npos)
      << s.message();
  // The anchor was measured against nothing: evidence beside its method
  // would be dropped on the next save, so it is refused.
  text = ProjectToJson(TwoSessions());
  const std::string anchor = "\"method\": \"anchor\"";
  text.replace(text.find(anchor), anchor.size(), anchor + ", \"rms_m\": 0.01");
  s = ProjectFromJson(text, "floor.sweepscan-project", &q);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("sessions[0].registration"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("rms_m"), std::string::npos) << s.message();
}

TEST(ProjectTest, TheAnchorStaysWhileOthersArePlacedOnIt) {
  Project p = TwoSessions();
  EXPECT_FALSE(p.RemoveSession("room_a").ok());
  EXPECT_TRUE(p.RemoveSession("room_b").ok());
  EXPECT_TRUE(p.RemoveSession("room_a").ok());
  EXPECT_FALSE(p.RemoveSession("nothing").ok());
}

// The anchor removed while the others are unplaced: the first of them is
// the anchor (a project without one had nothing to align against, and the
// next session added silently became it).
TEST(ProjectTest, RemovingTheAnchorMakesTheFirstLeftTheAnchor) {
  Project p;
  ASSERT_TRUE(p.AddSession("a.sweepscan", nullptr).ok());
  ASSERT_TRUE(p.AddSession("b.sweepscan", nullptr).ok());
  ASSERT_TRUE(p.AddSession("c.sweepscan", nullptr).ok());
  std::string anchor;
  ASSERT_TRUE(p.RemoveSession("a", &anchor).ok());
  EXPECT_EQ(anchor, "b");
  ASSERT_EQ(p.Anchor(), 0);
  EXPECT_EQ(p.sessions[0].registration.method, "anchor");
  EXPECT_TRUE(p.sessions[0].project_from_session->translation().isZero());
  EXPECT_FALSE(p.sessions[1].project_from_session.has_value());
  anchor.clear();
  ASSERT_TRUE(p.RemoveSession("c", &anchor).ok());
  EXPECT_EQ(anchor, "");  // not the anchor
  Project q;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(p), "p.sweepscan-project", &q).ok());
  EXPECT_EQ(q.Anchor(), 0);

  // A file saved so by an older sweepscan: repaired on opening, said; a
  // session added to it does not take the first one's place.
  Project none;
  ASSERT_TRUE(none.AddSession("b.sweepscan", nullptr).ok());
  ASSERT_TRUE(none.AddSession("c.sweepscan", nullptr).ok());
  none.sessions[0].project_from_session.reset();
  none.sessions[0].registration = RegistrationEvidence();
  std::vector<std::string> repairs;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(none), "p", &q, &repairs).ok());
  ASSERT_EQ(repairs.size(), 1u);
  EXPECT_NE(repairs[0].find("no session is the anchor: 'b', the first, now is"), std::string::npos)
      << repairs[0];
  EXPECT_EQ(q.Anchor(), 0);
  ProjectSession* added = nullptr;
  ASSERT_TRUE(none.AddSession("d.sweepscan", &added).ok());
  EXPECT_FALSE(added->project_from_session.has_value());
  EXPECT_EQ(none.Anchor(), 0);
}

// The loader compares the folders the paths name, not their spelling; the
// evidence's time and reference are what the format says; the pose source
// a placement was measured with is kept (absent: ekf).
TEST(ProjectTest, LoaderRefusesWhatTheFormatForbids) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "sweepscan_project_rules";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "scans" / "room_a.sweepscan");
  const std::string file = (dir / "floor.sweepscan-project").string();
  const std::string good = ProjectToJson(TwoSessions());
  struct Edit {
    std::function<void(nlohmann::json*)> apply;
    std::string expect;
  };
  const std::string absolute = (dir / "scans" / "room_a.sweepscan").string();
  const Edit edits[] = {
      {[&](nlohmann::json* e) { (*e)["sessions"][1]["path"] = absolute; },
       "floor.sweepscan-project: sessions[1].path: '" + absolute + "' is also session 'room_a'"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"]["time_utc"] = "yesterday"; },
       "sessions[1].registration.time_utc: expected ISO 8601 UTC"},
      {[](nlohmann::json* e) {
         (*e)["sessions"][1]["registration"]["time_utc"] = "2026-11-26 07:00:00";
       },
       "sessions[1].registration.time_utc: expected ISO 8601 UTC"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"].erase("reference"); },
       "sessions[1].registration.reference: missing: a planes+icp placement names the session"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"]["reference"] = ""; },
       "sessions[1].registration.reference: must not be empty"},
      {[](nlohmann::json* e) { (*e)["sessions"][0]["registration"]["reference"] = ""; },
       "sessions[0].registration.reference: the anchor is aligned to nothing"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"]["pose_source"] = "sfm"; },
       "sessions[1].registration.pose_source: must be \"ekf\" or \"odometry\""},
      {[](nlohmann::json* e) {
         (*e)["sessions"][1]["project_from_session"]["translation_m"][0] = 8000.4;
       },
       "translation_m: lies 8000.4 m from the project's origin, beyond 8000 m"},
  };
  Project p;
  for (const Edit& edit : edits) {
    nlohmann::json e = nlohmann::json::parse(good);
    edit.apply(&e);
    std::ofstream(file) << e.dump(2);
    const Status refused = LoadProject(file, &p);
    EXPECT_FALSE(refused.ok()) << edit.expect;
    EXPECT_NE(refused.message().find(edit.expect), std::string::npos) << refused.message();
  }
  nlohmann::json e = nlohmann::json::parse(good);
  EXPECT_EQ(e["sessions"][1]["registration"]["pose_source"], "ekf");
  e["sessions"][1]["registration"].erase("pose_source");  // a file from before it was kept
  e["sessions"][1]["registration"]["time_utc"] = "2026-11-26T07:00:00.250Z";
  ASSERT_TRUE(ProjectFromJson(e.dump(), "p", &p).ok());
  EXPECT_EQ(p.sessions[1].registration.pose_source, "ekf");
  e["sessions"][1]["registration"]["pose_source"] = "odometry";
  ASSERT_TRUE(ProjectFromJson(e.dump(), "p", &p).ok());
  Project q;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(p), "p", &q).ok());
  EXPECT_EQ(q.sessions[1].registration.pose_source, "odometry");
  // A manual placement names no reference and no pose source.
  e["sessions"][1]["registration"] = {{"method", "manual"}};
  ASSERT_TRUE(ProjectFromJson(e.dump(), "p", &p).ok());
  EXPECT_EQ(
      nlohmann::json::parse(ProjectToJson(p))["sessions"][1]["registration"].count("pose_source"),
      0u);
  std::filesystem::remove_all(dir);
}

// A session others are placed against cannot go: the file would name a
// reference it no longer holds, and could not be opened again.
TEST(ProjectTest, ASessionOthersArePlacedAgainstStays) {
  Project p = ThreeSessions();
  const Status refused = p.RemoveSession("room_b");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("'room_c' placed against 'room_b'"), std::string::npos)
      << refused.message();
  ASSERT_EQ(p.sessions.size(), 3u);
  Project again;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(p), "p.sweepscan-project", &again).ok());
  EXPECT_TRUE(p.RemoveSession("room_c").ok());
  EXPECT_TRUE(p.RemoveSession("room_b").ok());
}

// Each edit breaks one rule; the message names the JSON path.
TEST(ProjectTest, StrictLoadingNamesThePlace) {
  const std::string good = ProjectToJson(TwoSessions());
  struct Case {
    std::string from, to, expect;
  };
  const Case cases[] = {
      {"\"sweepscan-project\"", "\"sweepscan-session\"", "format"},
      {"\"version\": 1", "\"version\": 2", "version 1, the file is version 2"},
      {"\"visible\": false", "\"visble\": false", "visble"},
      {"\"color\": \"#f28e2b\"", "\"color\": \"orange\"", "sessions[1].color"},
      {"\"method\": \"planes+icp\"", "\"method\": \"guess\"", "sessions[1].registration.method"},
      {"\"reference\": \"room_a\"", "\"reference\": \"room_z\"", "unknown session 'room_z'"},
      {"\"id\": \"room_b\"", "\"id\": \"room_a\"", "appears twice"},
      {"\"overlap\": 0.37", "\"overlap\": 1.37", "sessions[1].registration.overlap"},
      {"\"alpha_rad\": 0.01", "\"alpha_rad\": \"0.01\"", "sessions[1].calibration.alpha_rad"},
  };
  for (const Case& c : cases) {
    std::string text = good;
    const size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, c.from.size(), c.to);
    Project p;
    const Status s = ProjectFromJson(text, "office.sweepscan-project", &p);
    ASSERT_FALSE(s.ok()) << c.to;
    EXPECT_NE(s.message().find("office.sweepscan-project: "), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(c.expect), std::string::npos) << s.message();
  }
  // A rotation that is not one.
  nlohmann::json j = nlohmann::json::parse(good);
  j["sessions"][1]["project_from_session"]["rotation_wxyz"][0] = 0.5;
  Project p;
  const Status s = ProjectFromJson(j.dump(), "x", &p);
  EXPECT_NE(s.message().find("sessions[1].project_from_session.rotation_wxyz: must be a unit quaternion"),
            std::string::npos)
      << s.message();
  EXPECT_FALSE(ProjectFromJson("{\"format\": \"sweepscan-project\", \"version\": 1, \"sessions\": [}", "x", &p).ok());
  // A newer version with its own new key: the version is what is said
  // (this sweepscan is the older one), not the key it does not know.
  nlohmann::json newer = nlohmann::json::parse(good);
  newer["version"] = 2;
  newer["site"] = {{"crs", "EPSG:25832"}};
  const Status v = ProjectFromJson(newer.dump(), "x", &p);
  EXPECT_NE(v.message().find("version 1, the file is version 2"), std::string::npos) << v.message();

  // Values the format's rules exclude, each named at its place.
  struct Edit {
    std::function<void(nlohmann::json*)> apply;
    std::string expect;
  };
  const Edit edits[] = {
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"]["correspondences"] = -5; },
       "sessions[1].registration.correspondences: must be >= 0, got -5"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["registration"]["iterations"] = 99999999999LL; },
       "sessions[1].registration.iterations: must be within 0..1000000"},
      {[](nlohmann::json* e) {
         (*e)["sessions"][1]["registration"]["free_direction"] = {2.0, 0.0, 0.0};
       },
       "sessions[1].registration.free_direction: must be a unit vector"},
      {[](nlohmann::json* e) {
         (*e)["sessions"][0]["project_from_session"]["translation_m"][0] = 1.0;
       },
       "sessions[0].project_from_session: the anchor defines the project's frame"},
      {[](nlohmann::json* e) { (*e)["sessions"][1]["path"] = "scans/./room_a.sweepscan"; },
       "sessions[1].path: 'scans/./room_a.sweepscan' is also session 'room_a'"},
      // Map-grid coordinates (a UTM northing), which float positions would
      // round to half a metre, and a number that is no place at all.
      {[](nlohmann::json* e) {
         (*e)["sessions"][1]["project_from_session"]["translation_m"][1] = 5000000.4567;
       },
       "sessions[1].project_from_session.translation_m: lies 5000000 m from the project's origin, "
       "beyond "
       "8000 m"},
      {[](nlohmann::json* e) {
         (*e)["sessions"][1]["project_from_session"]["translation_m"][0] = 1e308;
       },
       "sessions[1].project_from_session.translation_m: lies"},
  };
  // Nor is such a pose saved.
  {
    Project far = TwoSessions();
    far.sessions[1].project_from_session =
        Rigid3d(Eigen::Vector3d(0, 5e6, 0), Eigen::Quaterniond::Identity());
    const std::string path = ::testing::TempDir() + "/far.sweepscan-project";
    const Status refused = SaveProject(path, far);
    EXPECT_NE(refused.message().find("is placed beyond 8000 m"), std::string::npos)
        << refused.message();
    EXPECT_FALSE(std::ifstream(path).good());
  }
  for (const Edit& edit : edits) {
    nlohmann::json e = nlohmann::json::parse(good);
    edit.apply(&e);
    const Status refused = ProjectFromJson(e.dump(), "x", &p);
    EXPECT_NE(refused.message().find(edit.expect), std::string::npos) << refused.message();
  }
}

// A building of known truth for the anchor's change: world_from_session of
// each session drawn at random (within 40 m, any rotation), the project's
// poses their inverse(world_from_a) * world_from_k, references as a tree
//   a (anchor) <- b <- c <- h,  a <- d,  e (manual, no reference) <- f,
// and g not placed. Each measured placement carries a covariance built from
// known perturbations, a free direction and pairs that hold exactly.
struct Building {
  Project project;
  std::map<std::string, Rigid3d> world_from;  // the truth
  // Per measured session: the perturbations (in its reference's frame)
  // whose outer products sum to its covariance.
  std::map<std::string, std::vector<Eigen::Matrix<double, 6, 1>>> perturbations;
};

Rigid3d RandomPose(std::mt19937* rng, double extent) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-extent, extent);
  const Eigen::Quaterniond q(n(*rng), n(*rng), n(*rng), n(*rng));
  return Rigid3d({u(*rng), u(*rng), u(*rng)}, q.normalized());
}

// Exp(xi) to first order and beyond: the rotation by the vector omega, then
// the translation v (xi = (omega, v)).
Rigid3d Exp(const Eigen::Matrix<double, 6, 1>& xi) {
  const Eigen::Vector3d w = xi.head<3>();
  const Eigen::Quaterniond q = w.norm() > 0
                                   ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))
                                   : Eigen::Quaterniond::Identity();
  return Rigid3d(xi.tail<3>(), q);
}

// Log of a near-identity transform: (rotation vector, translation).
Eigen::Matrix<double, 6, 1> Log(const Rigid3d& t) {
  const Eigen::AngleAxisd aa(t.rotation());
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = aa.angle() * aa.axis();
  xi.tail<3>() = t.translation();
  return xi;
}

Building RandomBuilding(uint32_t seed) {
  std::mt19937 rng(seed);
  Building b;
  for (const char* id : {"a", "b", "c", "d", "e", "f", "g", "h"}) {
    EXPECT_TRUE(b.project.AddSession(std::string(id) + ".sweepscan", nullptr).ok());
    b.world_from[id] = RandomPose(&rng, 40.0);
  }
  std::normal_distribution<double> n(0.0, 1.0);
  const auto place = [&](const std::string& id, const std::string& reference,
                         const std::string& method) {
    ProjectSession& s = b.project.sessions[b.project.Find(id)];
    s.project_from_session = b.world_from["a"].inverse() * b.world_from[id];
    s.registration.method = method;
    s.registration.reference = reference;
    if (method == "manual") return;
    s.registration.rms_m = 0.004;
    s.registration.overlap = 0.3;
    s.registration.correspondences = 5000;
    s.registration.iterations = 9;
    s.registration.time_utc = "2026-11-29T10:00:00Z";
    s.registration.pose_source = "ekf";
    Eigen::Matrix<double, 6, 6> c = Eigen::Matrix<double, 6, 6>::Zero();
    for (int k = 0; k < 7; ++k) {
      Eigen::Matrix<double, 6, 1> xi;
      for (int i = 0; i < 6; ++i) xi[i] = n(rng) * (i < 3 ? 1e-3 : 5e-3);
      b.perturbations[id].push_back(xi);
      c += xi * xi.transpose();
    }
    for (int i = 0; i < 36; ++i) s.registration.covariance[i] = c(i / 6, i % 6);
    s.registration.free_direction = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    // Picks that hold exactly: the same world point in both frames.
    const Rigid3d reference_from_session = b.world_from[reference].inverse() * b.world_from[id];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d source(n(rng), n(rng), n(rng));
      s.registration.pairs.push_back({source, reference_from_session * source});
    }
  };
  place("b", "a", "planes+icp");
  place("c", "b", "pairs+icp");
  place("h", "c", "icp");
  place("d", "a", "planes");
  place("e", "", "manual");
  place("f", "e", "pairs");
  return b;
}

// Every placed session's points land where the truth puts them, seen from
// `anchor`'s start pose: the same building, only its origin changed.
void ExpectSameBuilding(const Building& b, const Project& p, const std::string& anchor) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (const ProjectSession& s : p.sessions) {
    if (s.id == "g") {
      EXPECT_FALSE(s.project_from_session.has_value());
      continue;
    }
    ASSERT_TRUE(s.project_from_session.has_value()) << s.id;
    const Rigid3d truth = b.world_from.at(anchor).inverse() * b.world_from.at(s.id);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d point(u(rng), u(rng), u(rng));
      EXPECT_LT((*s.project_from_session * point - truth * point).norm(), 1e-9)
          << "'" << s.id << "' anchored on '" << anchor << "'";
    }
  }
}

// Making another session the anchor moves the origin, not the building: on
// random buildings, every session's points are where the truth says, seen
// from the new anchor, and the references still form a tree whose every
// measurement (the pairs) holds between the session and its reference.
TEST(ProjectTest, ChangingTheAnchorKeepsTheBuildingAndTurnsTheChainRound) {
  struct Case {
    std::string anchor;
    std::vector<std::string> reversed;
    std::map<std::string, std::string> reference;  // afterwards ("" for none)
    std::map<std::string, std::string> method;
  };
  const std::vector<Case> cases = {
      {"b",
       {"a"},
       {{"a", "b"}, {"c", "b"}, {"h", "c"}, {"d", "a"}, {"e", ""}, {"f", "e"}},
       {{"b", "anchor"}, {"a", "planes+icp"}, {"c", "pairs+icp"}, {"e", "manual"}}},
      {"h",
       {"c", "b", "a"},
       {{"c", "h"}, {"b", "c"}, {"a", "b"}, {"d", "a"}, {"f", "e"}},
       {{"h", "anchor"}, {"c", "icp"}, {"b", "pairs+icp"}, {"a", "planes+icp"}, {"d", "planes"}}},
      {"d",
       {"a"},
       {{"a", "d"}, {"b", "a"}, {"c", "b"}, {"h", "c"}, {"f", "e"}},
       {{"d", "anchor"}, {"a", "planes"}, {"b", "planes+icp"}}},
      // On a chain that ends at a session held by hand, the old anchor is
      // held by hand too.
      {"f",
       {"e"},
       {{"e", "f"}, {"a", ""}, {"b", "a"}, {"d", "a"}},
       {{"f", "anchor"}, {"e", "pairs"}, {"a", "manual"}}},
      {"e",
       {},
       {{"a", ""}, {"f", "e"}, {"b", "a"}},
       {{"e", "anchor"}, {"a", "manual"}, {"f", "pairs"}}},
  };
  for (uint32_t seed = 1; seed <= 25; ++seed) {
    const Building b = RandomBuilding(seed);
    ExpectSameBuilding(b, b.project, "a");
    for (const Case& c : cases) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", anchor " + c.anchor);
      Project p = b.project;
      Project::AnchorChange change;
      const Status s = p.ChangeAnchor(c.anchor, &change);
      ASSERT_TRUE(s.ok()) << s.message();
      EXPECT_EQ(change.old_anchor, "a");
      EXPECT_FALSE(change.old_anchor_unplaced);
      EXPECT_EQ(change.reversed, c.reversed);
      ASSERT_EQ(p.Anchor(), p.Find(c.anchor));
      EXPECT_EQ(p.sessions.size(), b.project.sessions.size());
      ExpectSameBuilding(b, p, c.anchor);
      for (const auto& [id, reference] : c.reference) {
        EXPECT_EQ(p.sessions[p.Find(id)].registration.reference, reference) << id;
      }
      for (const auto& [id, method] : c.method) {
        EXPECT_EQ(p.sessions[p.Find(id)].registration.method, method) << id;
      }
      // Every measurement holds between the session and its reference.
      for (const ProjectSession& ps : p.sessions) {
        if (ps.registration.reference.empty()) continue;
        const ProjectSession& r = p.sessions[p.Find(ps.registration.reference)];
        const Rigid3d reference_from_session =
            r.project_from_session->inverse() * *ps.project_from_session;
        for (const PickedPair& pair : ps.registration.pairs) {
          EXPECT_LT((reference_from_session * pair.source - pair.target).norm(), 1e-9) << ps.id;
        }
      }
      // A valid file, nothing to repair, and the same again when read.
      Project q;
      std::vector<std::string> repairs;
      const Status loaded = ProjectFromJson(ProjectToJson(p), "p.sweepscan-project", &q, &repairs);
      ASSERT_TRUE(loaded.ok()) << loaded.message();
      EXPECT_TRUE(repairs.empty());
      ExpectSameBuilding(b, q, c.anchor);
    }
  }
}

// A placement turned round carries its uncertainty: the covariance, built
// from known perturbations of reference_from_session, is that of the same
// perturbations pushed through the inverse (measured numerically here),
// in the new reference's frame; the free direction is where the inverse
// stays free; turning back gives the first evidence again.
TEST(ProjectTest, ATurnedPlacementCarriesItsCovarianceAndFreeDirection) {
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Building b = RandomBuilding(seed);
    Project p = b.project;
    ASSERT_TRUE(p.ChangeAnchor("b").ok());
    const RegistrationEvidence& was = b.project.sessions[b.project.Find("b")].registration;
    const RegistrationEvidence& turned = p.sessions[p.Find("a")].registration;
    // a_from_b as measured; b_from_a now.
    const Rigid3d measured = b.world_from.at("a").inverse() * b.world_from.at("b");
    Eigen::Matrix<double, 6, 6> expect = Eigen::Matrix<double, 6, 6>::Zero();
    const double eps = 1e-6;
    for (const Eigen::Matrix<double, 6, 1>& xi : b.perturbations.at("b")) {
      // measured perturbed in a's frame, inverted, compared in b's frame.
      const Rigid3d inverse = (Exp(eps * xi) * measured).inverse();
      const Eigen::Matrix<double, 6, 1> turned_xi = Log(inverse * measured) / eps;
      expect += turned_xi * turned_xi.transpose();
    }
    double worst = 0.0;
    for (int i = 0; i < 36; ++i) {
      worst = std::max(worst, std::abs(turned.covariance[i] - expect(i / 6, i % 6)));
    }
    EXPECT_LT(worst, 1e-4 * expect.cwiseAbs().maxCoeff());
    // It differs from the one it came from (the lever arm of the rotation).
    EXPECT_GT(std::abs(turned.SigmaTranslation() - was.SigmaTranslation()), 1e-6);
    // Free along d in a's frame: the inverse moves along turned.free_direction in b's.
    const Rigid3d slid = (Rigid3d::Translation(0.5 * was.free_direction) * measured).inverse();
    const Rigid3d moved = slid * measured;
    EXPECT_LT(moved.rotation().angularDistance(Eigen::Quaterniond::Identity()), 1e-12);
    EXPECT_NEAR(std::abs(moved.translation().normalized().dot(turned.free_direction)), 1.0, 1e-9);
    EXPECT_NEAR(turned.free_direction.norm(), 1.0, 1e-12);
    // The numbers a measurement has, as measured.
    EXPECT_EQ(turned.rms_m, was.rms_m);
    EXPECT_EQ(turned.overlap, was.overlap);
    EXPECT_EQ(turned.correspondences, was.correspondences);
    EXPECT_EQ(turned.time_utc, was.time_utc);
    EXPECT_EQ(turned.pose_source, was.pose_source);
    ASSERT_EQ(turned.pairs.size(), was.pairs.size());
    EXPECT_EQ(turned.pairs[0].source, was.pairs[0].target);

    // Back to a: the poses and the evidence are the first ones again.
    Project::AnchorChange back;
    ASSERT_TRUE(p.ChangeAnchor("a", &back).ok());
    EXPECT_EQ(back.old_anchor, "b");
    EXPECT_EQ(back.reversed, std::vector<std::string>{"b"});
    for (size_t k = 0; k < p.sessions.size(); ++k) {
      const ProjectSession& now = p.sessions[k];
      const ProjectSession& first = b.project.sessions[k];
      EXPECT_EQ(now.registration.method, first.registration.method) << now.id;
      EXPECT_EQ(now.registration.reference, first.registration.reference) << now.id;
      for (int i = 0; i < 36; ++i) {
        EXPECT_NEAR(now.registration.covariance[i], first.registration.covariance[i], 1e-15)
            << now.id;
      }
      EXPECT_LT((now.registration.free_direction - first.registration.free_direction).norm(),
                1e-12);
      ASSERT_EQ(now.project_from_session.has_value(), first.project_from_session.has_value());
      if (!now.project_from_session) continue;
      EXPECT_LT(
          (now.project_from_session->translation() - first.project_from_session->translation())
              .norm(),
          1e-9);
      EXPECT_LT(now.project_from_session->rotation().angularDistance(
                    first.project_from_session->rotation()),
                1e-9);
    }
  }
}

// Only a placed session's frame is known relative to the others: an
// unplaced one is refused while anything else is placed, and then nothing
// changes; with nothing placed but the anchor, the old anchor is unplaced
// instead. The anchor already: nothing to do. Too far: refused.
TEST(ProjectTest, TheAnchorChangesOnlyToASessionWhoseFrameIsKnown) {
  const Building b = RandomBuilding(3);
  Project p = b.project;
  Status s = p.ChangeAnchor("g");
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("'g' is not placed: align it first"), std::string::npos)
      << s.message();
  EXPECT_EQ(ProjectToJson(p), ProjectToJson(b.project));
  EXPECT_NE(p.ChangeAnchor("nothing").message().find("no session 'nothing'"), std::string::npos);
  Project::AnchorChange change;
  change.old_anchor = "x";
  ASSERT_TRUE(p.ChangeAnchor("a", &change).ok());
  EXPECT_EQ(change.old_anchor, "");
  EXPECT_EQ(ProjectToJson(p), ProjectToJson(b.project));

  Project fresh;
  for (const char* f : {"a.sweepscan", "b.sweepscan", "c.sweepscan"}) {
    ASSERT_TRUE(fresh.AddSession(f, nullptr).ok());
  }
  ASSERT_TRUE(fresh.ChangeAnchor("c", &change).ok());
  EXPECT_EQ(change.old_anchor, "a");
  EXPECT_TRUE(change.old_anchor_unplaced);
  EXPECT_EQ(fresh.Anchor(), 2);
  EXPECT_FALSE(fresh.sessions[0].project_from_session.has_value());
  EXPECT_EQ(fresh.sessions[0].registration.method, "");
  Project q;
  ASSERT_TRUE(ProjectFromJson(ProjectToJson(fresh), "p", &q).ok());
  EXPECT_EQ(q.Anchor(), 2);

  // 6 km east and 6 km west of the anchor: either as the anchor puts the
  // other 12 km away, beyond what a cloud's floats hold.
  Project far;
  ProjectSession* added = nullptr;
  for (const char* f : {"a.sweepscan", "east.sweepscan", "west.sweepscan"}) {
    ASSERT_TRUE(far.AddSession(f, &added).ok());
  }
  far.sessions[1].project_from_session = Rigid3d::Translation({6000, 0, 0});
  far.sessions[1].registration.method = "manual";
  far.sessions[2].project_from_session = Rigid3d::Translation({-6000, 0, 0});
  far.sessions[2].registration.method = "manual";
  const std::string before = ProjectToJson(far);
  s = far.ChangeAnchor("east");
  EXPECT_NE(s.message().find("'west' would lie beyond 8000 m of 'east''s start pose"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(ProjectToJson(far), before);
}

TEST(ProjectTest, SavesAtomicallyAndResolvesPathsAgainstItsFolder) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "sweepscan_project_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "sub");
  const std::string file = (dir / "sub" / "floor.sweepscan-project").string();
  Project p = TwoSessions();
  p.sessions[0].path = "../room_a.sweepscan";
  p.sessions[1].path = "/data/room_b.sweepscan";
  ASSERT_TRUE(SaveProject(file, p).ok());
  Project q;
  const Status s = LoadProject(file, &q);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(ResolveSessionPath(file, q.sessions[0]), (dir / "room_a.sweepscan").string());
  EXPECT_EQ(ResolveSessionPath(file, q.sessions[1]), "/data/room_b.sweepscan");
  EXPECT_EQ(ProjectDirectory("floor.sweepscan-project"), ".");
  const Status missing = LoadProject((dir / "none.sweepscan-project").string(), &q);
  EXPECT_NE(missing.message().find("cannot open"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sweepscan
