// The simulated rigs of core/sim/rig.h as inputs of the sequence pipeline,
// and its errors against ground truth (tests, `sweepscan-cli sfm
// --rig-scenario`, the benchmark).
#ifndef SWEEPSCAN_CORE_SFM_RIG_SCENARIO_H_
#define SWEEPSCAN_CORE_SFM_RIG_SCENARIO_H_

#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/sfm/sequence.h"
#include "core/sim/rig.h"

namespace sweepscan::sfm {

std::vector<Scan> ScansFromRigRun(const sim::RigRun& run);
Rig RigFromRigRun(const sim::RigRun& run);

// Stands in for the operator who picks three planes and their lines in the
// first frame: the lines of the first frame whose samples (at least 90 %)
// truly hit one box face, grouped by face; of the faces with lines (at
// least two non-parallel ones when the planes are not given), the three
// whose normals are the most independent. `give_planes`: the planes are
// given (their true equations; the world is the truth's) or not (world =
// first rig frame). `chosen` receives the scene faces' labels.
Status InitFromTruth(const sim::RigRun& run, const sim::Scene& scene, bool give_planes,
                     const LineExtractionOptions& lines, SequenceInit* init, std::vector<std::string>* chosen);

// Named scenarios: "room" (650 frames, two lidars: 1300 scans) and
// "stairwell" (1750 frames: 3500 scans).
Status RigScenarioByName(const std::string& name, sim::RigSimConfig* config);

struct SequenceErrors {
  double rot_mean_deg = 0, rot_max_deg = 0, trans_mean_m = 0, trans_max_m = 0;
  int planes_matched = 0;       // found planes within 2 deg and 5 cm of a true face's plane
  int truth_planes_found = 0;   // distinct true face planes matched
  double plane_angle_mean_deg = 0, plane_offset_mean_m = 0;  // of the matched planes
  std::vector<std::string> matched_labels;  // the true faces matched, "box/face"
};

// Pose errors of `poses` (world_from_rig per frame) against the truth; with
// the first-pose gauge, the estimate is first carried into the truth's
// world by the true first pose. Planes: `planes` against every face of the
// scene (coplanar faces count once).
SequenceErrors EvaluateSequence(const std::vector<Rigid3d>& poses, const std::vector<FoundPlane>& planes,
                                bool gauge_first_pose, const sim::RigRun& run, const sim::Scene& scene);

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_RIG_SCENARIO_H_
