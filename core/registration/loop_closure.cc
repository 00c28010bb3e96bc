#include "core/registration/loop_closure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace sweepscan {

namespace {

Eigen::Vector2d Xy(const Rigid3d& p) { return p.translation().head<2>(); }

// The run of pose indices around `centre` whose positions stay within
// `radius` of it.
void Window(const PoseBuffer& poses, size_t centre, double radius, size_t* first, size_t* last) {
  const Eigen::Vector2d c = Xy(poses.pose(centre));
  *first = *last = centre;
  while (*first > 0 && (Xy(poses.pose(*first - 1)) - c).norm() <= radius) --*first;
  while (*last + 1 < poses.size() && (Xy(poses.pose(*last + 1)) - c).norm() <= radius) ++*last;
}

std::vector<Eigen::Vector3f> PointsBetween(const std::vector<CloudPoint>& points, Time begin, Time end) {
  const int64_t b = ToNanoseconds(begin), e = ToNanoseconds(end);
  std::vector<Eigen::Vector3f> out;
  for (const CloudPoint& p : points) {
    if (p.time_ns >= b && p.time_ns <= e) out.emplace_back(p.x, p.y, p.z);
  }
  return out;
}

}  // namespace

bool LoopClosureOptions::IsValid(std::string* error) const {
  if (!(revisit_radius_m > 0.0 && min_gap_s > 0.0 && min_away_m > revisit_radius_m && max_drift_fraction > 0.0)) {
    if (error != nullptr) {
      *error = "need revisit_radius_m > 0, min_gap_s > 0, min_away_m > revisit_radius_m and max_drift_fraction > 0";
    }
    return false;
  }
  return planes.IsValid(error) && icp.IsValid(error);
}

Status FindLoop(const std::vector<CloudPoint>& points, const PoseBuffer& poses, const LoopClosureOptions& o,
                LoopClosure* loop) {
  *loop = LoopClosure();
  std::string error;
  if (!o.IsValid(&error)) return Status::Error("loop closure: " + error);
  if (poses.size() < 2) return Status::Error("loop closure: fewer than two poses");
  // 1. The windows: the start's and the end's runs within the radius.
  const size_t last = poses.size() - 1;
  size_t e0, e1, l0, l1;
  Window(poses, 0, o.revisit_radius_m, &e0, &e1);
  Window(poses, last, o.revisit_radius_m, &l0, &l1);
  if (e1 >= l0) return Status::Ok();  // never left: no loop
  if (ToSeconds(poses.time(l0)) - ToSeconds(poses.time(e1)) < o.min_gap_s) return Status::Ok();
  double away = 0.0, driven = 0.0;
  for (size_t k = e1; k <= l0; ++k) {
    away = std::max(away, (Xy(poses.pose(k)) - Xy(poses.pose(0))).norm());
    if (k > e1) driven += (Xy(poses.pose(k)) - Xy(poses.pose(k - 1))).norm();
  }
  if (away < o.min_away_m) return Status::Ok();
  loop->found = true;
  loop->early_begin = poses.time(e0);
  loop->early_end = poses.time(e1);
  loop->late_begin = poses.time(l0);
  loop->late_end = poses.time(l1);
  const std::vector<Eigen::Vector3f> target = PointsBetween(points, loop->early_begin, loop->early_end);
  const std::vector<Eigen::Vector3f> source = PointsBetween(points, loop->late_begin, loop->late_end);
  loop->early_points = target.size();
  loop->late_points = source.size();
  if (target.size() < 1000 || source.size() < 1000) {
    char buf[200];
    std::snprintf(buf, sizeof(buf), "loop closure: the revisit's windows hold %zu and %zu points (at least 1000 each)",
                  target.size(), source.size());
    return Status::Error(buf);
  }
  // 2. The late window against the early one: planes, then ICP.
  RegistrationResult coarse;
  Rigid3d initial = Rigid3d::Identity();
  loop->method = "icp";
  if (AlignByPlanes(source, target, o.planes, &coarse).ok()) {
    initial = coarse.target_from_source;
    loop->method = "planes+icp";
  }
  const Status s = RefineIcp(source, target, initial, o.icp, RegistrationControl(), &loop->registration);
  if (!s.ok()) return Status::Error("loop closure: " + s.message());
  loop->correction = loop->registration.target_from_source;
  const double drift = loop->correction.translation().head<2>().norm();
  if (drift > o.max_drift_fraction * driven) {
    char buf[320];
    std::snprintf(buf, sizeof(buf),
                  "loop closure: the end's view registers %.2f m from the start's, more than %.0f %% of the "
                  "%.1f m driven in between: the drive does not end in the room it started in (a look-alike "
                  "room), or its poses drift more than allowed",
                  drift, 100.0 * o.max_drift_fraction, driven);
    return Status::Error(buf);
  }
  return Status::Ok();
}

PoseBuffer CorrectPoses(const PoseBuffer& poses, const LoopClosure& loop) {
  if (!loop.found) return poses;
  PoseBuffer out;
  const double a = ToSeconds(loop.early_end), b = ToSeconds(loop.late_begin);
  for (size_t i = 0; i < poses.size(); ++i) {
    const double t = ToSeconds(poses.time(i));
    const double s = t <= a ? 0.0 : t >= b ? 1.0 : (t - a) / (b - a);
    out.Add(poses.time(i), Interpolate(Rigid3d::Identity(), loop.correction, s) * poses.pose(i));
  }
  return out;
}

}  // namespace sweepscan
