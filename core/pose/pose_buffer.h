// Time-ordered poses world_from_body with interpolation by time.
//
// Between two stored poses the translation is interpolated linearly and the
// rotation by normalised quaternion lerp (nlerp). For the small angles
// between two filter steps (< 1 deg at 100 Hz and 1 rad/s) nlerp differs
// from slerp by less than 1e-7 rad and is several times cheaper, which
// matters at 5 000 lidar samples a second per scan and millions in replay.
//
// Gaps in the data (docs/models.md, "Gaps in the data"): a pose added with
// after_gap = true opens a new segment. The interval between it and the pose
// before is a hole in the sensor data, not a motion: Lookup and FindInterval
// refuse every time strictly inside it (the poses at its two ends still
// answer), so deskewing drops those samples instead of inventing poses. The
// mark is one byte per pose, read once per lookup: O(1) on the hot path.
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
  // (returns false) so that the buffer stays sorted. after_gap: the pose is
  // the first after a gap in the data (above); ignored for the first pose.
  bool Add(Time time, const Rigid3d& world_from_body, bool after_gap = false) {
    const int64_t t = ToNanoseconds(time);
    if (!times_.empty() && t < times_.back()) return false;
    if (!times_.empty() && t == times_.back()) {
      poses_.back() = world_from_body;
      if (after_gap && times_.size() > 1 && after_gap_.back() == 0) {
        after_gap_.back() = 1;
        ++gap_count_;
      }
      return true;
    }
    after_gap_.push_back(after_gap && !times_.empty() ? 1 : 0);
    if (after_gap_.back() != 0) ++gap_count_;
    times_.push_back(t);
    poses_.push_back(world_from_body);
    return true;
  }

  // Room for n poses: a long drive's buffer (hundreds of MB) is then not
  // copied as it doubles, and its pages are touched once.
  void reserve(size_t n) {
    times_.reserve(n);
    poses_.reserve(n);
    after_gap_.reserve(n);
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
  // Whether pose i opens a segment: (time(i - 1), time(i)) is a gap.
  bool AfterGap(size_t i) const { return after_gap_[i] != 0; }
  size_t gap_count() const { return gap_count_; }
  // Whether `time` lies strictly inside a gap (O(log n)).
  bool InGap(Time time) const {
    const int64_t t = ToNanoseconds(time);
    const size_t i = FirstAtOrAfter(time);
    return i > 0 && i < times_.size() && times_[i] > t && after_gap_[i] != 0;
  }
  // Index of the first pose at or after `time` (size() if none).
  size_t FirstAtOrAfter(Time time) const {
    return static_cast<size_t>(
        std::lower_bound(times_.begin(), times_.end(), ToNanoseconds(time)) - times_.begin());
  }

  // Interpolated pose at `time`; false if outside [earliest, latest] or
  // inside a gap.
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
  // False outside [earliest, latest] and strictly inside a gap (*hint is
  // still advanced, so a scan running through a gap keeps its O(1) walk).
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
    const bool at_pose = i + 1 == times_.size() || times_[i] == t;
    if (!at_pose && after_gap_[i + 1] != 0) return false;  // inside a gap
    *index = i;
    *fraction = at_pose ? 0.0
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
  std::vector<uint8_t> after_gap_;  // per pose: 1 if (time(i - 1), time(i)) is a gap
  size_t gap_count_ = 0;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_POSE_BUFFER_H_
