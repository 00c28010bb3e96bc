// Straight lines in a 2D point set (a horizontal section): sequential RANSAC
// for the lines, total least squares for their parameters.
//
// A line is (c, u): a point c on it and a unit direction u; its unit normal
// is n = (-u_y, u_x) and the signed distance of p is r(p) = n . (p - c),
// its position along the line t(p) = u . (p - c).
//
// Total least squares of points p_i (minimises sum r(p_i)^2 over c, u):
//   c = mean(p_i),  S = sum (p_i - c)(p_i - c)^T,
//   n = eigenvector of S with the smaller eigenvalue lambda_min,
//   rms = sqrt(lambda_min / N).
//
// Detection assumes walls are long compared to the tolerance and that most
// section points lie on walls or furniture faces; a random line through
// clutter collects few points within 2 cm and is rejected later by its length.
#ifndef SWEEPSCAN_CORE_PLAN_LINE_FIT_H_
#define SWEEPSCAN_CORE_PLAN_LINE_FIT_H_

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace sweepscan::plan {

struct Line2d {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  Eigen::Vector2d u = Eigen::Vector2d::UnitX();
  Eigen::Vector2d Normal() const { return {-u.y(), u.x()}; }
  double Distance(const Eigen::Vector2d& p) const { return Normal().dot(p - c); }
  double Along(const Eigen::Vector2d& p) const { return u.dot(p - c); }
  Eigen::Vector2d At(double t) const { return c + t * u; }
};

// Total least squares over points[idx]. False when fewer than 2 points or all
// coincide.
bool FitLine(const std::vector<Eigen::Vector2d>& points, const std::vector<size_t>& idx, Line2d* line,
             double* rms);

struct LineDetectionOptions {
  double tolerance_m = 0.02;  // RANSAC inlier distance
  int min_cells = 6;          // stop when the best line covers fewer grid cells
  int hypotheses = 400;       // per line
  int max_lines = 400;
  uint64_t seed = 1;
};

// The lines of `points`, best supported first. Works on one point per cell
// of side tolerance/2 (so that a wall seen up close does not outvote one seen
// from afar); each line's parameters come from total least squares on the
// cells within the tolerance, refitted three times. The caller refits on the
// full points.
std::vector<Line2d> DetectLines(const std::vector<Eigen::Vector2d>& points, const LineDetectionOptions& options);

}  // namespace sweepscan::plan

#endif  // SWEEPSCAN_CORE_PLAN_LINE_FIT_H_
