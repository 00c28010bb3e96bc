// The target board's rectangle (board_rect.h): the model's residuals and
// its linear solve at a fixed rotation, the golden-section search of the
// rotation, the fit with assignments and rejection, its covariance and the
// edges' systematic shifts. Split from board_fit.cc (edge extraction and
// the corners in the world), whose header comment gives the geometry.
#include "core/calibration/board_rect.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <utility>

namespace sweepscan::board_rect {
// The point on edge k that p stands for: p itself, or p moved back by its
// shift when the edge faces the beam (see LineEndPoints).
Eigen::Vector2d OnEdge(const EdgePoint& p, const Eigen::Vector2d& edge_normal) {
  return edge_normal.dot(p.shift) > 0.0 ? Eigen::Vector2d(p.uv - p.shift) : p.uv;
}

Eigen::Vector2d EdgeNormal(double phi, int k) {
  const double ang = phi + M_PI / 2 - k * M_PI / 2;
  return {std::cos(ang), std::sin(ang)};
}


// The edge a point belongs to under `r`: for an end point, the edge where
// its (vertical) scan line crosses the rectangle's boundary on that side;
// for a side point, where its horizontal line does. -1 if none.
int AssignEdge(const Rect& r, const EdgePoint& p) {
  const bool vertical = p.side == EdgeSide::kUpper || p.side == EdgeSide::kLower;
  const double sign = (p.side == EdgeSide::kUpper || p.side == EdgeSide::kRight) ? 1.0 : -1.0;
  int best = -1;
  double best_pos = 0.0;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d n = EdgeNormal(r.phi, k);
    const double h = (k % 2 == 0) ? r.b : r.a;
    // Along the line: the coordinate where it meets edge k.
    const double along = vertical ? n.y() : n.x();
    if (sign * along < kMinCrossing) continue;
    const double pos = vertical ? r.c.y() + (h - n.x() * (p.uv.x() - r.c.x())) / n.y()
                                : r.c.x() + (h - n.y() * (p.uv.y() - r.c.y())) / n.x();
    // Upper (right) boundary: the lowest (leftmost) such crossing.
    if (best < 0 || sign * pos < sign * best_pos) best = k, best_pos = pos;
  }
  return best;
}

// Offset of p along its line from edge k of r (what SolveForPhi minimises).
double Residual(const Rect& r, const EdgePoint& p, int k) {
  const Eigen::Vector2d n = EdgeNormal(r.phi, k);
  const double h = (k % 2 == 0) ? r.b : r.a;
  const Eigen::Vector2d q = OnEdge(p, n);
  if (p.side == EdgeSide::kUpper || p.side == EdgeSide::kLower) {
    return q.y() - (r.c.y() + (h - n.x() * (q.x() - r.c.x())) / n.y());
  }
  return q.x() - (r.c.x() + (h - n.y() * (q.y() - r.c.y())) / n.x());
}

