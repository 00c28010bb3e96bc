// A project: many sessions of one building in one frame (issue 29).
//
// A project file (docs/project-format.md, "sweepscan-project" version 1) is
// a small JSON document beside the session folders. It lists each session
// with the calibration to build its cloud with and its pose in the
// project's frame, project_from_session, plus the evidence of how that pose
// was found (the method, the reference session, the residual, the overlap,
// the 6x6 covariance, picked pairs, a direction the data left free). The
// cloud data stays in the sessions: the project never copies points.
//
// A session's own frame is the robot's pose at its first record (x forward,
// y left, z up, the floor under the wheels at z = 0): where the operator put
// the robot down. It is the same frame whatever the session's meta.json says
// about a simulated start or an imported odometry frame, so that a project
// never depends on knowledge a real robot does not have. The first session
// added is the anchor (project_from_session = identity) unless another is
// marked; every other session is unplaced until registration places it.
//
// Loading is strict, as for scenarios: unknown keys, wrong types, a
// non-unit quaternion or a duplicate id are refused with the file and the
// JSON path. Saving is atomic (a crash never leaves half a project).
//
// Pure data and file I/O; no threads of its own. Callers serialise access.
#ifndef SWEEPSCAN_CORE_PROJECT_PROJECT_H_
#define SWEEPSCAN_CORE_PROJECT_PROJECT_H_

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

constexpr int kProjectFormatVersion = 1;
// The farthest a session may be placed from the project's origin, per axis:
// a cloud's float positions keep whole millimetres within 8 192 m.
constexpr double kMaxProjectOffsetM = 8000.0;
// The file name suffix the app and the CLI propose for project files.
inline constexpr const char* kProjectSuffix = ".sweepscan-project";

// One pair picked by the operator: the same physical point in the session
// (source) and in the reference (target), each in its own session frame.
struct PickedPair {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
};

// How a session's pose was found, kept so that a reviewer can judge it.
struct RegistrationEvidence {
  // "anchor", "manual" (typed in), "pairs", "planes", "planes+icp",
  // "pairs+icp", "icp".
  std::string method;
  std::string reference;  // id of the session it was aligned to ("" for the anchor)
  double rms_m = 0.0;     // residual RMS of the final stage (m)
  double overlap = 0.0;   // share of the session's points matched in the reference, [0, 1]
  uint64_t correspondences = 0;
  int iterations = 0;
  // Covariance of the pose's error in the reference's frame, se(3) order
  // (rotation x y z in rad, translation x y z in m), row-major; zero when
  // unknown.
  std::array<double, 36> covariance{};
  // The data leave the pose free along this unit direction (a corridor);
  // zero when fully constrained.
  Eigen::Vector3d free_direction = Eigen::Vector3d::Zero();
  std::vector<PickedPair> pairs;
  std::string time_utc;  // when it was computed, ISO 8601
  // The poses the two clouds were built with when it was measured, "ekf"
  // or "odometry" (absent in a file: "ekf"). Drawn with other poses, the
  // clouds differ from the ones registered, and the placement need not hold.
  std::string pose_source = "ekf";
  // 1-sigma of the rotation (rad) and translation (m) from the covariance:
  // the square roots of the largest eigenvalues of its two diagonal blocks.
  double SigmaRotation() const;
  double SigmaTranslation() const;
};

struct ProjectSession {
  std::string id;    // unique in the project; the session folder's name by default
  std::string path;  // the session folder, relative to the project file's folder (or absolute)
  // The calibration to build its cloud with; none: the session's own
  // meta.json calibration.
  std::optional<MountingError> calibration;
  // Pose in the project's frame; none: not placed yet.
  std::optional<Rigid3d> project_from_session;
  RegistrationEvidence registration;
  bool visible = true;
  std::string color = "#1f77b4";  // #rrggbb, the app's colour for "colour by session"
  // The recording added: its meta.json's created_utc then ("" in files of
  // an older sweepscan, and for sessions without one). A folder that later
  // holds another recording (the room recorded again under the same name)
  // is refused by its cloud's loaders (hardware/station/session_cloud.h):
  // the placements were measured on the first.
  std::string recorded_utc;
};

struct Project {
  std::string name;
  std::string description;  // free text: the building, the floor, the operator
  std::vector<ProjectSession> sessions;

