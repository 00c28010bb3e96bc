#include "core/sfm/line_extraction.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace sweepscan::sfm {

ScanLine FitScanLine(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& indices) {
  ScanLine line;
  line.indices = indices;
  if (indices.empty()) return line;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i : indices) mean += points[i];
  mean /= static_cast<double>(indices.size());
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (int i : indices) S += (points[i] - mean) * (points[i] - mean).transpose();
  // Principal axis of the scatter S: the eigenvector of the largest
  // eigenvalue is the direction, the smallest's the normal.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S);
  line.centroid = mean;
  line.direction = es.eigenvectors().col(1).normalized();
  line.normal = Eigen::Vector2d(-line.direction.y(), line.direction.x());
  line.rms = std::sqrt(std::max(es.eigenvalues()[0], 0.0) / static_cast<double>(indices.size()));
  double lo = 1e300, hi = -1e300;
  for (int i : indices) {
    const double s = line.direction.dot(points[i] - mean);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  line.start = mean + lo * line.direction;
  line.end = mean + hi * line.direction;
  line.length = hi - lo;
  return line;
}

namespace {

// Recursive split (the "split" of split-and-merge): the point farthest from
// the chord between the segment's end points cuts it in two, until every
// point lies within split_distance_m of its chord (a closed ring, whose ends
// meet, is first cut at the point farthest from its start).
void Split(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& seg, const LineExtractionOptions& o,
           std::vector<std::vector<int>>* out) {
  if (static_cast<int>(seg.size()) < std::max(o.min_points, 3)) return;
  const Eigen::Vector2d a = points[seg.front()], b = points[seg.back()];
  const Eigen::Vector2d chord = b - a;
  const double len = chord.norm();
  size_t worst = 0;
  double worst_d = -1.0;
  for (size_t k = 1; k + 1 < seg.size(); ++k) {
    const Eigen::Vector2d q = points[seg[k]] - a;
    const double d = len > o.split_distance_m ? std::abs(chord.x() * q.y() - chord.y() * q.x()) / len : q.norm();
    if (d > worst_d) {
      worst_d = d;
      worst = k;
    }
  }
  if (len > o.split_distance_m && worst_d <= o.split_distance_m) {
    out->push_back(seg);
    return;
  }
  const size_t cut = std::clamp<size_t>(worst, 1, seg.size() - 1);
  Split(points, std::vector<int>(seg.begin(), seg.begin() + static_cast<long>(cut)), o, out);
  Split(points, std::vector<int>(seg.begin() + static_cast<long>(cut), seg.end()), o, out);
}

}  // namespace

std::vector<ScanLine> ExtractLines(const std::vector<Eigen::Vector2d>& points, const LineExtractionOptions& o) {
  // 1. Segments of consecutive valid samples without range gaps.
  std::vector<std::vector<int>> segments(1);
  int prev = -1;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (!points[i].allFinite()) continue;
    if (prev >= 0) {
      const double gap = (points[i] - points[prev]).norm();
      if (gap > std::max(o.gap_m, o.gap_range_factor * points[i].norm())) segments.emplace_back();
    }
    segments.back().push_back(i);
    prev = i;
  }
  // 2. Split.
  std::vector<std::vector<int>> pieces;
  for (const auto& seg : segments) Split(points, seg, o, &pieces);
  // 3. Merge neighbouring collinear pieces (the split may cut a long noisy
  // line in two; consecutive pieces of one surface are refitted together).
  std::vector<std::vector<int>> merged;
  for (const auto& piece : pieces) {
    if (!merged.empty()) {
      const ScanLine a = FitScanLine(points, merged.back()), b = FitScanLine(points, piece);
      const double angle = std::acos(std::min(1.0, std::abs(a.direction.dot(b.direction))));
      std::vector<int> joined = merged.back();
      joined.insert(joined.end(), piece.begin(), piece.end());
      const bool near = (points[piece.front()] - points[merged.back().back()]).norm() <=
                        std::max(o.gap_m, o.gap_range_factor * points[piece.front()].norm());
      if (near && angle < o.merge_angle_rad && std::abs(a.normal.dot(b.centroid - a.centroid)) < o.merge_distance_m) {
        const ScanLine j = FitScanLine(points, joined);
        double worst = 0;
        for (int i : joined) worst = std::max(worst, std::abs(j.normal.dot(points[i] - j.centroid)));
        if (worst <= o.split_distance_m) {
          merged.back() = joined;
          continue;
        }
      }
    }
    merged.push_back(piece);
  }
  // 4. Keep the long ones, refitted.
  std::vector<ScanLine> lines;
  for (const auto& m : merged) {
    if (static_cast<int>(m.size()) < o.min_points) continue;
    ScanLine l = FitScanLine(points, m);
    if (l.length >= o.min_length_m) lines.push_back(std::move(l));
  }
  return lines;
}

}  // namespace sweepscan::sfm
