// The raw samples a calibration re-projects (Miao et al. 2022, Eq. 1, 11-14).
//
// Model. Sample i (range rho_i, scan angle theta_i, time t_i) lands at
//   p_W(c) = world_from_body(t_i) * body_from_lidar(g, c) * p_L(rho_i, theta_i)   (Eq. 1, 11-14)
// with body_from_lidar = [Rz(alpha) Ry(beta) Rx(gamma) | (l1, 0, h)] (Eq. 13)
// and c = (alpha, beta, gamma) the mounting error. The calibration re-projects
// raw samples for every candidate c; it never moves cloud points.
//
// Pure functions and values, no globals; may run on any thread.
#ifndef SWEEPSCAN_CORE_CALIBRATION_SAMPLES_H_
#define SWEEPSCAN_CORE_CALIBRATION_SAMPLES_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/calibration/passes.h"
#include "core/common/status.h"
#include "core/pose/pose_buffer.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"

namespace sweepscan {

// A raw sample's address in the recording as decoded: its revolution and
// its position in it as received. Unique within one decode, but a lost X4
// packet (40 samples) renumbers the later beams of its revolution, so a file
// that must name the same sample in another decode of the bytes names it by
// SampleName instead.
struct SampleRef {
  uint32_t scan = 0;
  uint16_t beam = 0;
  bool operator==(const SampleRef& o) const { return scan == o.scan && beam == o.beam; }
};

// A raw sample's name that survives lost packets (docs/calibration.md,
// "Pairs file"): its time stamp, which the decoder derives from the packet's
// own receive time and the sample clock, never from its position, with what
// the sample measured as a check that the recording is decoded with the same
// timing (a change of the session's serial settings shifts every time stamp).
struct SampleName {
  int64_t time_ns = 0;
  // The sample's range and scan angle as decoded; NaN: not checked.
  double range_m = std::numeric_limits<double>::quiet_NaN();
  double theta_rad = std::numeric_limits<double>::quiet_NaN();
};

// What the solver re-projects: a point in the lidar frame (Eq. 1 for a real
// sample, any point for a virtual one such as a fitted corner) and the body
// pose at the sample's own time.
struct LidarObservation {
  SampleRef ref;
  int64_t time_ns = 0;
  Eigen::Vector3d p_lidar = Eigen::Vector3d::Zero();
  Rigid3d world_from_body;
  // The raw measurement p_lidar came from (a real sample; 0 for a virtual one).
  float range_m = 0.0f;
  float theta = 0.0f;
};

// p_W(c) = world_from_body * body_from_lidar(g, c) * p_lidar.
Eigen::Vector3d ProjectObservation(const LidarObservation& o, const RobotGeometry& geometry,
                                   const MountingError& calibration);

// The valid raw samples of a recording with their interpolated poses,
// addressable by (scan, beam) and by time stamp. Samples without a pose or
// out of range are left out (as the assembler leaves them out).
class SampleStore {
 public:
  SampleStore() = default;
  SampleStore(const SensorLog& log, const PoseBuffer& poses, double min_range_m = 0.12,
              double max_range_m = 10.0);

  const std::vector<LidarObservation>& observations() const { return observations_; }
  // A copy whose poses' positions are scaled about `centre`: t_WB -> centre
  // + scale (t_WB - centre) (the automatic mode's path scale, automatic.h).
  SampleStore ScaledAbout(const Eigen::Vector3d& centre, double scale) const;
  // Error if the recording has no such valid sample.
  Status Find(const SampleRef& ref, LidarObservation* out) const;
  // The valid sample with exactly this time stamp; error if there is none
  // (with the nearest one's distance in time), if two samples share it, or
  // if its range or angle differs from the name's (by more than 0.5 mm, the
  // X4's range unit, resp. 1e-4 rad, a hundredth of the beam spacing).
  Status Find(const SampleName& name, LidarObservation* out) const;
  // Whether samples of ref.scan were lost before ref.beam (a gap of more
  // than 20 sample periods, half an X4 packet, between two consecutive
  // samples of the revolution, the period being the revolution's median
  // spacing): then (scan, beam) may name another sample than in a decode
  // without the loss. *gap_s: the first such gap.
  bool LostSamplesBefore(const SampleRef& ref, double* gap_s) const;
  // Indices of the observations whose time lies in the window.
  std::vector<size_t> InWindow(const PassWindow& window) const;
  // Nearest observation of the window to `world` under `calibration`;
  // error if the window is empty.
  Status Nearest(const PassWindow& window, const Eigen::Vector3d& world,
                 const RobotGeometry& geometry, const MountingError& calibration,
                 LidarObservation* out) const;

 private:
  std::vector<LidarObservation> observations_;  // time order
  bool time_sorted_ = true;  // Strictly increasing times (binary search by time).
  std::unordered_map<uint64_t, size_t> by_ref_;
  // Per revolution with a loss: the beam after the first gap, and the gap (ns).
  std::unordered_map<uint32_t, std::pair<uint16_t, int64_t>> first_loss_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_SAMPLES_H_
