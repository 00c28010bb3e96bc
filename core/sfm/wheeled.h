// Lidar-only structure from motion for the wheeled scanner (issue 12;
// docs/sfm.md, "The wheeled scanner"): the vertical X4's scans placed by the
// planes they cross, with the wheel + IMU EKF (or odometry) as the motion
// prior.
//
// Why a prior at all: the X4 scans a vertical plane across the driving
// direction, so one scan of a room crosses the floor, the ceiling and the
// two side walls, planes of two normal directions only. Such a scan fixes
// the height, the lateral offset and the roll; the pitch and the yaw only
// to second order (the cut through two parallel walls is W / cos(yaw) wide);
// the position along the walls not at all. The paper's minimal solver
// (three planes of independent normals) is degenerate on it, and its
// constant-velocity tracking drifts along the unobserved directions. So the
// prior predicts every scan's pose and its relative motion between scans
// weighs in the pose update and in the joint refinement (sequence.h,
// MotionPrior); the planes correct what they observe and the prior keeps
// the rest.
//
// Each scan is one frame, at the middle of its revolution (~140 ms): its
// samples are deskewed to that instant with the prior's motion (the
// Assembler's per-sample deskew, relative to the middle pose), lines are
// found in the scan plane and fitted to the deskewed 3D samples.
#ifndef SWEEPSCAN_CORE_SFM_WHEELED_H_
#define SWEEPSCAN_CORE_SFM_WHEELED_H_

#include <vector>

#include "core/cloud/assembler.h"
#include "core/common/status.h"
#include "core/pose/pose_buffer.h"
#include "core/pose/pose_estimator.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "core/sfm/sequence.h"
#include "core/sim/scene.h"

namespace sweepscan::sfm {

// The sequence options for the wheeled scanner: new planes from pairs of
// parallel lines too (driving straight, every floor line is parallel to
// every other one).
SequenceOptions WheeledSequenceOptions();

// The motion prior's weights for a prior source: the EKF's tilt (IMU
// gravity) and yaw (IMU yaw) also as absolute terms (0.3 deg, 0.6 deg per
// scan), odometry's tilt only (it assumes a level floor; its yaw drifts).
MotionPrior WheeledMotionPrior(PoseSource prior_source);

struct WheeledSfmOptions {
  SequenceOptions sequence = WheeledSequenceOptions();
  MotionPrior motion = WheeledMotionPrior(PoseSource::kEkf);  // the per-frame poses are filled in
  AssemblyOptions assembly;   // range limits for the deskew
  int min_scan_samples = 50;  // scans with fewer valid samples are skipped
};

struct WheeledSfmResult {
  SequenceResult sequence;      // one frame per scan; rig = body
  std::vector<uint32_t> scans;  // LidarScan::index of each frame
  std::vector<Rigid3d> prior;   // the prior's world_from_body at each frame
  // Corrected world_from_body at every time of the prior: the correction
  // C_k = X_k P_k^-1 of the frames, interpolated (nlerp) between them and
  // held before the first and after the last, applied to the prior,
  // C(t) P(t); a scan is deskewed with it like with any pose source.
  PoseBuffer poses;
};

// `prior`: world_from_body (EKF or odometry). `init`: none (every
// InitPlane's lines empty: planes found on the way) or three known planes
// with lines of the first scan (lidar 0; `near` in the scan plane,
// (r cos theta, r sin theta) of docs/sfm.md).
Status RunWheeledSfm(const std::vector<LidarScan>& scans, const Rigid3d& body_from_lidar, const PoseBuffer& prior,
                     const SequenceInit& init, const WheeledSfmOptions& options, WheeledSfmResult* result);

// The same from a whole log: the prior by EstimatePoses (`prior_source`:
// kEkf or kOdometry, from `start`), the scans placed by the mounting
// `calibration`.
Status WheeledSfmFromLog(const SensorLog& log, const RobotGeometry& geometry, const MountingError& calibration,
                         const Pose2d& start, PoseSource prior_source, const SequenceInit& init,
                         const WheeledSfmOptions& options, WheeledSfmResult* result);

// Stands in for the operator who picks three planes in the first scan (for
// --motion-prior none, which needs them): the three faces of `scene` on
// which most samples of the first scan with at least `min_samples` valid
// returns lie (within 1 cm, placed by the truth), as known planes, each
// with the `near` reference of its middle sample. `chosen`: the faces'
// labels.
Status WheeledInitFromTruth(const std::vector<LidarScan>& scans, const PoseBuffer& truth,
                            const Rigid3d& body_from_lidar, const sim::Scene& scene, int min_samples,
                            SequenceInit* init, std::vector<std::string>* chosen);

// Errors of per-frame poses against the truth, split the way the scanner
// sees the world: the horizontal position error along the true heading
// (`along`, what the side walls cannot see) and across it (`lateral`), the
// height, the heading (yaw) and the tilt (angle between the up axes).
struct WheeledErrors {
  int frames = 0;
  double along_mean_m = 0, along_max_m = 0, along_final_m = 0;      // |.|
  double lateral_mean_m = 0, lateral_max_m = 0, lateral_final_m = 0;
  double height_mean_m = 0, height_max_m = 0;
  double heading_mean_deg = 0, heading_max_deg = 0, heading_final_deg = 0;
  double tilt_mean_deg = 0, tilt_max_deg = 0;
  double trans_mean_m = 0, trans_max_m = 0;
};
WheeledErrors EvaluateWheeled(const std::vector<double>& times_s, const std::vector<Rigid3d>& poses,
                              const PoseBuffer& truth);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_WHEELED_H_