// For fixed phi and assignments the offsets of the edge points along their
// lines are linear in x = (c_u, c_v, a, b). Edge k crossed by a vertical line
// at u: v = c_v + (h_k - N_u (u - c_u)) / N_v, so the residual is
//   r = (v + N_u/N_v u) - [N_u/N_v, 1, h-selector / N_v] x,
// and likewise with u and v exchanged for side points. Returns the weighted
// cost; false if x is not determined (no points on some pair of edges).
bool SolveForPhi(double phi, const std::vector<EdgePoint>& pts, const std::vector<int>& edge,
                 Rect* r, double* cost) {
  Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
  Eigen::Vector4d aty = Eigen::Vector4d::Zero();
  std::vector<std::pair<Eigen::Vector4d, double>> rows(pts.size());
  for (size_t j = 0; j < pts.size(); ++j) {
    rows[j].second = std::numeric_limits<double>::quiet_NaN();
    if (edge[j] < 0) continue;
    const int k = edge[j];
    const Eigen::Vector2d n = EdgeNormal(phi, k);
    const bool vertical = pts[j].side == EdgeSide::kUpper || pts[j].side == EdgeSide::kLower;
    const double along = vertical ? n.y() : n.x(), across = vertical ? n.x() : n.y();
    if (std::abs(along) < 0.5 * kMinCrossing) continue;  // phi moved too far for this edge
    Eigen::Vector4d a;
    if (vertical) {
      a << across / along, 1.0, 0.0, 0.0;
    } else {
      a << 1.0, across / along, 0.0, 0.0;
    }
    a[(k % 2 == 0) ? 3 : 2] = 1.0 / along;
    const Eigen::Vector2d q = OnEdge(pts[j], n);
    const double y = vertical ? q.y() + across / along * q.x() : q.x() + across / along * q.y();
    rows[j] = {a, y};
    ata += pts[j].weight * a * a.transpose();
    aty += pts[j].weight * y * a;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(ata);
  if (eig.eigenvalues().minCoeff() <= 1e-9 * std::max(1.0, eig.eigenvalues().maxCoeff())) {
    return false;
  }
  const Eigen::Vector4d x = ata.ldlt().solve(aty);
  double c = 0.0;
  for (size_t j = 0; j < pts.size(); ++j) {
    if (std::isnan(rows[j].second)) continue;
    const double res = rows[j].second - rows[j].first.dot(x);
    c += pts[j].weight * res * res;
  }
  r->c = x.head<2>();
  r->a = x[2];
  r->b = x[3];
  r->phi = phi;
  *cost = c;
  return r->a > 0.0 && r->b > 0.0;
}

// Smallest-area bounding rectangle of the points over phi in [-pi/4, pi/4)
// (0.5 deg steps): the start of the least-squares fit. A square's inertia
// is isotropic, so principal axes would not give its rotation.
Rect BoundingRect(const std::vector<EdgePoint>& pts) {
  Rect best;
  double best_area = std::numeric_limits<double>::infinity();
  for (int i = -90; i < 90; ++i) {
    const double phi = i * M_PI / 360.0;
    const Eigen::Vector2d e1(std::cos(phi), std::sin(phi)), e2(-std::sin(phi), std::cos(phi));
    double lo1 = 1e9, hi1 = -1e9, lo2 = 1e9, hi2 = -1e9;
    for (const auto& p : pts) {
      lo1 = std::min(lo1, p.uv.dot(e1)), hi1 = std::max(hi1, p.uv.dot(e1));
      lo2 = std::min(lo2, p.uv.dot(e2)), hi2 = std::max(hi2, p.uv.dot(e2));
    }
    const double area = (hi1 - lo1) * (hi2 - lo2);
    if (area < best_area) {
      best_area = area;
      best.phi = phi;
      best.a = 0.5 * (hi1 - lo1);
      best.b = 0.5 * (hi2 - lo2);
      best.c = 0.5 * (lo1 + hi1) * e1 + 0.5 * (lo2 + hi2) * e2;
    }
  }
  return best;
}


// ----------------------------------------------------------------------------
// The corner model's solve

// Golden-section search of phi within +-3 deg of the current rotation, then
// the rectangle at the best phi; false if that rectangle is not determined.
bool SolveRectangle(const std::vector<EdgePoint>& edge_points, const std::vector<int>& edge,
                    Rect* rect, double* cost) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = rect->phi - 0.05, hi = rect->phi + 0.05;
  auto f = [&](double phi) {
    Rect r;
    double cst;
    return SolveForPhi(phi, edge_points, edge, &r, &cst) ? cst
                                                         : std::numeric_limits<double>::max();
  };
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int it = 0; it < 40; ++it) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = f(x2);
    }
  }
  return SolveForPhi(0.5 * (lo + hi), edge_points, edge, rect, cost);
}

