// The paper's synthetic protocol for the minimal solver (Choi et al. 2017,
// section 5.1): random poses (rotation up to 50 deg, translation up to 4 m
// per axis), random planes within 5 m of the origin, line points drawn in
// [-4, 4] m, uniform noise of a given width on the points in the sensor
// frame. Used by the tests, `sweepscan-cli p3l --protocol` and the benchmark.
#ifndef SWEEPSCAN_CORE_SFM_SYNTHETIC_H_
#define SWEEPSCAN_CORE_SFM_SYNTHETIC_H_

#include <random>
#include <vector>

#include "core/sfm/p3l.h"

namespace sweepscan::sfm {

struct SyntheticOptions {
  double max_rotation_deg = 50.0;
  double max_translation_m = 4.0;   // per axis
  double max_plane_distance_m = 5.0;
  double point_box_m = 4.0;         // line points' world coordinates within [-4, 4]
  double noise_width_m = 0.0;       // uniform in [-w/2, w/2] per coordinate, sensor frame
  int points_per_line = 2;
  int extra_correspondences = 1;    // a fourth line for disambiguation
  double min_plane_angle_deg = 15.0;  // planes at least this far from parallel / sharing a direction
};

struct SyntheticProblem {
  std::array<WorldPlane, 3> planes;
  std::array<RigLine, 3> lines;      // noisy, sensor (= rig) frame
  Disambiguation disambiguation;     // the extra correspondences
  Eigen::Matrix3d R_true = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_true = Eigen::Vector3d::Zero();
};

SyntheticProblem MakeSyntheticProblem(const SyntheticOptions& options, std::mt19937_64* rng);

struct TrialError {
  bool solved = false;   // at least one candidate
  double rotation_deg = 0.0;
  double translation_m = 0.0;
};

// One noise level of the protocol. `closest`: the candidate nearest the
// truth (the solver's accuracy, as the paper plots it); `ranked`: the
// candidate ranked first by the extra correspondence (what a user gets).
struct ProtocolRow {
  double noise_width_m = 0.0;
  int trials = 0;
  int solved = 0;
  int truth_found_1e6 = 0;  // true pose among the candidates to 1e-6
  double rot_mean_deg = 0, rot_std_deg = 0, trans_mean_m = 0, trans_std_m = 0;        // closest
  double ranked_rot_mean_deg = 0, ranked_rot_std_deg = 0, ranked_trans_mean_m = 0,
         ranked_trans_std_m = 0;                                                      // ranked
  double rot_median_deg = 0, trans_median_m = 0;                                      // closest
  double mean_candidates = 0;
};

ProtocolRow RunProtocol(const SyntheticOptions& options, int trials, uint64_t seed);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_SYNTHETIC_H_
