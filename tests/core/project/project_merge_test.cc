// Merging a project edited here with the file another program saved
// meanwhile (core/project/project_merge.h): what one side changed is kept,
// what both changed differently is a conflict naming the session, and so
// are placements that would not hold together in the merge.
#include "core/project/project_merge.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace {

// a the anchor, b placed against a, c unplaced.
Project Base() {
  Project p;
  p.name = "floor";
  for (const char* path : {"a.sweepscan", "b.sweepscan", "c.sweepscan"})
    EXPECT_TRUE(p.AddSession(path, nullptr).ok());
  p.sessions[1].project_from_session = Rigid3d::FromPose(4.0, -3.0, 0.0, 0.0, 0.0, 1.1);
  p.sessions[1].registration.method = "planes+icp";
  p.sessions[1].registration.reference = "a";
  return p;
}

void PlaceC(Project* p, const std::string& against, const Rigid3d& reference_from_c) {
  ProjectSession& c = p->sessions[p->Find("c")];
  c.project_from_session = *p->sessions[p->Find(against)].project_from_session * reference_from_c;
  c.registration = RegistrationEvidence();
  c.registration.method = "planes+icp";
  c.registration.reference = against;
}

// Session `id` as the file would hold it.
std::string Saved(const Project& p, const std::string& id) {
  Project one;
  one.sessions = {p.sessions[p.Find(id)]};
  return ProjectToJson(one);
}

std::vector<std::string> Ids(const Project& p) {
  std::vector<std::string> ids;
  for (const ProjectSession& s : p.sessions) ids.push_back(s.id);
  return ids;
}

TEST(ProjectMergeTest, KeepsEachSidesOwnChanges) {
  const Project base = Base();
  Project here = base, file = base;
  here.sessions[1].color = "#00ff00";  // b recoloured here
  here.description = "east wing";
  ASSERT_TRUE(here.AddSession("d.sweepscan", nullptr).ok());
  const Rigid3d b_from_c = Rigid3d::FromPose(1.0, 2.0, 0.0, 0.0, 0.0, -0.3);
  PlaceC(&file, "b", b_from_c);  // the CLI aligned c
  file.sessions[0].visible = false;
  const ProjectMerge m = MergeProjects(base, here, file);
  EXPECT_TRUE(m.conflicts.empty()) << m.conflicts.front();
  EXPECT_EQ(Ids(m.merged), (std::vector<std::string>{"a", "b", "c", "d"}));
  EXPECT_EQ(m.merged.description, "east wing");
  EXPECT_EQ(m.merged.sessions[1].color, "#00ff00");
  EXPECT_FALSE(m.merged.sessions[0].visible);
  ASSERT_TRUE(m.merged.sessions[2].project_from_session.has_value());
  EXPECT_EQ(Saved(m.merged, "c"), Saved(file, "c"));
  EXPECT_EQ(m.from_file, (std::vector<std::string>{"a", "c"}));
}

// Each side's edits are fine alone and touch different sessions, but
// together they put two sessions on one folder: the merge would write a
// file the loader refuses, so it is a conflict, said with the loader's words.
TEST(ProjectMergeTest, EditsThatTogetherMakeAFileTheLoaderRefusesConflict) {
  const Project base = Base();
  Project here = base, file = base;
  here.sessions[1].path = "x.sweepscan";  // b's folder moved here
  file.sessions[2].path = "x.sweepscan";  // c's in the file
  const ProjectMerge m = MergeProjects(base, here, file);
  ASSERT_EQ(m.conflicts.size(), 1u);
  EXPECT_NE(m.conflicts[0].find("the merge: "), std::string::npos) << m.conflicts[0];
  EXPECT_NE(m.conflicts[0].find("x.sweepscan"), std::string::npos) << m.conflicts[0];
  EXPECT_NE(m.conflicts[0].find("from the edits here and in the file together"),
            std::string::npos)
      << m.conflicts[0];
}

TEST(ProjectMergeTest, TakesRemovalsFromEitherSide) {
  const Project base = Base();
  Project here = base, file = base;
  ASSERT_TRUE(here.RemoveSession("c").ok());
  ASSERT_TRUE(file.AddSession("d.sweepscan", nullptr).ok());
  ASSERT_TRUE(file.RemoveSession("b").ok());
  const ProjectMerge m = MergeProjects(base, here, file);
  EXPECT_TRUE(m.conflicts.empty());
  EXPECT_EQ(Ids(m.merged), (std::vector<std::string>{"a", "d"}));
}

TEST(ProjectMergeTest, TheSameSessionChangedOnBothSidesConflicts) {
  const Project base = Base();
  Project here = base, file = base;
  here.sessions[1].color = "#00ff00";
  file.sessions[1].color = "#ff0000";
  here.sessions[2].visible = false;  // changed here only: not a conflict
  ProjectMerge m = MergeProjects(base, here, file);
  EXPECT_EQ(m.conflicting, (std::vector<std::string>{"b"}));
  ASSERT_EQ(m.conflicts.size(), 1u);
  EXPECT_EQ(m.conflicts[0], "'b': its colour here, its colour in the file");
  // The same change on both sides is no conflict.
  file.sessions[1].color = "#00ff00";
  EXPECT_TRUE(MergeProjects(base, here, file).conflicts.empty());
  // Removed in the file, edited here.
  file = base;
  ASSERT_TRUE(file.RemoveSession("c").ok());
  m = MergeProjects(base, here, file);
  EXPECT_EQ(m.conflicting, (std::vector<std::string>{"c"}));
  EXPECT_EQ(m.conflicts[0], "'c': hidden here, removed in the file");
}

