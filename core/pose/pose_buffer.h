// Time-ordered poses world_from_body with interpolation by time.
//
// Between two stored poses the translation is interpolated linearly and the
// rotation by normalised quaternion lerp (nlerp). For the small angles
// between two filter steps (< 1 deg at 100 Hz and 1 rad/s) nlerp differs
// from slerp by less than 1e-7 rad and is several times cheaper, which
// matters at 5 000 lidar samples a second per scan and millions in replay.
//
// Not thread-safe: owned by the processing thread.
#ifndef SWEEPSCAN_CORE_POSE_POSE_BUFFER_H_
#define SWEEPSCAN_CORE_POSE_POSE_BUFFER_H_

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/common/time.h"
#include "core/geometry/transform.h"

namespace sweepscan {

class PoseBuffer {
 public:
  // Poses must be added in non-decreasing time; an older one is ignored
  // (returns false) so that the buffer stays sorted.
  bool Add(Time time, const Rigid3d& world_from_body) {
    const int64_t t = ToNanoseconds(time);
    if (!times_.empty() && t < times_.back()) return false;
    if (!times_.empty() && t == times_.back()) {
      poses_.back() = world_from_body;
      return true;
    }
    times_.push_back(t);
    poses_.push_back(world_from_body);
    return true;
  }

  bool empty() const { return times_.empty(); }
  size_t size() const { return times_.size(); }
  Time earliest() const { return TimeFromNanoseconds(times_.front()); }
  Time latest() const { return TimeFromNanoseconds(times_.back()); }
  Time time(size_t i) const { return TimeFromNanoseconds(times_[i]); }
  const Rigid3d& pose(size_t i) const { return poses_[i]; }
  bool Covers(Time t) const {
    return !empty() && ToNanoseconds(t) >= times_.front() && ToNanoseconds(t) <= times_.back();
  }

  // Interpolated pose at `time`; false if outside [earliest, latest].
  bool Lookup(Time time, Rigid3d* world_from_body) const {
    size_t hint = 0;
    return LookupWithHint(time, &hint, world_from_body);
  }

  // As Lookup, for time-ordered queries: `hint` keeps the last interval and
  // the search walks forward from it, so a scan costs O(1) per sample.
  bool LookupWithHint(Time time, size_t* hint, Rigid3d* world_from_body) const {
    size_t i;
    double s;
    if (!FindInterval(time, hint, &i, &s)) return false;
    *world_from_body = s == 0.0 ? poses_[i] : InterpolateNlerp(poses_[i], poses_[i + 1], s);
    return true;
  }

  // The stored interval [i, i + 1] around `time` and the fraction s in [0, 1)
  // of the way through it (s = 0 and i = size() - 1 at the very end).
  bool FindInterval(Time time, size_t* hint, size_t* index, double* fraction) const {
    const int64_t t = ToNanoseconds(time);
    if (times_.empty() || t < times_.front() || t > times_.back()) return false;
    size_t i = std::min(*hint, times_.size() - 1);
    if (times_[i] > t) {
      i = static_cast<size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin()) - 1;
    } else {
      // Walk a few steps, then fall back to bisection.
      int steps = 0;
      while (i + 1 < times_.size() && times_[i + 1] <= t && ++steps < 8) ++i;
      if (i + 1 < times_.size() && times_[i + 1] <= t) {
        i = static_cast<size_t>(std::upper_bound(times_.begin() + i, times_.end(), t) -
                                times_.begin()) - 1;
      }
    }
    *hint = i;
    *index = i;
    *fraction = (i + 1 == times_.size() || times_[i] == t)
                    ? 0.0
                    : static_cast<double>(t - times_[i]) / static_cast<double>(times_[i + 1] - times_[i]);
    return true;
  }

  static Rigid3d InterpolateNlerp(const Rigid3d& a, const Rigid3d& b, double s) {
    Eigen::Vector4d qa = a.rotation().coeffs(), qb = b.rotation().coeffs();
    if (qa.dot(qb) < 0.0) qb = -qb;  // shortest arc
    const Eigen::Vector4d q = ((1.0 - s) * qa + s * qb).normalized();
    return Rigid3d(a.translation() + s * (b.translation() - a.translation()),
                   Eigen::Quaterniond(q[3], q[0], q[1], q[2]));
  }

 private:
  std::vector<int64_t> times_;
  std::vector<Rigid3d> poses_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_POSE_BUFFER_H_
