// Line extraction from one 2D scan (Choi et al. 2017, section 4: scan lines
// are the measurements of the SfM pipeline). The scan is an ordered list of
// points in the scan plane; it is cut at range gaps, split recursively where
// a point lies too far from the total-least-squares line of its segment
// (split-and-merge), adjacent collinear pieces are merged, and every line of
// at least `min_length_m` is refitted by total least squares, keeping the
// indices of the samples that support it.
#ifndef SWEEPSCAN_CORE_SFM_LINE_EXTRACTION_H_
#define SWEEPSCAN_CORE_SFM_LINE_EXTRACTION_H_

#include <Eigen/Core>
#include <vector>

namespace sweepscan::sfm {

struct LineExtractionOptions {
  double min_length_m = 0.5;       // extent of the supporting samples along the line
  int min_points = 8;
  double split_distance_m = 0.03;  // a point farther than this from its segment's line splits it
  double gap_m = 0.15;             // consecutive samples farther apart start a new segment
  double gap_range_factor = 0.05;  // ... or farther than this times their range
  double merge_angle_rad = 0.05;   // adjacent pieces this close in direction and
  double merge_distance_m = 0.03;  // offset are merged
};

// A line n . p = c in the scan plane (|n| = 1), fitted by total least squares:
// through the centroid of its samples, along the principal axis of their
// scatter; rms = sqrt(smallest eigenvalue / count).
struct ScanLine {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  // unit
  Eigen::Vector2d normal = Eigen::Vector2d::UnitY();     // unit, direction rotated +90 deg
  Eigen::Vector2d start = Eigen::Vector2d::Zero(), end = Eigen::Vector2d::Zero();  // extreme projections
  double length = 0.0;
  double rms = 0.0;
  std::vector<int> indices;  // supporting samples, in scan order
};

// Total least-squares line through points[indices].
ScanLine FitScanLine(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& indices);

// `points` in scan order (non-finite points are skipped: dropouts).
std::vector<ScanLine> ExtractLines(const std::vector<Eigen::Vector2d>& points,
                                   const LineExtractionOptions& options = {});

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_LINE_EXTRACTION_H_