// The rectangle through the edge points: assign points to edges, solve,
// repeat until the assignment holds. Then reject the implausible points
// (further from their edge than EdgePoint::limit) and fit again, until the
// rejected set holds or after kRejectRounds fits (2: reject once). A clean
// end point lies within s/2 (plus noise) of its edge. At a depth edge
// exactly one beam straddles the edge, and a triangulation lidar may report
// it mixed: a blend or the far surface's range (the line ends a spacing
// short), or the board's range for a beam whose centre missed it (a spacing
// long); its end then lies s/2 to s off, on either side (docs/calibration.md,
// "Mixed returns"). Those ends are kept: rejecting them at s/2 + noise
// (until 2026-11-27) cut the far side of the scatter around the first fit's
// edge and pulled the edge further that way (seeds 1-30 of the refined
// sweep: alpha 3.25 -> 2.33 mrad RMS, 9.29 -> 4.91 worst, kept). They are
// counted in `off_a_sample`, whose share per edge widens the sigma
// (EdgeShiftCovariance). Only a line more than a spacing off, which no
// single straddling beam makes (a dropout beside the edge, a foreign
// return), is rejected. `edge[j]`: the edge of point j, -1 if none (or an
// outlier); `rejected`: the points the final fit rejected.
constexpr int kRejectRounds = 2;
Status FitRectangle(const std::vector<EdgePoint>& edge_points, Rect* rect_io,
                    std::vector<int>* edge_io, double* cost_io, std::vector<bool>* rejected,
                    std::vector<bool>* off_a_sample) {
  Rect& rect = *rect_io;
  std::vector<int>& edge = *edge_io;
  double& cost = *cost_io;
  edge.assign(edge_points.size(), -1);
  std::vector<bool> outlier(edge_points.size(), false);
  cost = 0.0;
  // The last fit that worked, kept in case rejecting points leaves an edge
  // without points (a sparse pass: the rectangle is then that fit).
  Rect kept_rect;
  std::vector<int> kept_edge;
  std::vector<bool> kept_outlier;
  double kept_cost = 0.0;
  for (int pass = 0; pass < kRejectRounds; ++pass) {
    bool failed = false;
    for (int round = 0; round < 8 && !failed; ++round) {
      bool changed = round == 0;
      for (size_t j = 0; j < edge_points.size(); ++j) {
        const int e = outlier[j] ? -1 : AssignEdge(rect, edge_points[j]);
        changed |= e != edge[j];
        edge[j] = e;
      }
      if (!changed) break;
      if (!SolveRectangle(edge_points, edge, &rect, &cost)) failed = true;
    }
    if (failed) {
      if (pass == 0) {
        return Status::Error(
            "board fit: the edge points do not determine a rectangle (an edge without points)");
      }
      rect = kept_rect, edge = kept_edge, cost = kept_cost, outlier = kept_outlier;
      break;
    }
    kept_rect = rect, kept_edge = edge, kept_cost = cost, kept_outlier = outlier;
    if (pass + 1 == kRejectRounds) break;
    std::vector<bool> next(edge_points.size(), false);
    for (size_t j = 0; j < edge_points.size(); ++j) {
      const int e = edge[j] >= 0 ? edge[j] : (outlier[j] ? AssignEdge(rect, edge_points[j]) : -1);
      next[j] = e >= 0 && std::abs(Residual(rect, edge_points[j], e)) > edge_points[j].limit;
    }
    if (next == outlier) break;
    outlier = next;
  }
  *rejected = outlier;
  off_a_sample->assign(edge_points.size(), false);
  for (size_t j = 0; j < edge_points.size(); ++j) {
    (*off_a_sample)[j] =
        edge[j] >= 0 && std::abs(Residual(rect, edge_points[j], edge[j])) > edge_points[j].clean_limit;
  }
  return Status::Ok();
}

