// The raw samples of a recording, addressable by (scan, beam), and their
// re-projection under a candidate calibration.
#include "core/calibration/samples.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/calibration/internal.h"

namespace sweepscan {
namespace {

uint64_t Key(const SampleRef& r) { return (static_cast<uint64_t>(r.scan) << 16) | r.beam; }

}  // namespace

using calibration_internal::Finite;
using calibration_internal::RefName;

Eigen::Vector3d ProjectObservation(const LidarObservation& o, const RobotGeometry& geometry,
                                   const MountingError& calibration) {
  return o.world_from_body * (BodyFromLidar(geometry, calibration) * o.p_lidar);
}

// ----------------------------------------------------------------------------
// SampleStore

SampleStore::SampleStore(const SensorLog& log, const PoseBuffer& poses, double min_range_m,
                         double max_range_m) {
  for (const LidarScan& scan : log.scans) {
    size_t hint = 0;
    for (const LidarSample& s : scan.samples) {
      if (!(s.range_m >= min_range_m && s.range_m <= max_range_m)) continue;
      LidarObservation o;
      if (!poses.LookupWithHint(s.time, &hint, &o.world_from_body)) continue;
      o.ref = {scan.index, s.beam};
      o.time_ns = ToNanoseconds(s.time);
      o.p_lidar = LidarPoint(s.range_m, s.theta);
      by_ref_[Key(o.ref)] = observations_.size();
      observations_.push_back(o);
    }
  }
}

Status SampleStore::Find(const SampleRef& ref, LidarObservation* out) const {
  const auto it = by_ref_.find(Key(ref));
  if (it == by_ref_.end()) {
    return Status::Error("sample " + RefName(ref) +
                         " is not a valid sample of the recording (unknown scan or beam, no "
                         "return, or no pose)");
  }
  *out = observations_[it->second];
  return Status::Ok();
}

std::vector<size_t> SampleStore::InWindow(const PassWindow& window) const {
  std::vector<size_t> out;
  const auto lo =
      std::lower_bound(observations_.begin(), observations_.end(), window.begin_ns,
                       [](const LidarObservation& o, int64_t t) { return o.time_ns < t; });
  for (auto it = lo; it != observations_.end() && it->time_ns <= window.end_ns; ++it) {
    out.push_back(static_cast<size_t>(it - observations_.begin()));
  }
  return out;
}

Status SampleStore::Nearest(const PassWindow& window, const Eigen::Vector3d& world,
                            const RobotGeometry& geometry, const MountingError& calibration,
                            LidarObservation* out) const {
  if (!Finite(world)) return Status::Error("pick position is not finite");
  double best = std::numeric_limits<double>::infinity();
  for (size_t i : InWindow(window)) {
    const double d =
        (ProjectObservation(observations_[i], geometry, calibration) - world).squaredNorm();
    if (d < best) {
      best = d;
      *out = observations_[i];
    }
  }
  if (!std::isfinite(best)) return Status::Error("the pass has no samples to snap to");
  return Status::Ok();
}

}  // namespace sweepscan
