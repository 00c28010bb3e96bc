// The sequence pipeline of lidar-only structure from motion (Choi et al.
// 2017, section 4; docs/sfm.md, "The sequence pipeline"):
//
//  1. initialisation: three known planes, each with designated lines of the
//     first frame (or planes fitted from two lines each in the first frame,
//     the world then being the first rig frame); the first pose by the
//     minimal solver (p3l.h) when the planes are given;
//  2. per frame: line extraction in every scan (line_extraction.h), the
//     lines moved into the rig frame by the extrinsics;
//  3. association of lines to known planes from the predicted pose
//     (constant velocity) with the point-to-plane distance gate (Eq. 38) and
//     the line-plane angle gate (Eq. 39);
//  4. pose update by robust least squares over the associated lines
//     (Gauss-Newton on SE(3)), or the minimal solver over the associated lines
//     (RANSAC over triples) when the least squares is not constrained or fails;
//  5. new planes from the accumulated unassigned lines (at least 30): plane
//     candidates from pairs of non-parallel lines, most inlier lines wins
//     (inlier bound 0.05 m);
//  6. joint refinement of all poses and planes (Eq. 40, refine.h, Ceres).
//
// Frames: scans with the same time stamp (within 1 us) form one frame with
// one rig pose (a rig whose lidars scan together). A pose is
// x_world = R x_rig + t.
#ifndef SWEEPSCAN_CORE_SFM_SEQUENCE_H_
#define SWEEPSCAN_CORE_SFM_SEQUENCE_H_

#include <Eigen/Core>
#include <array>
#include <vector>

#include "core/common/status.h"
#include "core/sfm/line_extraction.h"
#include "core/sfm/p3l.h"

