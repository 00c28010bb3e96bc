// The minimal solver of lidar-only structure from motion (Choi, Bok, Kim,
// Shim, Kweon, "Structure-From-Motion in 3D Space Using 2D Lidars", Sensors
// 2017, 17(2):242, section 3): the 6-DoF pose of a rig of 2D lidars from
// three scan lines that lie on three known world planes ("P3L"). The math,
// with the paper's equation numbers, is in docs/sfm.md.
//
// Conventions: a world plane is n . x + d = 0 with |n| = 1 and n pointing to
// the plane's back side (away from where the sensor can stand), so the
// sensor origin t satisfies n . t + d < 0 (Eq. 37). A pose is
// x_world = R x_rig + t.
//
// Rig-aware: each line names the lidar that saw it; `Rig` holds every
// lidar's rig_from_lidar, so lines from different lidars mix freely (a rig
// of one lidar has rig = lidar).
#ifndef SWEEPSCAN_CORE_SFM_P3L_H_
#define SWEEPSCAN_CORE_SFM_P3L_H_

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"

namespace sweepscan::sfm {

struct WorldPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, pointing to the back side
  double d = 0.0;
  double SignedDistance(const Eigen::Vector3d& p) const { return normal.dot(p) + d; }
};

// A scan line in one lidar's frame: the points that support it (at least
// two; the minimal problem uses two points per line).
struct LineObservation {
  std::vector<Eigen::Vector3d> points;
  int lidar = 0;
};

struct Rig {
  std::vector<Rigid3d> rig_from_lidar{Rigid3d::Identity()};
};

// A line expressed in the rig frame: a point, a unit direction, and the
// supporting points (rig frame).
struct RigLine {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  std::vector<Eigen::Vector3d> points;
};

// Line-plane pair: line `line` lies on plane `plane`.
struct Correspondence {
  LineObservation line;
  WorldPlane plane;
};

struct PoseCandidate {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  // max_i |n_i^T R u_i| after polishing (0 for an exact solution of Eq. 10-12).
  double rotation_residual = 0.0;
  // RMS of the point-to-plane distances of the three lines' points (m).
  double point_rms = 0.0;
  // Smallest singular value of the Jacobian of the three rotation
  // constraints (d r_i / d rotation, rows (R u_i x n_i)^T): near zero, the
  // lines pin the rotation only to second order (e.g. a scan plane
  // perpendicular to both a floor and a wall) and the pose is ill-conditioned.
  double conditioning = 0.0;
  // Ranking score (smaller is better): see P3lOptions.
  double score = 0.0;
};

struct P3lOptions {
  // Degeneracy thresholds (sines of angles).
  double parallel_tolerance = 1e-6;
  // A candidate is kept when its rotation residual after polishing is below
  // this. Noise-free problems polish to ~1e-16; with noisy lines a real
  // double root can split into a complex pair whose nearest real rotation
  // satisfies the constraints only approximately (sine of the angle
  // between line and plane), so the default tolerates 1e-3 (0.06 deg).
  double max_rotation_residual = 1e-3;
  // Apply the physical constraint n . t + d < 0 (Eq. 37).
  bool require_in_front = true;
  // Candidates whose rotations differ by less than this (Frobenius) are merged.
  double duplicate_tolerance = 1e-7;
};

// Disambiguation (section 3, end): further correspondences and/or the
// previous pose. Candidates are ranked by the RMS point-to-plane distance of
// the extra correspondences' points when there are any, else by the distance
// to the previous pose (rotation angle in rad + translation in m) when given,
// else by the residual of the minimal problem.
struct Disambiguation {
  // Further lines (rig frame) and their planes, index by index.
  std::vector<RigLine> extra_lines;
  std::vector<WorldPlane> extra_planes;
  bool has_previous = false;
  Eigen::Matrix3d previous_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d previous_t = Eigen::Vector3d::Zero();
};

// Line in the rig frame from an observation: the points mapped through
// rig_from_lidar, the direction by total least squares (principal axis).
// Fails (with why) for an unknown lidar, fewer than two points, coincident
// points or non-finite coordinates.
Status ToRigLine(const LineObservation& obs, const Rig& rig, RigLine* out);

// Checks the minimal problem for degeneracy: non-finite values, a zero
// normal, parallel planes, three normals sharing a direction (translation
// along it undetermined), parallel lines (both would run along the
// intersection of their planes). Normalises the normals (scaling d).
Status CheckMinimalProblem(std::array<WorldPlane, 3>* planes, const std::array<RigLine, 3>& lines,
                           const P3lOptions& options = {});

// All candidate poses for three lines (rig frame) on three planes, ranked
// best first. Returns a Status error for a degenerate problem; an empty
// `candidates` means the problem is consistent with no pose.
Status SolveP3l(std::array<WorldPlane, 3> planes, const std::array<RigLine, 3>& lines,
                const P3lOptions& options, const Disambiguation& disambiguation,
                std::vector<PoseCandidate>* candidates);

// Convenience: three correspondences from a rig.
Status SolveP3l(const std::array<Correspondence, 3>& correspondences, const Rig& rig,
                const P3lOptions& options, const Disambiguation& disambiguation,
                std::vector<PoseCandidate>* candidates);

// Only the rotations (Eq. 4-35): every R with n_i^T R u_i = 0, i = 1..3,
// polished, unranked. `u` are unit line directions in the rig frame, `n`
// unit normals. Exposed for tests and the benchmark.
std::vector<Eigen::Matrix3d> SolveP3lRotations(const std::array<Eigen::Vector3d, 3>& n,
                                               const std::array<Eigen::Vector3d, 3>& u,
                                               double max_residual = 1e-6);

// Translation by least squares from the point-on-plane equations (Eq. 36):
// n_i^T (R p + t) + d_i = 0 for every point p of line i.
Eigen::Vector3d SolveTranslation(const Eigen::Matrix3d& R, const std::array<WorldPlane, 3>& planes,
                                 const std::array<RigLine, 3>& lines);

// See PoseCandidate::conditioning.
double RotationConditioning(const std::array<Eigen::Vector3d, 3>& n, const std::array<Eigen::Vector3d, 3>& u,
                            const Eigen::Matrix3d& R);

// Rotation angle of R_a^T R_b (rad).
double RotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_P3L_H_
