// The raw samples of a recording, addressable by (scan, beam) and by time,
// and their re-projection under a candidate calibration.
#include "core/calibration/samples.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include "core/calibration/internal.h"

namespace sweepscan {
namespace {

uint64_t Key(const SampleRef& r) { return (static_cast<uint64_t>(r.scan) << 16) | r.beam; }

}  // namespace

using calibration_internal::Finite;
using calibration_internal::kNsPerS;
using calibration_internal::Num;
using calibration_internal::RefName;

Eigen::Vector3d ProjectObservation(const LidarObservation& o, const RobotGeometry& geometry,
                                   const MountingError& calibration) {
  return o.world_from_body * (BodyFromLidar(geometry, calibration) * o.p_lidar);
}

// ----------------------------------------------------------------------------
// SampleStore

SampleStore SampleStore::ScaledAbout(const Eigen::Vector3d& centre, double scale) const {
  SampleStore out = *this;
  for (LidarObservation& o : out.observations_) {
    o.world_from_body = Rigid3d(centre + scale * (o.world_from_body.translation() - centre),
                                o.world_from_body.rotation());
  }
  return out;
}

SampleStore::SampleStore(const SensorLog& log, const PoseBuffer& poses, double min_range_m,
                         double max_range_m) {
  size_t total = 0;
  for (const LidarScan& scan : log.scans) total += scan.samples.size();
  observations_.reserve(total);
  by_ref_.reserve(total);
  std::vector<int64_t> spacing;
  for (const LidarScan& scan : log.scans) {
    size_t hint = 0;
    for (const LidarSample& s : scan.samples) {
      if (!(s.range_m >= min_range_m && s.range_m <= max_range_m)) continue;
      LidarObservation o;
      if (!poses.LookupWithHint(s.time, &hint, &o.world_from_body)) continue;
      o.ref = {scan.index, s.beam};
      o.time_ns = ToNanoseconds(s.time);
      o.p_lidar = LidarPoint(s.range_m, s.theta);
      o.range_m = s.range_m;
      o.theta = s.theta;
      if (!observations_.empty() && o.time_ns <= observations_.back().time_ns) {
        time_sorted_ = false;
      }
      by_ref_[Key(o.ref)] = observations_.size();
      observations_.push_back(o);
    }
    // Lost samples: the X4 samples at a fixed rate, so consecutive samples of
    // a revolution are one period apart (the median spacing); a lost packet
    // leaves a gap of its 40 periods. 20 periods tolerates receive-time jitter.
    const std::vector<LidarSample>& v = scan.samples;
    if (v.size() < 3) continue;
    spacing.clear();
    for (size_t i = 1; i < v.size(); ++i) spacing.push_back((v[i].time - v[i - 1].time).count());
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    const int64_t period = spacing[spacing.size() / 2];
    if (period <= 0) continue;
    for (size_t i = 1; i < v.size(); ++i) {
      const int64_t gap = (v[i].time - v[i - 1].time).count();
      if (gap > 20 * period) {
        first_loss_[scan.index] = {v[i].beam, gap};
        break;
      }
    }
  }
}

bool SampleStore::LostSamplesBefore(const SampleRef& ref, double* gap_s) const {
  const auto it = first_loss_.find(ref.scan);
  if (it == first_loss_.end() || ref.beam < it->second.first) return false;
  if (gap_s != nullptr) *gap_s = static_cast<double>(it->second.second) / kNsPerS;
  return true;
}

Status SampleStore::Find(const SampleName& name, LidarObservation* out) const {
  const std::string what = "sample at time " + std::to_string(name.time_ns) + " ns";
  // Exact match: the same bytes decoded with the same options give the same
  // time stamps to the nanosecond.
  size_t found = observations_.size(), matches = 0;
  int64_t nearest = std::numeric_limits<int64_t>::max();
  const auto consider = [&](size_t i) {
    const int64_t d = observations_[i].time_ns - name.time_ns;
    if (d == 0) {
      found = i;
      ++matches;
    } else if (std::llabs(d) < std::llabs(nearest)) {
      nearest = d;
    }
  };
  if (time_sorted_) {
    const auto it =
        std::lower_bound(observations_.begin(), observations_.end(), name.time_ns,
                         [](const LidarObservation& o, int64_t t) { return o.time_ns < t; });
    const size_t k = static_cast<size_t>(it - observations_.begin());
    if (k > 0) consider(k - 1);
    if (k < observations_.size()) consider(k);
  } else {
    for (size_t i = 0; i < observations_.size(); ++i) consider(i);
  }
  if (matches == 0) {
    return Status::Error(
        what + " is not a valid sample of the recording" +
        (nearest == std::numeric_limits<int64_t>::max()
             ? std::string(" (it has none)")
             : " (the nearest is " + Num(static_cast<double>(std::llabs(nearest)) * 1e-6) +
                   " ms away: another recording, or decoded with other serial settings?)"));
  }
  if (matches > 1) return Status::Error(what + " is ambiguous: two samples have that time");
  const LidarObservation& o = observations_[found];
  if (std::isfinite(name.range_m) && std::abs(o.range_m - name.range_m) > 0.5e-3) {
    return Status::Error(what + " measured " + Num(o.range_m) + " m, the pick says " +
                         Num(name.range_m) + " m: the recording or its timing changed since");
  }
  if (std::isfinite(name.theta_rad) &&
      std::abs(std::remainder(o.theta - name.theta_rad, 2.0 * M_PI)) > 1e-4) {
    return Status::Error(what + " has scan angle " + Num(o.theta) + " rad, the pick says " +
                         Num(name.theta_rad) + " rad: the recording or its timing changed since");
  }
  *out = o;
  return Status::Ok();
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
