#include "core/calibration/passes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/geometry/transform.h"

namespace sweepscan {

std::vector<PassWindow> SplitByTimeGaps(std::vector<int64_t> times_ns, double gap_s,
                                        size_t min_count) {
  std::vector<PassWindow> out;
  if (times_ns.empty()) return out;
  // The automatic mode's planes pass their members in time order already.
  if (!std::is_sorted(times_ns.begin(), times_ns.end())) std::sort(times_ns.begin(), times_ns.end());
  const double gap_ns = gap_s * 1e9;
  PassWindow w{times_ns[0], times_ns[0], 1};
  for (size_t i = 1; i < times_ns.size(); ++i) {
    if (static_cast<double>(times_ns[i] - w.end_ns) > gap_ns) {
      if (w.count >= min_count) out.push_back(w);
      w = PassWindow{times_ns[i], times_ns[i], 0};
    }
    w.end_ns = times_ns[i];
    ++w.count;
  }
  if (w.count >= min_count) out.push_back(w);
  return out;
}

static std::vector<int64_t> TimesInRegion(const std::vector<CloudPoint>& points,
                                          const Eigen::AlignedBox3d& region) {
  std::vector<int64_t> times;
  for (const CloudPoint& p : points) {
    if (region.contains(Eigen::Vector3d(p.x, p.y, p.z))) times.push_back(p.time_ns);
  }
  return times;
}

std::vector<PassWindow> FindPassWindows(const std::vector<CloudPoint>& points,
                                        const Eigen::AlignedBox3d& region, double gap_s,
                                        size_t min_count) {
  return SplitByTimeGaps(TimesInRegion(points, region), gap_s, min_count);
}

std::vector<std::vector<size_t>> SplitRegionIntoPasses(const std::vector<CloudPoint>& points,
                                                       const Eigen::AlignedBox3d& region,
                                                       double gap_s, size_t min_count) {
  const std::vector<PassWindow> windows = FindPassWindows(points, region, gap_s, min_count);
  std::vector<std::vector<size_t>> out(windows.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const CloudPoint& p = points[i];
    if (!region.contains(Eigen::Vector3d(p.x, p.y, p.z))) continue;
    const int k = PassOfTime(windows, p.time_ns);
    if (k >= 0) out[k].push_back(i);
  }
  for (auto& pass : out) {
    std::stable_sort(pass.begin(), pass.end(), [&points](size_t a, size_t b) {
      return points[a].time_ns < points[b].time_ns;
    });
  }
  return out;
}

int PassOfTime(const std::vector<PassWindow>& windows, int64_t t_ns) {
  for (size_t k = 0; k < windows.size(); ++k) {
    if (windows[k].Contains(t_ns)) return static_cast<int>(k);
  }
  return -1;
}

CirclePass CircleDrive::PassOf(const Eigen::Vector2d& robot_xy,
                               const Eigen::Vector2d& object_xy) const {
  const Eigen::Vector2d r = robot_xy - centre, o = object_xy - centre;
  // |phi - psi| < pi/2 <=> the robot is on the object's side of the centre.
  return r.dot(o) >= 0.0 ? CirclePass::kNear : CirclePass::kFar;
}

bool CircleDrive::PassAtTime(const PoseBuffer& poses, Time t, const Eigen::Vector2d& object_xy,
                             CirclePass* pass) const {
  Rigid3d world_from_body;
  if (!poses.Lookup(t, &world_from_body)) return false;
  *pass = PassOf(world_from_body.translation().head<2>(), object_xy);
  return true;
}

}  // namespace sweepscan

