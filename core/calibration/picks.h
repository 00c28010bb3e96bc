// Picks (the paper's method, Miao et al. 2022, section 4): the operator
// picks the same physical feature (a corner of the target board) in the
// first and the second pass of a circle drive, as a raw sample or as an
// approximate world position. ResolvePairs turns picks into the
// observations SolvePairs (pairs_solver.h) re-projects; the pairs file
// (docs/calibration.md, "Pairs file") stores them.
//
// Pure functions, no globals; may run on any thread.
#ifndef SWEEPSCAN_CORE_CALIBRATION_PICKS_H_
#define SWEEPSCAN_CORE_CALIBRATION_PICKS_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/calibration/passes.h"
#include "core/calibration/samples.h"
#include "core/common/status.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

// One picked feature: a raw sample, or an approximate world position that
// snaps to the nearest sample of its pass. A sample is named by its time
// stamp (`sample`), which a lost packet does not change; files written before
// that name it by (scan, beam) as received (`position`, by_position), which
// a lost packet earlier in the revolution renumbers (docs/calibration.md).
struct Pick {
  bool has_sample = false;
  bool by_position = false;  // has_sample: `position` instead of `sample`
  SampleName sample;
  SampleRef position;
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  // used when !has_sample
};

// The pick of a sample the store holds, by its name (time, range, angle).
Pick SamplePick(const LidarObservation& o);
// A version-1 pick by (scan, beam) as received.
Pick PositionPick(const SampleRef& ref);
// The sample a pick names; a world pick is an error here.
Status FindPickedSample(const Pick& pick, const SampleStore& store, LidarObservation* out);
struct PickPair {
  Pick pass1, pass2;
};
struct ObservationPair {
  LidarObservation pass1, pass2;
};

// Resolves picks against the recording: samples are looked up, world
// positions snap to their pass under `calibration`. Checks every pick
// belongs to the pass it claims (windows[0] for pass1, windows[1] for pass2).
Status ResolvePairs(const std::vector<PickPair>& picks, const SampleStore& store,
                    const std::vector<PassWindow>& windows, const RobotGeometry& geometry,
                    const MountingError& calibration, std::vector<ObservationPair>* pairs);

// The pairs file (docs/calibration.md).
Status LoadPairsFile(const std::string& path, std::vector<PickPair>* pairs);
Status ParsePairs(const std::string& text, const std::string& source, std::vector<PickPair>* pairs);
std::string PairsToJson(const std::vector<PickPair>& pairs);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_PICKS_H_
