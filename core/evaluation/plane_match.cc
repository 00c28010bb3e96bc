#include "core/evaluation/plane_match.h"

#include <cmath>
#include <limits>

namespace sweepscan {

std::vector<int> MatchPlanes(const CloudEvaluation& now, const CloudEvaluation& before,
                             const PlaneMatchOptions& options) {
  const double min_cos = std::cos(options.max_angle_deg * M_PI / 180.0);
  std::vector<int> match(now.planes.size(), -1);
  std::vector<bool> taken(before.planes.size(), false);
  for (size_t i = 0; i < now.planes.size(); ++i) {
    const EvaluatedPlane& a = now.planes[i];
    double best = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < before.planes.size(); ++j) {
      const EvaluatedPlane& b = before.planes[j];
      if (taken[j] || a.kind != b.kind) continue;
      if (std::abs(a.plane.normal.dot(b.plane.normal)) < min_cos) continue;
      const double to_a = std::abs(a.plane.SignedDistance(b.plane.centroid));
      const double to_b = std::abs(b.plane.SignedDistance(a.plane.centroid));
      if (to_a > options.max_offset_m || to_b > options.max_offset_m) continue;
      if (to_a + to_b < best) {
        best = to_a + to_b;
        match[i] = static_cast<int>(j);
      }
    }
    if (match[i] >= 0) taken[static_cast<size_t>(match[i])] = true;
  }
  return match;
}

std::vector<int> MatchDimensions(const CloudEvaluation& now, const CloudEvaluation& before,
                                 const std::vector<int>& match) {
  const auto matched = [&](int plane) {
    return plane >= 0 && static_cast<size_t>(plane) < match.size()
               ? match[static_cast<size_t>(plane)]
               : -1;
  };
  std::vector<int> out(now.dimensions.size(), -1);
  for (size_t i = 0; i < now.dimensions.size(); ++i) {
    const int a = matched(now.dimensions[i].plane_a);
    const int b = matched(now.dimensions[i].plane_b);
    if (a < 0 || b < 0) continue;
    for (size_t j = 0; j < before.dimensions.size(); ++j) {
      const RoomDimension& d = before.dimensions[j];
      if ((d.plane_a == a && d.plane_b == b) || (d.plane_a == b && d.plane_b == a)) {
        out[i] = static_cast<int>(j);
        break;
      }
    }
  }
  return out;
}

}  // namespace sweepscan
