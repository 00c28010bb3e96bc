// Places lidar samples in the world: the spine of the pipeline.
//
// For sample i of a scan, taken at its own time t_i (Miao et al. 2022,
// Eq. 11-14, with per-sample deskew):
//   p_W = world_from_body(t_i) * body_from_lidar(geometry, calibration) * p_L(rho_i, theta_i)
// with p_L from Eq. 1 and world_from_body(t_i) interpolated from the pose
// buffer. Without deskew every sample of the scan uses the pose at the scan's
// first sample, as a naive pipeline that stamps a whole scan once would.
// An X4 revolution lasts about 0.14 s: at 0.2 m/s that is 3 cm of travel,
// and while turning in place at 0.5 rad/s it sweeps a wall 5 m away by 35 cm.
#ifndef SWEEPSCAN_CORE_CLOUD_ASSEMBLER_H_
#define SWEEPSCAN_CORE_CLOUD_ASSEMBLER_H_

#include <string>

#include "core/cloud/cloud.h"
#include "core/pose/pose_buffer.h"
#include "core/pose/pose_estimator.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"

namespace sweepscan {

struct AssemblyOptions {
  bool deskew = true;
  double min_range_m = 0.12;  // X4 specification
  double max_range_m = 10.0;
  // Round positions to the cloud's 1 mm grid (cloud.h), as every cloud the
  // app and the CLI show or write is. Off only for scan matching's own
  // points (core/sfm), which never leave it.
  bool snap_to_grid = true;

  bool IsValid(std::string* error) const;
};

struct AssemblyStats {
  size_t samples_in = 0;
  size_t points_out = 0;
  size_t invalid_range = 0;  // zero, or outside [min, max]
  size_t no_pose = 0;        // sample time outside the pose buffer
};

class Assembler {
 public:
  Assembler(const AssemblyOptions& options, const Rigid3d& body_from_lidar, PoseSource source)
      : options_(options), body_from_lidar_(body_from_lidar), source_(source) {}

  // Appends the scan's points to `out`. Samples whose time the pose buffer
  // does not cover are counted and skipped; a live caller waits until
  // poses.latest() >= scan.end_time() before calling.
  void AddScan(const LidarScan& scan, const PoseBuffer& poses, PointChunks* out);
  // The same appended to a plain vector (a streaming reader that hands the
  // points on and clears it).
  void AddScan(const LidarScan& scan, const PoseBuffer& poses, CloudChunk* out);

  const AssemblyStats& stats() const { return stats_; }

 private:
  template <typename Emit>
  void Place(const LidarScan& scan, const PoseBuffer& poses, Emit&& emit);

  AssemblyOptions options_;
  Rigid3d body_from_lidar_;
  PoseSource source_;
  AssemblyStats stats_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_ASSEMBLER_H_