Rect Perturbed(const Rect& r, int q, double delta) {
  Rect out = r;
  double* p[5] = {&out.c.x(), &out.c.y(), &out.a, &out.b, &out.phi};
  *p[q] += delta;
  return out;
}

// Covariance of the rectangle's parameters (c_u, c_v, a, b, phi) at the
// solution, for the assignment `edge`: (J^T W J)^-1 with J the residuals'
// derivatives (central differences), scaled by chi^2 / dof when above 1
// (the edge points scatter more than their model: noise, a rough edge).
Eigen::Matrix<double, 5, 5> RectCovariance(const Rect& rect, const std::vector<EdgePoint>& pts,
                                           const std::vector<int>& edge) {
  Eigen::Matrix<double, 5, 5> n = Eigen::Matrix<double, 5, 5>::Zero();
  double chi2 = 0.0;
  int used = 0;
  for (size_t j = 0; j < pts.size(); ++j) {
    if (edge[j] < 0) continue;
    Eigen::Matrix<double, 5, 1> g;
    for (int q = 0; q < 5; ++q) {
      g[q] = (Residual(Perturbed(rect, q, kRectStep), pts[j], edge[j]) -
              Residual(Perturbed(rect, q, -kRectStep), pts[j], edge[j])) /
             (2.0 * kRectStep);
    }
    n += pts[j].weight * g * g.transpose();
    const double r = Residual(rect, pts[j], edge[j]);
    chi2 += pts[j].weight * r * r;
    ++used;
  }
  const double scale = used > 5 ? std::max(1.0, chi2 / (used - 5)) : 1.0;
  Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(n);
  if (!lu.isInvertible()) return Eigen::Matrix<double, 5, 5>::Zero();
  return scale * lu.inverse();
}

// The edges' own systematic shifts. The ends a sample off (FitRectangle),
// rejected or kept, are lines that ended a spacing short or long: mixed
// returns at the board's depth edges, dropouts. They need not balance: a
// blended return only ever shortens a line, and as many again may sit
// within the clean limit. So each edge k may sit off by up to its share
// rho_k of such ends times its mean spacing s_k, taken as a 1-sigma shift
// sigma_k = rho_k s_k / 2 along its normal, independent between edges. Edge
// k moved by d with the others fixed moves the centre by d/2 N_k and its
// half size h_k by d/2, so cov += sum_k sigma_k^2 g_k g_k^T with
// g_k = (N_k / 2, [k odd] / 2, [k even] / 2, 0) over (c_u, c_v, a, b, phi).
// Shifts shared by all edges of both passes are not in it: see
// docs/calibration.md, "Mixed returns".
Eigen::Matrix<double, 5, 5> EdgeShiftCovariance(const Rect& rect,
                                                 const std::vector<EdgePoint>& pts,
                                                 const std::vector<int>& edge,
                                                 const std::vector<bool>& shifted) {
  double kept[4] = {0, 0, 0, 0}, off[4] = {0, 0, 0, 0}, spacing[4] = {0, 0, 0, 0};
  for (size_t j = 0; j < pts.size(); ++j) {
    const int k = edge[j] >= 0 ? edge[j] : (shifted[j] ? AssignEdge(rect, pts[j]) : -1);
    if (k < 0) continue;
    (shifted[j] ? off : kept)[k] += 1.0;
    spacing[k] += pts[j].spacing;
  }
  Eigen::Matrix<double, 5, 5> cov = Eigen::Matrix<double, 5, 5>::Zero();
  for (int k = 0; k < 4; ++k) {
    const double n = kept[k] + off[k];
    if (n <= 0.0) continue;
    const double sigma = 0.5 * off[k] / n * spacing[k] / n;
    Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
    g.head<2>() = 0.5 * EdgeNormal(rect.phi, k);
    g[(k % 2 == 0) ? 3 : 2] = 0.5;
    cov += sigma * sigma * g * g.transpose();
  }
  return cov;
}

}  // namespace sweepscan::board_rect
