// The target board's corner model (board_fit.cc's internals, shared by its
// two files): where scan lines leave the board (EdgePoint, made by the edge
// extraction in board_fit.cc) and the rectangle through them (Rect), with
// its least-squares solve, its covariance and its edges' systematic shifts
// (board_rect.cc). Not an API: only board_fit.cc and board_rect.cc use it.
#ifndef SWEEPSCAN_CORE_CALIBRATION_BOARD_RECT_H_
#define SWEEPSCAN_CORE_CALIBRATION_BOARD_RECT_H_

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "core/common/status.h"

namespace sweepscan::board_rect {

// Where a scan line leaves the board, in board coordinates. kUpper/kLower:
// the midpoint between where a line's outermost beam and its next beam
// cross the plane (error along the line, U(-s/2, s/2)). kLeft/kRight: a
// sample of the outermost line, moved out by half the line spacing (error
// across the lines, shared by the whole line).
enum class EdgeSide { kUpper, kLower, kLeft, kRight };
struct EdgePoint {
  Eigen::Vector2d uv;
  EdgeSide side;
  double weight;  // 1 / sigma^2
  // Largest offset from the true edge of a clean end: half the spacing
  // plus the noise of a crossing (LineEndPoints). A line whose outermost
  // straddling beam reported a mixed return ends up to a whole spacing short
  // or long (`off_a_sample` in FitRectangle: kept, and in the sigma);
  // beyond `limit`, a spacing more, the end is rejected (a dropout, a
  // foreign return).
  double clean_limit = std::numeric_limits<double>::infinity();
  double limit = std::numeric_limits<double>::infinity();
  // The board's thickness seen along this beam (LineEndPoints): an edge
  // whose outward normal N has N . shift > 0 faces the beam, which can hit
  // its edge face, and the hit/miss boundary lies `shift` beyond it.
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  double spacing = 0.0;  // s: the distance between the hit's and the miss's crossings
};

// A rectangle in the board plane: centre c, first axis at angle phi from u,
// half sizes a (along the first axis) and b. Edge k has the outward normal
// N_k at angle phi + pi/2 - k pi/2 (top, right, bottom, left for phi = 0)
// and offset h_k = b, a, b, a:  N_k . (p - c) = h_k.
struct Rect {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  double phi = 0.0, a = 0.0, b = 0.0;
};

// An edge crossed by the scan lines at less than 20 deg gets no end points
// (the crossing would be ill-defined); one within 20 deg of them gets the
// outermost lines' side points.
constexpr double kMinCrossing = 0.342;  // sin(20 deg)

// Edge k's outward normal under a rectangle turned by phi.
Eigen::Vector2d EdgeNormal(double phi, int k);
// The edge a point belongs to under `r`, -1 if none.
int AssignEdge(const Rect& r, const EdgePoint& p);
// Smallest-area bounding rectangle of the points: the start of the fit.
Rect BoundingRect(const std::vector<EdgePoint>& pts);
// The rectangle through the edge points (assignments, rejection of the
// implausible points); `edge_io[j]` the edge of point j or -1. `off_a_sample`:
// the kept points further than their clean limit from their edge.
Status FitRectangle(const std::vector<EdgePoint>& edge_points, Rect* rect_io, std::vector<int>* edge_io,
                    double* cost_io, std::vector<bool>* rejected, std::vector<bool>* off_a_sample);
// r with its parameter q of (c_u, c_v, a, b, phi) moved by delta.
Rect Perturbed(const Rect& r, int q, double delta);
inline constexpr double kRectStep = 1e-6;  // central differences: metres, radians
// Covariance of (c_u, c_v, a, b, phi) at the solution.
Eigen::Matrix<double, 5, 5> RectCovariance(const Rect& rect, const std::vector<EdgePoint>& pts,
                                           const std::vector<int>& edge);
// The edges' own systematic shifts (the shares of their ends a sample
// off, `shifted`) as a covariance.
Eigen::Matrix<double, 5, 5> EdgeShiftCovariance(const Rect& rect, const std::vector<EdgePoint>& pts,
                                                const std::vector<int>& edge, const std::vector<bool>& shifted);

}  // namespace sweepscan::board_rect

#endif  // SWEEPSCAN_CORE_CALIBRATION_BOARD_RECT_H_
