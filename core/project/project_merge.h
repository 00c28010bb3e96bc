// Merging two edits of one project file (docs/project-format.md,
// "Concurrent edits"): the project as this program holds it ("here") and
// as another program saved it meanwhile ("the file"), both edited from the
// same "base" (the file as it was read or last written here). The desktop
// app's Save merges so, as `sweepscan-cli project align` puts its
// placements onto what another program saved meanwhile.
//
// A three-way merge by session id: a session changed on one side only
// takes that side's state (added, removed or edited); one edited on both
// sides merges field by field (its folder, calibration, placement,
// visibility and colour each from the side that changed it), and is a
// conflict when both changed one of them differently or one side removed it. So are placements that
// would no longer hold together in the merge: a session placed against a reference the other side
// removed, unplaced or placed again (the session's pose relative to its reference is not what was
// measured), and a placement made on one side while the other changed the anchor (it is in the old
// frame). The project's name and description merge likewise.
//
// Pure data; no I/O.
#ifndef SWEEPSCAN_CORE_PROJECT_PROJECT_MERGE_H_
#define SWEEPSCAN_CORE_PROJECT_PROJECT_MERGE_H_

#include <string>
#include <vector>

#include "core/project/project.h"

namespace sweepscan {

struct ProjectMerge {
  // The merge; when there are conflicts, here's side of them.
  Project merged;
  // Sessions (by id) whose state the merge takes, wholly or in part, from
  // the file: what the other program changed, which this side did not.
  std::vector<std::string> from_file;
  // One a conflicting session (or "the project's name"/"description"):
  // "ID: why", in the file's session order. Empty: `merged` is the merge.
  std::vector<std::string> conflicts;
  // The ids of the conflicting sessions, as in `conflicts`.
  std::vector<std::string> conflicting;
};

ProjectMerge MergeProjects(const Project& base, const Project& here, const Project& file);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_PROJECT_PROJECT_MERGE_H_