TEST(ProjectMergeTest, APlacementAgainstAReferenceMovedOnTheOtherSideConflicts) {
  const Project base = Base();
  Project here = base, file = base;
  PlaceC(&file, "b", Rigid3d::FromPose(1.0, 2.0, 0.0, 0.0, 0.0, -0.3));
  // b placed again here (c untouched here, so it would be taken from the file).
  here.sessions[1].project_from_session = Rigid3d::FromPose(4.1, -3.0, 0.0, 0.0, 0.0, 1.1);
  ProjectMerge m = MergeProjects(base, here, file);
  EXPECT_EQ(m.conflicting, (std::vector<std::string>{"c"}));
  EXPECT_EQ(m.conflicts[0], "'c': placed against 'b', placed again here");
  // b removed here instead.
  here = base;
  ASSERT_TRUE(here.RemoveSession("b").ok());
  m = MergeProjects(base, here, file);
  EXPECT_EQ(m.conflicting, (std::vector<std::string>{"c"}));
  EXPECT_EQ(m.conflicts[0], "'c': placed against 'b', removed here");
}

TEST(ProjectMergeTest, APlacementInTheOldFrameConflictsWithAChangeOfAnchor) {
  const Project base = Base();
  Project here = base, file = base;
  ASSERT_TRUE(here.ChangeAnchor("b").ok());
  // c placed in the file by hand, in a's frame, on no reference.
  file.sessions[2].project_from_session = Rigid3d::FromPose(8.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  file.sessions[2].registration.method = "manual";
  ProjectMerge m = MergeProjects(base, here, file);
  ASSERT_EQ(m.conflicting, (std::vector<std::string>{"c"}));
  EXPECT_EQ(m.conflicts[0], "'c': placed in the file while the anchor became 'b' here");
  // No placement in the file: the change of anchor merges.
  file = base;
  file.sessions[2].color = "#123456";
  m = MergeProjects(base, here, file);
  EXPECT_TRUE(m.conflicts.empty()) << m.conflicts.front();
  EXPECT_EQ(m.merged.Anchor(), 1);
  EXPECT_EQ(m.merged.sessions[2].color, "#123456");
  EXPECT_EQ(m.merged.sessions[0].registration.reference, "b");
  // The anchor changed in the file, a placement here.
  here = base;
  PlaceC(&here, "a", Rigid3d::FromPose(0.0, 5.0, 0.0, 0.0, 0.0, 0.0));
  file = base;
  ASSERT_TRUE(file.ChangeAnchor("b").ok());
  m = MergeProjects(base, here, file);
  ASSERT_EQ(m.conflicting, (std::vector<std::string>{"c"}));
}

// `sweepscan-cli project anchor b` moves every placement into b's frame;
// a colour set here on b and a hidden here are other fields of the same
// sessions, so the merge takes both (it once refused: "its colour here,
// placed again in the file").
TEST(ProjectMergeTest, AChangeOfAnchorThereMergesWithOtherFieldsSetHere) {
  const Project base = Base();
  Project here = base, file = base;
  here.sessions[1].color = "#00ff00";
  here.sessions[0].visible = false;
  ASSERT_TRUE(file.ChangeAnchor("b").ok());
  ProjectMerge m = MergeProjects(base, here, file);
  EXPECT_TRUE(m.conflicts.empty()) << m.conflicts.front();
  EXPECT_EQ(m.merged.Anchor(), 1);
  EXPECT_EQ(m.merged.sessions[1].color, "#00ff00");
  EXPECT_FALSE(m.merged.sessions[0].visible);
  for (const char* id : {"a", "b"}) {
    const ProjectSession& merged = m.merged.sessions[m.merged.Find(id)];
    const ProjectSession& there = file.sessions[file.Find(id)];
    ASSERT_TRUE(merged.project_from_session.has_value()) << id;
    EXPECT_TRUE(merged.project_from_session->ToIsometry().isApprox(
        there.project_from_session->ToIsometry(), 1e-12))
        << id;
    EXPECT_EQ(merged.registration.method, there.registration.method) << id;
    EXPECT_EQ(merged.registration.reference, there.registration.reference) << id;
  }
  EXPECT_EQ(m.from_file, (std::vector<std::string>{"a", "b"}));
  // The same field changed on both sides is still a conflict (and a, in
  // b's frame in the file, with it: b stays here's, in a's).
  file.sessions[1].color = "#ff0000";
  m = MergeProjects(base, here, file);
  EXPECT_EQ(m.conflicting, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(m.conflicts[1], "'b': its colour here, placed again (anchor), its colour in the file");
}

TEST(ProjectMergeTest, TheProjectsNameChangedOnBothSidesConflicts) {
  const Project base = Base();
  Project here = base, file = base;
  here.name = "first floor";
  file.name = "ground floor";
  const ProjectMerge m = MergeProjects(base, here, file);
  ASSERT_EQ(m.conflicts.size(), 1u);
  EXPECT_EQ(m.conflicts[0], "the project's name: changed here and in the file");
  EXPECT_TRUE(m.conflicting.empty());
}

}  // namespace
}  // namespace sweepscan