namespace sweepscan::sfm {

// One 2D scan: points in the lidar's scan plane (lidar x, y; the lidar
// frame's z = 0), in scan order, NaN for dropouts.
struct Scan {
  double time_s = 0.0;
  int lidar = 0;
  std::vector<Eigen::Vector2d> points;
};

// A line of the first frame, designated by the index of the extracted line
// in that lidar's first scan (`line` >= 0), or else by a point of the scan
// plane near it (the extracted line whose supporting samples pass nearest).
struct InitLineRef {
  int lidar = 0;
  int line = -1;
  Eigen::Vector2d near = Eigen::Vector2d::Zero();
};

struct InitPlane {
  bool known = false;  // `plane` given in the world frame
  WorldPlane plane;
  std::vector<InitLineRef> lines;
};

// Either all three planes known (world = the planes' frame; the first pose
// by the minimal solver; gauge: the three planes fixed), or none (world =
// first rig frame; each plane fitted from at least two non-parallel lines
// of the first frame; gauge: the first pose fixed).
struct SequenceInit {
  std::array<InitPlane, 3> planes;
};

struct SequenceOptions {
  LineExtractionOptions lines;
  // Association gates (Eq. 38-39), from the predicted pose: every point of
  // the line (its two extreme points and centroid) within `distance` of the
  // plane, and the line within `angle` of lying in the plane. A second pass
  // after the pose update uses the tight gates.
  double assoc_distance_m = 0.10;
  double assoc_angle_deg = 5.0;
  double assoc_tight_distance_m = 0.05;
  double assoc_tight_angle_deg = 2.0;
  // A line must also lie within the plane's seen extent grown by this.
  double extent_margin_m = 0.6;
  // Pose update: Huber threshold of the per-line RMS distance (m), iterations.
  double huber_m = 0.02;
  int pose_iterations = 6;
  // New planes (section 4): candidates once this many unassigned lines are
  // waiting, inlier bound, least inliers, line pairs tried per search.
  int new_plane_min_lines = 30;
  double new_plane_inlier_m = 0.05;
  int new_plane_min_inliers = 12;
  int new_plane_min_frames = 4;       // inliers from at least this many frames
  double new_plane_min_pair_angle_deg = 10.0;
  int new_plane_max_pairs = 400;
  int unassigned_max_age_frames = 120;  // older unassigned lines are dropped
  // Joint refinement (Eq. 40): passes (re-associating every frame with the
  // refined poses between passes); 0 skips it.
  int refine_passes = 2;
  double refine_huber_m = 0.02;
  int refine_max_iterations = 50;
  int threads = 2;
  uint64_t seed = 1;
};

// A line-plane observation (rig frame), in the compact form that Eq. 40
// needs: for the line's N samples with centroid c, principal direction u and
// spread sigma^2 = lambda_max / N along u,
//   (1/N) sum_k (n . (R p_k + t) + d)^2
//     = (n . (R c + t) + d)^2 + sigma^2 (n . R u)^2 + (noise across the line),
// so two residuals per line are exact for the point-to-plane cost.
struct LineObs {
  int frame = 0;
  int plane = -1;  // -1: unassigned
  int scan = 0;    // index into the input scans
  int line = 0;    // index of the line within its scan's extraction
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();   // rig frame
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // rig frame, unit
  double sigma = 0.0;                                    // spread along the line (m)
  double half_length = 0.0;                              // half the extent (m)
  int count = 0;                                         // supporting samples
};

struct FoundPlane {
  WorldPlane plane;
  bool initial = false;   // one of the three initial planes
  int first_frame = 0;    // frame at which it was initialised / found
  int observations = 0;   // lines assigned to it (after refinement)
  int frames = 0;         // distinct frames that see it
  Eigen::Vector3d extent_min = Eigen::Vector3d::Constant(1e300), extent_max = Eigen::Vector3d::Constant(-1e300);
};

struct RefineSummary {
  int passes = 0;
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  double seconds = 0.0;  // wall time of the Ceres solves
  int residual_blocks = 0;
};

struct SequenceResult {
  std::vector<double> frame_times_s;
  std::vector<std::vector<int>> frame_scans;  // input scan indices per frame
  std::vector<Rigid3d> tracked;               // world_from_rig, before refinement
  std::vector<Rigid3d> poses;                 // world_from_rig, refined (= tracked if no refinement)
  std::vector<FoundPlane> planes;
  std::vector<LineObs> lines;                 // every extracted line, with its final plane
  bool gauge_first_pose = false;              // true: world = first rig frame
  int lines_total = 0, lines_assigned = 0;
  int frames_p3l = 0;                         // frames placed by the minimal solver (relocalisation)
  int frames_weak = 0;                        // frames whose least squares was rank-deficient
  RefineSummary refine;
  double tracking_seconds = 0.0;
};

// The rig-frame points of a scan (NaNs skipped) at a pose: the cloud.
std::vector<Eigen::Vector3d> ScanPointsInWorld(const Scan& scan, const Rig& rig, const Rigid3d& world_from_rig);

Status RunSequence(const std::vector<Scan>& scans, const Rig& rig, const SequenceInit& init,
                   const SequenceOptions& options, SequenceResult* result);

// Association test (Eq. 38-39) of a line (rig frame) at a pose: the largest
// point-to-plane distance of the line's extreme points and centroid, and the
// sine of the angle between the line and the plane. Exposed for tests.
void LinePlaneDistance(const LineObs& line, const Rigid3d& world_from_rig, const WorldPlane& plane,
                       double* max_distance_m, double* sin_angle);

// Robust least-squares pose from lines on known planes (Gauss-Newton on
// SE(3) from `*pose`, Huber weights, Eq. 40 restricted to one pose). Returns
// the smallest eigenvalue of the normalised 6x6 information matrix (0 when
// the lines do not fix the pose); a weak direction stays at the start pose.
double UpdatePose(const std::vector<const LineObs*>& lines, const std::vector<WorldPlane>& planes,
                  const SequenceOptions& options, Rigid3d* pose);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_SEQUENCE_H_