  // Index of the session with this id, or -1.
  int Find(const std::string& id) const;
  // The anchor: the session placed with method "anchor", or -1.
  int Anchor() const;
  // Adds a session folder (path as given; relative paths are relative to
  // the project's folder). The id is the folder's name without
  // ".sweepscan", made unique with a suffix; the first session becomes the
  // anchor. Refuses a path already in the project, however written (relative
  // or absolute, a trailing separator; resolved against `project_file`'s
  // folder when given), and a name that is not UTF-8.
  Status AddSession(const std::string& path, ProjectSession** added,
                    const std::string& project_file = "");
  // Removes it; refuses the anchor while other sessions are placed, and a
  // session others are placed against (their reference). When the anchor
  // goes and (unplaced) sessions remain, the first of them becomes the
  // anchor; its id is then set in `new_anchor` (optional).
  Status RemoveSession(const std::string& id, std::string* new_anchor = nullptr);
  // Session `id` was placed again and moved by `delta` (its new pose times
  // the old one's inverse). The sessions placed against it, and those placed
  // against them, were measured relative to it: they move by `delta` too.
  // Returns their ids.
  std::vector<std::string> MoveDependants(const std::string& id, const Rigid3d& delta);
  // Whether `id`'s pose rests on `on`'s: `on` is its reference, or its
  // reference's, and so on. Such a session cannot be what `on` is placed
  // against: MoveDependants would move it with `on`, and the two would
  // refer to each other.
  bool PlacedThrough(const std::string& id, const std::string& on) const;
  // Makes session `id` the anchor: the project's frame becomes its start
  // pose (docs/project-format.md, "Changing the anchor"). Every placement
  // is re-expressed in that frame, project_from_session' =
  // inverse(project_from_id) * project_from_session, so that every point
  // stays where it was relative to every other. The placements on the
  // chain of references from `id` to the anchor (or to a session placed by
  // hand without one) are turned round: each of those sessions is then
  // placed against the one that was placed against it, by the same
  // measurement inverted (the covariance carried into the new reference's
  // frame by the adjoint, the free direction rotated into it, the pairs'
  // source and target swapped; rms, overlap, counts, time and pose source
  // kept as measured). `id`'s own evidence thus goes to its old reference.
  // The old anchor, when it is not on that chain, is held where it is by
  // hand (manual, no reference). Every other placement keeps its reference
  // and its evidence, which are relative to the reference and unchanged.
  // Refuses an unknown id, `id` unplaced while any session but the anchor
  // is placed (its frame is not known relative to theirs; with nothing
  // else placed the old anchor becomes unplaced instead), and a session
  // that would then lie beyond kMaxProjectOffsetM of the new origin. Nothing
  // changes when it refuses, or when `id` is the anchor already.
  struct AnchorChange {
    std::string old_anchor;            // "" if there was none (or `id` is it)
    bool old_anchor_unplaced = false;  // nothing else was placed: not placed now
    // The sessions whose placement was turned round, from `id` outwards.
    std::vector<std::string> reversed;
  };
  Status ChangeAnchor(const std::string& id, AnchorChange* change = nullptr);
};

// Makes `session` the anchor: the identity, aligned to nothing.
void MakeAnchor(ProjectSession* session);

// The distinct colours new sessions get in turn (Tableau 10).
std::string SessionColor(size_t index);

// The folder `path` resolves against: the project file's folder.
std::string ProjectDirectory(const std::string& project_file);
// Whether `s` is UTF-8, as every string of a project file (JSON) must be.
bool IsUtf8Text(const std::string& s);
// A session's folder as an absolute (or working-directory-relative) path.
std::string ResolveSessionPath(const std::string& project_file, const ProjectSession& session);

// `repairs` (optional): a reference that places a session against itself,
// against an unplaced session or in a loop (which sweepscan before
// 2026-11-29 could save) is refused without it; with it, the reference is
// dropped (the session keeps its pose, now held as placed by hand: method
// "manual", the old measurement's numbers cleared) and what was done is
// said there, so that such a project opens and can be aligned again. A
// project with sessions but no anchor and none placed (what removing the
// anchor left before 2026-12) gets its first session as the anchor, said
// there too.
Status LoadProject(const std::string& path, Project* project,
                   std::vector<std::string>* repairs = nullptr);
Status SaveProject(const std::string& path, const Project& project);
Status ProjectFromJson(const std::string& text, const std::string& source, Project* project,
                       std::vector<std::string>* repairs = nullptr);
std::string ProjectToJson(const Project& project);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_PROJECT_PROJECT_H_
