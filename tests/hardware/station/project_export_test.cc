// A project's cloud written as one file (ExportProjectCloud, what `project
// export` and the app's File > Export Project Cloud write), against the
// truth of each session's cloud built whole (LoadSessionCloud, not
// streamed) and moved by its placement: the lab drive twice, the second
// turned a quarter and moved 20 m, so a record in the wrong place, under
// the wrong session's id or with the other's clock shows.
#include "hardware/station/project_export.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "tests/testing/lab_session.h"
#include "tests/testing/las_records.h"
#include "tests/testing/remove_at_exit.h"

namespace sweepscan::hardware {
namespace {

std::string Dir() {
  static const std::string dir = [] {
    const std::string d = testing::RemoveAtExit(
        ::testing::TempDir() + "/sweepscan_project_export_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}
std::string P(const std::string& name) { return Dir() + "/" + name; }
const std::string kProjectFile = "/nowhere/floor.sweepscan-project";  // the folders are absolute

const Rigid3d kSecond = Rigid3d::FromPose(20.0, -3.0, 0.0, 0.0, 0.0, M_PI / 2);

// Session "a" (the anchor) and "b" (the same drive, placed at kSecond),
// and "hidden" (placed, not shown) and "loose" (not placed).
Project TwoPlaced() {
  Project p;
  p.name = "floor";
  for (const char* id : {"a", "hidden", "b", "loose"}) {
    ProjectSession s;
    s.id = id;
    s.path = testing::LabDriveSession();
    p.sessions.push_back(s);
  }
  p.sessions[0].project_from_session = Rigid3d();
  p.sessions[1].project_from_session = Rigid3d();
  p.sessions[1].visible = false;
  p.sessions[2].project_from_session = kSecond;
  return p;
}

std::vector<CloudPoint> Truth(const Rigid3d& placed) {
  ProjectSession s;
  s.id = "truth";
  s.path = testing::LabDriveSession();
  SessionCloud cloud;
  const Status st = LoadSessionCloud(kProjectFile, s, SessionCloudOptions(), &cloud);
  EXPECT_TRUE(st.ok()) << st.message();
  TransformPoints(placed, &cloud.points);
  return cloud.points;
}

TEST(ProjectExportTest, TheShownSessionsArePlacedAndVisibleOnes) {
  std::vector<std::string> unplaced;
  EXPECT_EQ(PlacedVisibleSessions(TwoPlaced(), &unplaced), (std::vector<size_t>{0, 2}));
  EXPECT_EQ(unplaced, std::vector<std::string>{"loose"});
}

// Every record is its session's point where the placement puts it (within
// half the scale), under its session's Point Source ID (1-based place in
// the file: 1 and 3) and with its own clock; the PLY is the two clouds.
TEST(ProjectExportTest, LasAndPlyHoldEachSessionWherePlaced) {
  const Project project = TwoPlaced();
  const std::vector<size_t> chosen = PlacedVisibleSessions(project, nullptr);
  std::vector<CloudPoint> truth = Truth(Rigid3d());
  const size_t first = truth.size();
  const std::vector<CloudPoint> second = Truth(kSecond);
  truth.insert(truth.end(), second.begin(), second.end());
  ASSERT_GT(first, 100000u);

  std::vector<std::string> stages;
  double last = -1.0;
  bool climbs = true;
  const ProjectExportProgress progress = [&](const std::string& stage, double f) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
    climbs = climbs && f >= last && f <= 1.0;
    last = f;
    return true;
  };
  ProjectExportResult r;
  Status s = ExportProjectCloud(kProjectFile, project, chosen, P("floor.las"),
                                SessionCloudOptions(), progress, &r);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_TRUE(climbs);
  EXPECT_GT(last, 0.99);
  EXPECT_EQ(stages.front(), "Reading 'a' for the extent (1 of 2)");
  EXPECT_EQ(stages.back(), "Reading 'b' (2 of 2)");
  ASSERT_EQ(r.sessions.size(), 2u);
  EXPECT_EQ(r.sessions[0].id, "a");
  EXPECT_EQ(r.sessions[1].point_source_id, 3);
  EXPECT_EQ(r.sessions[0].points, first);
  EXPECT_EQ(r.points, truth.size());
  EXPECT_TRUE(r.gps_time);
  EXPECT_TRUE(r.warnings.empty());

  testing::LasRecords las;
  ASSERT_TRUE(las.Read(P("floor.las")));
  EXPECT_EQ(las.global_encoding & 1, 1);  // adjusted GPS time
  EXPECT_EQ(las.system_identifier, "sweepscan project");
  ASSERT_EQ(las.count, truth.size());
  double worst = 0.0;
  size_t wrong_source = 0, other_clock = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(worst, (las.Position(i) - Eigen::Vector3d(truth[i].x, truth[i].y, truth[i].z))
                                .cwiseAbs()
                                .maxCoeff());
    wrong_source += las.PointSourceId(i) != (i < first ? 1 : 3);
    // The same drive twice: session b's k-th point has a's k-th point's time.
    if (i >= first) other_clock += las.GpsTime(i) != las.GpsTime(i - first);
  }
  EXPECT_LE(worst, 0.5 * las.scale[0] + 1e-6);
  EXPECT_EQ(wrong_source, 0u);
  EXPECT_EQ(other_clock, 0u);

  s = ExportProjectCloud(kProjectFile, project, chosen, P("floor.ply"), SessionCloudOptions(),
                         nullptr, &r);
  ASSERT_TRUE(s.ok()) << s.message();
  std::vector<CloudPoint> ply;
  ASSERT_TRUE(LoadCloud(P("floor.ply"), &ply).ok());
  ASSERT_EQ(ply.size(), truth.size());
  size_t differ = 0;
  for (size_t i = 0; i < ply.size(); ++i) {
    differ += ply[i].x != truth[i].x || ply[i].y != truth[i].y || ply[i].z != truth[i].z;
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_EQ(r.sessions[1].points, second.size());

  // PCD through the same streamed writer: every attribute of every point.
  s = ExportProjectCloud(kProjectFile, project, chosen, P("floor.pcd"), SessionCloudOptions(),
                         nullptr, &r);
  ASSERT_TRUE(s.ok()) << s.message();
  std::vector<CloudPoint> pcd;
  ASSERT_TRUE(LoadCloud(P("floor.pcd"), &pcd).ok());
  ASSERT_EQ(pcd.size(), ply.size());
  differ = 0;
  for (size_t i = 0; i < pcd.size(); ++i) {
    differ += std::memcmp(&pcd[i], &ply[i], sizeof(CloudPoint)) != 0;
  }
  EXPECT_EQ(differ, 0u);
}

// Cancelled half way, a session that cannot be read, an unplaced session
// and a file name of no cloud format: each fails, says why and leaves no
// file (not even the writer's temporary).
TEST(ProjectExportTest, CancelledOrRefusedLeavesNothing) {
  const std::string out = P("refused/floor.las");
  std::filesystem::create_directories(P("refused"));
  Project project = TwoPlaced();
  ProjectExportResult r;
  Status s;
  // LAS writes in its second pass, PLY from the first session's first chunk.
  for (const char* name : {"refused/floor.las", "refused/floor.ply"}) {
    s = ExportProjectCloud(
        kProjectFile, project, {0, 2}, P(name), SessionCloudOptions(),
        [](const std::string&, double f) { return f < 0.6; }, &r);
    EXPECT_EQ(s.message(), "cancelled") << name;
    EXPECT_FALSE(r.session_unreadable);
    EXPECT_TRUE(std::filesystem::is_empty(P("refused"))) << name;
  }

  project.sessions[2].path = P("no_such.sweepscan");
  for (const char* name : {"refused/floor.las", "refused/floor.ply"}) {
    s = ExportProjectCloud(kProjectFile, project, {0, 2}, P(name), SessionCloudOptions(), nullptr,
                           &r);
    EXPECT_NE(s.message().find("session 'b'"), std::string::npos) << s.message();
    EXPECT_TRUE(r.session_unreadable) << name;
    EXPECT_TRUE(std::filesystem::is_empty(P("refused"))) << name;
  }

  s = ExportProjectCloud(kProjectFile, project, {3}, out, SessionCloudOptions(), nullptr, &r);
  EXPECT_EQ(s.message(), "'loose' is not placed yet");
  s = ExportProjectCloud(kProjectFile, project, {0}, P("refused/floor.txt"), SessionCloudOptions(),
                         nullptr, &r);
  EXPECT_FALSE(s.ok());
  s = ExportProjectCloud(kProjectFile, project, {0}, P("refused/no/such/floor.las"),
                         SessionCloudOptions(), nullptr, &r);
  EXPECT_FALSE(s.ok());
  EXPECT_FALSE(r.session_unreadable);
  EXPECT_TRUE(std::filesystem::is_empty(P("refused")));
}

}  // namespace
}  // namespace sweepscan::hardware
