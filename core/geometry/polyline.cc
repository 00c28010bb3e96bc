#include "core/geometry/polyline.h"

#include <algorithm>

namespace sweepscan {

double DistanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

void PolylineSimplifier::Add(const Eigen::Vector2d& p) {
  ++given_;
  if (vertices_.empty()) {
    vertices_.push_back(p);  // The first vertex is fixed.
    return;
  }
  if (pending_.empty()) {
    vertices_.push_back(p);
    pending_.push_back(p);
    return;
  }
  // vertices_ = [..., a, end] with end == pending_.back().
  const Eigen::Vector2d& a = vertices_[vertices_.size() - 2];
  bool fits = pending_.size() < max_pending_;
  for (size_t i = 0; fits && i < pending_.size(); ++i) {
    fits = DistanceToSegment(pending_[i], a, p) <= tolerance_;
  }
  if (fits) {
    vertices_.back() = p;  // The open end moves on.
  } else {
    vertices_.push_back(p);  // The old end is fixed; p opens the next segment.
    pending_.clear();
  }
  pending_.push_back(p);
}

void PolylineSimplifier::Clear() {
  vertices_.clear();
  pending_.clear();
  given_ = 0;
}

}  // namespace sweepscan