namespace sweepscan {

bool FitCircleDrive(const PoseBuffer& poses, CircleDrive* circle, std::string* why,
                    double min_turns) {
  if (poses.size() < 10) {
    *why = "too few poses for a circle drive (" + std::to_string(poses.size()) + ")";
    return false;
  }
  // Kasa fit: minimise sum (x^2 + y^2 + D x + E y + F)^2, linear in (D, E, F).
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector2d p = poses.pose(i).translation().head<2>();
    const Eigen::Vector3d row(p.x(), p.y(), 1.0);
    ata += row * row.transpose();
    atb -= row * p.squaredNorm();
  }
  const Eigen::Vector3d def = ata.ldlt().solve(atb);
  const Eigen::Vector2d centre(-0.5 * def[0], -0.5 * def[1]);
  const double r2 = centre.squaredNorm() - def[2];
  if (!def.allFinite() || !(r2 > 0.01)) {
    *why = "the drive is not a circle (no finite centre)";
    return false;
  }
  const double radius = std::sqrt(r2);
  // How far the path strays from the circle, and how far round it goes: the
  // span of the polar angle about the centre, unwrapped, so that a circle
  // driven forward and then backward (which cancels a lidar time offset,
  // docs/calibration.md) counts its turn once.
  double worst = 0.0, swept = 0.0, lo = 0.0, hi = 0.0;
  double last = 0.0;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector2d d = poses.pose(i).translation().head<2>() - centre;
    worst = std::max(worst, std::abs(d.norm() - radius));
    const double phi = std::atan2(d.y(), d.x());
    if (i > 0) swept += std::remainder(phi - last, 2.0 * M_PI);
    lo = std::min(lo, swept);
    hi = std::max(hi, swept);
    last = phi;
  }
  const double turns = (hi - lo) / (2.0 * M_PI);
  char text[160];
  if (worst > 0.15 * radius) {
    std::snprintf(text, sizeof(text),
                  "the drive strays %.2f m from its best circle (radius %.2f m): not a circle drive",
                  worst, radius);
    *why = text;
    return false;
  }
  if (turns < min_turns) {
    std::snprintf(text, sizeof(text), "the drive goes %.2f turns round its circle, need %.2f",
                  turns, min_turns);
    *why = text;
    return false;
  }
  circle->centre = centre;
  circle->radius_m = radius;
  return true;
}

double MaxHeadingDeparture(const PoseBuffer& poses, const PoseBuffer& reference) {
  bool started = false;
  double last_a = 0.0, last_b = 0.0, turn_a = 0.0, turn_b = 0.0, worst = -1.0;
  size_t hint = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    Rigid3d ref;
    if (!reference.LookupWithHint(poses.time(i), &hint, &ref)) continue;
    const double a = YawFromQuaternion(poses.pose(i).rotation()),
                 b = YawFromQuaternion(ref.rotation());
    if (started) {
      turn_a += std::remainder(a - last_a, 2.0 * M_PI);
      turn_b += std::remainder(b - last_b, 2.0 * M_PI);
    }
    started = true;
    last_a = a;
    last_b = b;
    worst = std::max(worst, std::abs(turn_a - turn_b));
  }
  return worst;
}

void LabelCirclePasses(const CloudPoint* points, size_t n, const PoseBuffer& poses,
                       const CircleDrive& circle, size_t* hint, uint8_t* labels) {
  for (size_t i = 0; i < n; ++i) {
    const CloudPoint& p = points[i];
    Rigid3d world_from_body;
    labels[i] = kNoPass;
    // Points come in time order, so the hint makes each lookup O(1).
    if (!poses.LookupWithHint(TimeFromNanoseconds(p.time_ns), hint, &world_from_body)) continue;
    labels[i] = static_cast<uint8_t>(
        circle.PassOf(world_from_body.translation().head<2>(), Eigen::Vector2d(p.x, p.y)));
  }
}

std::vector<uint8_t> LabelCirclePasses(const std::vector<CloudPoint>& points,
                                       const PoseBuffer& poses, const CircleDrive& circle) {
  std::vector<uint8_t> labels(points.size(), kNoPass);
  size_t hint = 0;
  LabelCirclePasses(points.data(), points.size(), poses, circle, &hint, labels.data());
  return labels;
}

}  // namespace sweepscan
