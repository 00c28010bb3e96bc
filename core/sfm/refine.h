// Joint refinement of all rig poses and all planes (Choi et al. 2017,
// Eq. 40) with Ceres; the only translation unit that includes Ceres
// (refine.cc). The cost, for every line l (rig frame, centroid c, direction
// u, spread sigma, N samples) assigned to plane (n, d) and seen at pose
// (R, t):
//
//   E = sum_l N rho( (n . (R c + t) + d)^2 + sigma^2 (n . R u)^2 )     (Eq. 40)
//
// which is the sum of the squared point-to-plane distances of the line's
// samples (sequence.h, LineObs), with rho a Huber loss on the per-line RMS
// distance. Parametrisation: a unit quaternion and a translation per pose
// (EigenQuaternionManifold), a unit normal on the sphere
// (SphereManifold<3>) and an offset per plane. Gauge (the problem is
// invariant to a rigid motion of the world): either the first pose is held
// constant, or planes that fix all six degrees of freedom (three with
// independent normals: the initial planes) are. A weak prior holds each pose
// near its tracked value along directions its lines leave free; with a
// motion prior (another pose source), the relative motion of consecutive
// poses does instead.
#ifndef SWEEPSCAN_CORE_SFM_REFINE_H_
#define SWEEPSCAN_CORE_SFM_REFINE_H_

#include <cmath>
#include <vector>

#include "core/common/status.h"
#include "core/sfm/sequence.h"

namespace sweepscan::sfm {

struct RefineOptions {
  double huber_m = 0.02;
  int max_iterations = 50;
  int threads = 2;
  bool fix_first_pose = false;
  std::vector<int> fixed_planes;
  // Weak prior of each pose at its start value (0 disables): holds the
  // directions that a frame's lines leave free.
  double prior_translation_m = 1.0;
  double prior_rotation_rad = 0.3;
  // A motion prior (sequence.h; not owned, may be null): every pose takes
  // part, each pair of consecutive poses (X_{k-1}, X_k) gains the term
  //   || diag(sqrt_info_k) [2 vec(q_D^-1 q_E); t_E - t_D] ||^2,
  //   E = X_{k-1}^-1 X_k,  D = the prior's relative motion,
  // and the weak prior above is dropped (the chain holds every direction).
  // Consecutive poses then share residuals, so the poses cannot be
  // eliminated block by block (DENSE_SCHUR): the sparse Cholesky of the
  // whole system solves it (the chain is banded, the planes few).
  const MotionPrior* motion = nullptr;
  const std::atomic<bool>* cancel = nullptr;  // SequenceOptions::cancel
};

// Lines with plane < 0 are ignored. Poses indexed by LineObs::frame, planes
// by LineObs::plane; both are updated in place.
Status RefinePosesAndPlanes(const std::vector<LineObs>& lines, const RefineOptions& options,
                            std::vector<Rigid3d>* poses, std::vector<WorldPlane>* planes,
                            RefineSummary* summary);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_REFINE_H_
