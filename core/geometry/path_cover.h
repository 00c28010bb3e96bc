// The part of a growing path that goes where the path has not been, for
// drawing: a place the robot passes again is drawn once.
//
// Why: a building is scanned by driving the same corridors and lanes again
// and again. A 5.7-hour back-and-forth drive, simplified to within 5 mm
// (polyline.h), still keeps every pass as its own segments, and drawn as a
// 3-pixel line under a software renderer those passes cost about 9 ms of
// each frame (perf of 300 frames in motion: one shader, the line's, took a
// quarter of the rasterising threads; docs/performance.md). Passes over the
// same ground add nothing to the picture.
//
// The scheme: a grid of square cells of side c. Each segment given is
// sampled every c/2 along its length; a sample is "covered" when its cell
// was reached by a drawn sample at least 4 c of path earlier (a straight
// pass stays in one cell for at most c sqrt(2) of its length, so the
// samples of one pass do not cover each other). The drawn runs are the
// stretches of uncovered samples, each widened by one sample at either end
// so that a run meets the line it rejoins rather than stopping a cell short
// of it. Drawn samples, and the midpoints between neighbouring ones, mark
// their cells with the path length at which they were drawn.
//
// The bound (checked by brute force in tests/core/geometry): a covered
// sample's cell holds a drawn sample, within c sqrt(2); every point of a
// segment is within c/4 of a sample; so every point of the path given lies
// within c (sqrt(2) + 1/4) of the drawn runs.
#ifndef SWEEPSCAN_CORE_GEOMETRY_PATH_COVER_H_
#define SWEEPSCAN_CORE_GEOMETRY_PATH_COVER_H_

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/geometry/polyline.h"

namespace sweepscan {

class PathCover {
 public:
  // cell: the grid's side (m).
  explicit PathCover(double cell) : cell_(cell), revisit_(4.0 * cell) {}

  // The path's next segment: a is the previous segment's b (or the start).
  void Add(const Eigen::Vector2d& a, const Eigen::Vector2d& b);
  void Clear();

  // The drawn runs, each a polyline of at least two vertices (the last run
  // may hold one vertex while it is open: it then continues at the next
  // segment).
  const std::vector<std::vector<Eigen::Vector2d>>& runs() const { return runs_; }
  // The largest distance of a point of the path given from the runs.
  double bound() const;
  // The path length given and the length drawn (m).
  double given_length() const { return arc_; }
  double drawn_length() const { return drawn_; }

 private:
  uint64_t Key(const Eigen::Vector2d& p) const;

  double cell_, revisit_;
  double arc_ = 0.0;    // Path length before the next segment.
  double drawn_ = 0.0;  // Length of the runs.
  bool open_ = false;   // The last run ends at the last segment's b and continues.
  std::unordered_map<uint64_t, double> marked_;  // Cell -> path length where first drawn.
  std::vector<std::vector<Eigen::Vector2d>> runs_;
};

// The robot's path as the view draws it: the poses simplified as they come
// (PolylineSimplifier), each segment the simplifier has fixed through the
// cover, and the open end (the last fixed vertex to the latest pose) drawn
// as it is, since it still moves.
class DrawnPath {
 public:
  DrawnPath(double tolerance, double cell) : tolerance_(tolerance), simplifier_(tolerance), cover_(cell) {}

  void Add(const Eigen::Vector2d& p);
  void Clear();

  // The polylines to draw: the cover's runs, then the open end.
  std::vector<std::vector<Eigen::Vector2d>> Polylines() const;
  // Every pose given lies within this of the polylines.
  double bound() const { return tolerance_ + cover_.bound(); }
  size_t points_given() const { return simplifier_.points_given(); }
  const PathCover& cover() const { return cover_; }

 private:
  double tolerance_;
  PolylineSimplifier simplifier_;
  PathCover cover_;
  size_t committed_ = 0;  // Segments of the simplifier's given to the cover.
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_PATH_COVER_H_
