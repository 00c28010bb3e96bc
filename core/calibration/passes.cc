#include "core/calibration/passes.h"

#include <algorithm>
#include <cmath>

#include "core/geometry/transform.h"

namespace sweepscan {

std::vector<PassWindow> SplitByTimeGaps(std::vector<int64_t> times_ns, double gap_s,
                                        size_t min_count) {
  std::vector<PassWindow> out;
  if (times_ns.empty()) return out;
  std::sort(times_ns.begin(), times_ns.end());
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
