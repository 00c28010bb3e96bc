// A path simplified as it grows, for drawing: every point given lies within
// a tolerance of the polyline kept.
//
// Why: the view draws the robot's path at ~10 poses a second, 205 000
// vertices for a 5.7-hour drive. Under a software renderer a 3-pixel line
// of that many vertices cost a quarter of each frame while the camera moved
// (docs/performance.md); straight legs need two vertices, a turn of radius
// r about sqrt(8 r / tol) per radian.
//
// The scheme (an incremental "sleeve" test, as Douglas-Peucker's criterion
// applied to the open end only): the kept polyline ends at the latest point.
// A new point p moves that end to p when every point since the last fixed
// vertex a lies within the tolerance of the segment a-p; otherwise the old
// end becomes fixed and p is the new end. The check is linear in the points
// since a, so it is capped (max_pending): a straight leg of any length then
// costs a vertex every max_pending points, not quadratic time.
#ifndef SWEEPSCAN_CORE_GEOMETRY_POLYLINE_H_
#define SWEEPSCAN_CORE_GEOMETRY_POLYLINE_H_

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace sweepscan {

// Distance from p to the segment a-b (to a when a == b).
double DistanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                         const Eigen::Vector2d& b);

class PolylineSimplifier {
 public:
  explicit PolylineSimplifier(double tolerance, size_t max_pending = 1024)
      : tolerance_(tolerance), max_pending_(max_pending) {}

  void Add(const Eigen::Vector2d& p);
  void Clear();

  // The kept vertices: the first point given, the fixed vertices, and the
  // latest point given (empty before the first).
  const std::vector<Eigen::Vector2d>& vertices() const { return vertices_; }
  size_t points_given() const { return given_; }

 private:
  double tolerance_;
  size_t max_pending_;
  std::vector<Eigen::Vector2d> vertices_;
  std::vector<Eigen::Vector2d> pending_;  // Given since the last fixed vertex.
  size_t given_ = 0;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_POLYLINE_H_
