// The target board of one pass, fitted from raw samples re-projected under a
// candidate calibration (declared in board_fit.h). Plain Eigen: no Ceres
// here, the rectangle fit is a 1-D search over a linear least squares.
//
// Geometry. The scan plane is vertical, so on a vertical board every scan
// line is (nearly) a vertical line in board coordinates (u along, v up).
// Along a line the samples are 0.5 deg apart: 6 mm at 0.7 m, 21 mm at 2.4 m
// on the lab's board. Between lines the spacing is the robot's sweep: on the
// 0.83 m circle about 5 cm. An edge crossed by the lines is therefore seen
// at many places, each to within one sample spacing; an edge parallel to the
// lines is seen only as "between this line and the next".
//
// FitBoardCorners in three steps: the board's scan lines (plane, runs),
// edge extraction (where each line leaves the board), the corner model (a
// rectangle through the edge points) and its solve, which are in
// board_rect.{h,cc}.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <unordered_map>

#include "core/calibration/board_fit.h"
#include "core/calibration/board_rect.h"

namespace sweepscan {
namespace {

using board_rect::AssignEdge;
using board_rect::BoundingRect;
using board_rect::EdgeNormal;
using board_rect::EdgePoint;
using board_rect::EdgeShiftCovariance;
using board_rect::EdgeSide;
using board_rect::FitRectangle;
using board_rect::kMinCrossing;
using board_rect::kRectStep;
using board_rect::Perturbed;
using board_rect::Rect;
using board_rect::RectCovariance;

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double Theta(const LidarObservation& o) { return std::atan2(o.p_lidar.y(), o.p_lidar.z()); }
double AngleStep(const LidarObservation& a, const LidarObservation& b) {
  return std::abs(std::remainder(Theta(a) - Theta(b), 2.0 * M_PI));
}

// ----------------------------------------------------------------------------
// The board's scan lines

// The samples in the world under the calibration, with each sample's
// membership band.
void ProjectWithBands(const std::vector<LidarObservation>& samples, const RobotGeometry& geometry,
                      const MountingError& calibration, std::vector<Eigen::Vector3d>* pts,
                      std::vector<double>* band) {
  pts->reserve(samples.size());
  band->reserve(samples.size());
  for (const auto& s : samples) {
    pts->push_back(ProjectObservation(s, geometry, calibration));
    // 2.5 sigma of the X4's range noise (data sheet: 2 mm + 0.2 % of the
    // range; the beam meets the board nearly head-on). Tight on purpose: a
    // beam passing just below a bottom edge can hit the board's edge face,
    // up to its thickness behind the front; such a sample is no front-face
    // hit and should count as a miss (measured: a 20 mm board came out
    // 2-9 mm too large in the near pass; a 5 mm one does not).
    const double rho = s.p_lidar.norm();
    band->push_back(std::max(0.005, 2.5 * std::hypot(0.002, 0.002 * rho)));
  }
}

// The range noise as the samples show it: each band is the data sheet's
// 2.5 sigma, scaled by the robust spread (1.4826 MAD) of the residuals
// r_i / sigma_i of the samples within 3 cm of the plane when that spread
// exceeds 1 (at most 3). A lidar noisier than its data sheet would
// otherwise lose board samples from the tight band, break the scan lines'
// runs and shorten them: with 2.8 mm + 0.34 % of range noise the two
// passes' corners stayed 13 mm apart and the angles came out 8-15 mrad off
// (docs/results.md, "Robustness").
void ScaleBandsToNoise(const std::vector<Eigen::Vector3d>& pts, const Plane& plane,
                       std::vector<double>* band) {
  std::vector<double> z;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double r = plane.SignedDistance(pts[i]);
    if (std::abs(r) < 0.03) z.push_back(r / ((*band)[i] / 2.5));
  }
  if (z.size() < 20) return;
  const auto median = [](std::vector<double>* v) {
    std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
    return (*v)[v->size() / 2];
  };
  const double centre = median(&z);
  for (double& x : z) x = std::abs(x - centre);
  const double spread = 1.4826 * median(&z);
  if (!(spread > 1.0)) return;
  const double k = std::min(spread, 3.0);
  for (double& b : *band) b *= k;
}

// Plane: RANSAC with a 1 cm band (the lab's window sill is 2 cm behind the
// board, the wall 16 cm); FindBoardLines then refits it by least squares on
// the board's runs within each sample's own band.
Plane RansacBoardPlane(const std::vector<Eigen::Vector3d>& pts) {
  constexpr double kBand = 0.01;
  Plane plane;
  {
    std::mt19937 rng(1);
    std::uniform_int_distribution<size_t> pick(0, pts.size() - 1);
    size_t best = 0;
    Eigen::Vector3d best_n = Eigen::Vector3d::UnitY();
    double best_d = 0.0;
    for (int it = 0; it < 300; ++it) {
      const Eigen::Vector3d a = pts[pick(rng)], b = pts[pick(rng)], cc = pts[pick(rng)];
      Eigen::Vector3d nn = (b - a).cross(cc - a);
      if (nn.norm() < 1e-9) continue;
      nn.normalize();
      const double dd = -nn.dot(a);
      size_t count = 0;
      for (const auto& p : pts) count += std::abs(nn.dot(p) + dd) < kBand;
      if (count > best) best = count, best_n = nn, best_d = dd;
    }
    plane.normal = best_n;
    plane.d = best_d;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& p : pts) {
      if (std::abs(plane.SignedDistance(p)) < kBand) sum += p;
    }
    plane.centroid = sum / std::max<size_t>(1, best);
  }
  return plane;
}

// Board coordinates: n the plane's normal, u = normalize(z x n) along the
// board (n oriented so that u points along +x, or +y if the board faces x),
// v = n x u up, c the origin (the plane's centroid).
struct BoardFrame {
  Eigen::Vector3d n, u, v, c;
};

Status BoardFrameOf(const Plane& plane, BoardFrame* f) {
  Eigen::Vector3d& n = f->n;
  Eigen::Vector3d& u = f->u;
  n = plane.normal;
  u = Eigen::Vector3d::UnitZ().cross(n);
  if (u.norm() < 0.5) return Status::Error("board fit: the board is not vertical");
  u.normalize();
  const bool along_x = std::abs(u.x()) >= std::abs(u.y());
  if ((along_x && u.x() < 0) || (!along_x && u.y() < 0)) {
    n = -n;
    u = -u;
  }
  f->v = n.cross(u);
  f->c = plane.centroid;
  return Status::Ok();
}

// One scan line's samples on the board.
struct Line {
  std::vector<std::pair<Eigen::Vector2d, size_t>> uv;  // (u, v), sample index; sorted by v
  double mean_u = 0.0;
};

// The in-plane samples (within their band) grouped by scan line, in board
// coordinates.
std::vector<Line> InPlaneScanLines(const std::vector<LidarObservation>& samples,
                                   const std::vector<Eigen::Vector3d>& pts,
                                   const std::vector<double>& band, const Plane& plane,
                                   const BoardFrame& f) {
  std::vector<Line> lines;
  std::unordered_map<uint32_t, size_t> by_scan;
  for (size_t i = 0; i < pts.size(); ++i) {
    if (std::abs(plane.SignedDistance(pts[i])) >= band[i]) continue;
    const Eigen::Vector3d q = pts[i] - f.c;
    auto it = by_scan.find(samples[i].ref.scan);
    if (it == by_scan.end()) {
      it = by_scan.emplace(samples[i].ref.scan, lines.size()).first;
      lines.emplace_back();
    }
    lines[it->second].uv.push_back({Eigen::Vector2d(q.dot(f.u), q.dot(f.v)), i});
  }
  return lines;
}

// Per scan line the longest run of samples without a gap (the sill below
// the board, or a stray wall sample, must not become an end point); keeps
// the runs that reach the middle height of the longest run.
void KeepBoardRuns(const std::vector<LidarObservation>& samples, std::vector<Line>* lines_io) {
  std::vector<Line>& lines = *lines_io;
  double longest = -1.0, middle = 0.0;
  std::vector<double> steps;
  // The beam step: the median angle between neighbouring in-plane samples
  // of a line (scan angle theta = atan2(y_L, z_L), Eq. 1). A run ends where
  // more than one beam in a row is missing (one may be a dropout); a run on
  // the sill below, 7 cm lower, is then separate even if it has 1 sample.
  std::vector<double> line_steps;
  for (auto& l : lines) {
    std::sort(l.uv.begin(), l.uv.end(),
              [](const auto& x, const auto& y) { return x.first.y() < y.first.y(); });
    for (size_t i = 1; i < l.uv.size(); ++i) {
      line_steps.push_back(AngleStep(samples[l.uv[i].second], samples[l.uv[i - 1].second]));
    }
  }
  const double limit = 2.5 * Median(line_steps);
  for (auto& l : lines) {
    size_t best_begin = 0, best_len = 0, begin = 0;
    for (size_t i = 1; i <= l.uv.size(); ++i) {
      if (i == l.uv.size() ||
          AngleStep(samples[l.uv[i].second], samples[l.uv[i - 1].second]) > limit) {
        if (i - begin > best_len) best_len = i - begin, best_begin = begin;
        begin = i;
      }
    }
    l.uv = std::vector<std::pair<Eigen::Vector2d, size_t>>(l.uv.begin() + best_begin,
                                                           l.uv.begin() + best_begin + best_len);
    for (size_t i = 1; i < l.uv.size(); ++i) {
      steps.push_back(l.uv[i].first.y() - l.uv[i - 1].first.y());
    }
    const double span = l.uv.back().first.y() - l.uv.front().first.y();
    if (span > longest) {
      longest = span;
      middle = 0.5 * (l.uv.back().first.y() + l.uv.front().first.y());
    }
  }
  // A convex board is crossed by every one of its lines at the height of
  // its widest line's middle, give or take a sample spacing.
  const double margin = 2.0 * Median(steps) + 1e-3;
  lines.erase(std::remove_if(lines.begin(), lines.end(),
                             [&](const Line& l) {
                               return l.uv.size() < 2 ||
                                      l.uv.front().first.y() > middle + margin ||
                                      l.uv.back().first.y() < middle - margin;
                             }),
              lines.end());
}

// The board's plane, frame and scan lines (sorted by u, each with its mean
// u), and the samples on them (`keep`). Alternates: inliers of the plane ->
// per scan line the longest gap-free run -> keep the runs that reach the
// middle height of the longest run -> refit the plane on them. Three rounds.
Status FindBoardLines(const std::vector<LidarObservation>& samples,
                      const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& band,
                      Plane* plane_io, BoardFrame* f, std::vector<Line>* lines_io,
                      std::vector<size_t>* keep_io) {
  Plane& plane = *plane_io;
  std::vector<Line>& lines = *lines_io;
  std::vector<size_t>& keep = *keep_io;
  for (int round = 0; round < 3; ++round) {
    Status s = BoardFrameOf(plane, f);
    if (!s.ok()) return s;
    lines = InPlaneScanLines(samples, pts, band, plane, *f);
    KeepBoardRuns(samples, &lines);
    if (lines.size() < 3) {
      return Status::Error("board fit: the board was crossed by " + std::to_string(lines.size()) +
                           " scan lines, need at least 3");
    }
    keep.clear();
    std::vector<Eigen::Vector3d> in;
    for (const auto& l : lines) {
      for (const auto& p : l.uv) keep.push_back(p.second), in.push_back(pts[p.second]);
    }
    if (round < 2 && !FitPlane(in, &plane)) return Status::Error("board fit: degenerate samples");
  }
  plane.normal = f->n;
  plane.d = -f->n.dot(f->c);
  for (auto& l : lines) {
    for (const auto& p : l.uv) l.mean_u += p.first.x();
    l.mean_u /= l.uv.size();
  }
  std::sort(lines.begin(), lines.end(),
            [](const Line& x, const Line& y) { return x.mean_u < y.mean_u; });
  return Status::Ok();
}

// ----------------------------------------------------------------------------
// Edge extraction

// Whether the sample of the next beam beyond a line's end (sample `last`,
// `prev` the one before it on the line) is a mixed return: a triangulation
// lidar whose spot straddles the board's edge reports a blend of the board's
// and the background's ranges (docs/calibration.md, "Mixed returns"). Such a
// sample lies behind the board (beyond its band) and off the background, which
// the two beams after it show: extrapolated linearly to its beam, they miss it
// by more than kMixedJump, and the background lies at least that much further
// behind (or the background lies beyond the target's region, where the
// samples stop). A clean miss lies on the background; a mixed return
// reported at one surface's range cannot be told from a clean hit or miss.
// kMixedJump: the simulator's default depth step (a sill 2 cm behind the
// board is no background to tell a blend from).
constexpr double kMixedJump = 0.03;
template <typename Key>
bool IsMixedReturn(const std::vector<LidarObservation>& samples,
                   const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& band,
                   const Plane& plane, const Eigen::Vector3d& lidar,
                   const std::unordered_map<uint64_t, size_t>& by_beam, const Key& key, size_t last,
                   size_t prev) {
  const int dir = samples[last].ref.beam > samples[prev].ref.beam ? 1 : -1;
  const auto find = [&](int k) -> long {
    const auto it = by_beam.find(key(samples[last].ref.scan, samples[last].ref.beam + dir * k));
    return it == by_beam.end() ? -1 : static_cast<long>(it->second);
  };
  // Depth behind the board's front, seen from the lidar.
  const double side = plane.SignedDistance(lidar) > 0.0 ? -1.0 : 1.0;
  const auto depth = [&](long i) { return side * plane.SignedDistance(pts[i]); };
  const long q = find(1), n1 = find(2), n2 = find(3);
  if (q < 0 || !(depth(q) > std::max(band[q], kMixedJump))) return false;
  if (n1 >= 0) {
    if (!(depth(n1) > depth(q) + kMixedJump)) return false;  // q is on the background
    if (n2 < 0) return true;
    const Eigen::Vector3d background = 2.0 * pts[n1] - pts[n2];
    return (pts[q] - background).norm() > std::max(kMixedJump, 3.0 * band[q]);
  }
  if (n2 >= 0) return depth(n2) > depth(q) + kMixedJump;  // n1 lost (a dropout)
  // The background lies beyond the target's region (the samples stop at it):
  // q, inside it and behind the board, is between the two.
  return true;
}

// Each line's top and bottom end points: the midpoint between where the
// outermost sample's beam and the next beam of that scan cross the plane,
// with the board's thickness as each point's shift.
Status LineEndPoints(const std::vector<LidarObservation>& samples,
                     const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& band,
                     const std::vector<Line>& lines, const Plane& plane, const BoardFrame& f,
                     const Rigid3d& body_from_lidar, double board_thickness_m,
                     std::vector<EdgePoint>* edge_points_out, size_t* mixed_out) {
  const Eigen::Vector3d& u = f.u;
  const Eigen::Vector3d& v = f.v;
  const Eigen::Vector3d& c = f.c;
  auto theta = [&](size_t i) { return Theta(samples[i]); };
  std::vector<double> dthetas;
  for (const auto& l : lines) {
    for (size_t i = 1; i < l.uv.size(); ++i) {
      dthetas.push_back(AngleStep(samples[l.uv[i].second], samples[l.uv[i - 1].second]));
    }
  }
  const double dtheta = Median(dthetas);
  // Range noise in the board plane (X4 data sheet scale) adds to the
  // quantisation of each end point in its weight. A point further than
  // s/2 + kRejectNoise from its edge is a line that ended a spacing short or
  // long (a mixed return: kept, counted, in the sigma); one further than
  // s + kRejectNoise is rejected (FitRectangle).
  constexpr double kInPlaneNoise = 0.003;
  constexpr double kRejectNoise = 2.0 * kInPlaneNoise;
  std::vector<EdgePoint>& edge_points = *edge_points_out;
  std::unordered_map<uint64_t, size_t> by_beam;  // (scan, beam) -> sample
  const auto key = [](uint32_t scan, int beam) {
    return (static_cast<uint64_t>(scan) << 20) ^ static_cast<uint64_t>(beam & 0xfffff);
  };
  for (size_t i = 0; i < samples.size(); ++i) by_beam[key(samples[i].ref.scan, samples[i].ref.beam)] = i;
  *mixed_out = 0;
  for (const auto& l : lines) {
    for (int end = 0; end < 2; ++end) {
      const size_t last = end == 0 ? l.uv.size() - 1 : 0;
      const size_t prev = end == 0 ? l.uv.size() - 2 : 1;
      const size_t i = l.uv[last].second;
      const double step = std::remainder(theta(i) - theta(l.uv[prev].second), 2.0 * M_PI);
      if (!(std::abs(step) > 0.0) || !(dtheta > 0.0)) continue;
      // The next beam beyond the outermost sample, one local step further
      // (the step varies along the line with the triangulation correction;
      // the median step if a dropout left a gap).
      const double next =
          std::abs(step) > 0.5 * dtheta && std::abs(step) < 1.5 * dtheta ? step
                                                                         : std::copysign(dtheta, step);
      const Rigid3d world_from_lidar = samples[i].world_from_body * body_from_lidar;
      const Eigen::Vector3d o = world_from_lidar.translation();
      const auto beam = [&](double th) -> Eigen::Vector3d {
        return world_from_lidar.rotation() * Eigen::Vector3d(0.0, std::sin(th), std::cos(th));
      };
      // Where a beam from o crosses the plane: o + t d with n . (o + t d) + d0 = 0.
      const auto crossing = [&](const Eigen::Vector3d& d, Eigen::Vector2d* uv) {
        const double denom = plane.normal.dot(d);
        if (std::abs(denom) < 1e-6) return false;
        const double t = -plane.SignedDistance(o) / denom;
        if (!(t > 0.0)) return false;
        const Eigen::Vector3d q = o + t * d - c;
        *uv = Eigen::Vector2d(q.dot(u), q.dot(v));
        return true;
      };
      // Both ends of the interval are beam crossings, not the sample's
      // projection: a beam that hit the board's edge face (below) lies
      // beyond the edge where it crosses the front plane but projects onto
      // the edge itself, and the crossing does not carry the range noise.
      const Eigen::Vector3d hit_dir = beam(theta(i));
      Eigen::Vector2d hit_uv, miss_uv;
      if (!crossing(hit_dir, &hit_uv) || !crossing(beam(theta(i) + next), &miss_uv)) continue;
      const double s = (miss_uv - hit_uv).norm();
      if (s > 0.2) continue;  // grazing beam: no useful bound
      // A mixed return just beyond the line's end straddled the edge: the edge
      // lies within its footprint (one beam step), so its own crossing (the
      // next beam's, on the board's local step: its reported angle carries
      // the correction c of its blended range) is the edge point, error
      // U(-s/2, s/2) as for a midpoint.
      const bool mixed = IsMixedReturn(samples, pts, band, plane, o, by_beam, key, i,
                                       l.uv[prev].second);
      *mixed_out += mixed;

      EdgePoint p{mixed ? miss_uv : Eigen::Vector2d(0.5 * (hit_uv + miss_uv)),
                  end == 0 ? EdgeSide::kUpper : EdgeSide::kLower,
                  1.0 / (s * s / 12.0 + kInPlaneNoise * kInPlaneNoise),
                  0.5 * s + kRejectNoise, s + kRejectNoise};
      // The board's thickness T. A beam that crosses the front plane just
      // beyond an edge can still hit that edge's face, T deep, if going
      // deeper carries it back over the edge: per unit of depth the beam d
      // moves q = (d - (d.n) n) / |d.n| in the plane, so the hits reach the
      // edge line translated by D = -T q wherever N . D > 0 (N the edge's
      // outward normal: the bottom edges for a lidar below the board). The
      // midpoint above locates that boundary, so the edge is at mid - D
      // (OnEdge, once the point's edge is known). Such a hit projects onto
      // the edge, inside the band, and without this the bottom edges came
      // out half a beam step low (a 5 mm board 2-4 mm too large in the
      // near pass). Hits deeper than the sample's band are not on the
      // board's line, so T counts up to the band.
      const double depth = std::min(board_thickness_m, band[i]);
      const double dn = std::abs(plane.normal.dot(hit_dir));
      if (depth > 0.0 && dn > 1e-3) {
        const Eigen::Vector3d q = (hit_dir - plane.normal.dot(hit_dir) * plane.normal) / dn;
        p.shift = -depth * Eigen::Vector2d(q.dot(u), q.dot(v));
      }
      p.spacing = s;
      edge_points.push_back(p);
    }
  }
  if (edge_points.size() < 6) {
    return Status::Error("board fit: only " + std::to_string(edge_points.size()) +
                         " edge points, need at least 6");
  }
  return Status::Ok();
}

// Side points, only if an edge runs along the scan lines: the outermost
// lines' samples moved out by du/2 (the edge lies somewhere between the
// last line and the next one). The whole line shares one error of
// variance du^2/12, so its points together weigh as one observation.
void AddSidePoints(const std::vector<Line>& lines, const Rect& rect,
                   std::vector<EdgePoint>* edge_points) {
  std::vector<double> dus;
  for (size_t i = 1; i < lines.size(); ++i) dus.push_back(lines[i].mean_u - lines[i - 1].mean_u);
  const double du = Median(dus);
  const bool upright = std::abs(std::sin(rect.phi)) < kMinCrossing;
  if (upright) {
    for (int k = 0; k < 2; ++k) {
      const Line& l = k == 0 ? lines.front() : lines.back();
      const double shift = k == 0 ? -0.5 * du : 0.5 * du;
      const double w = 12.0 / (du * du * l.uv.size());
      for (const auto& p : l.uv) {
        edge_points->push_back({p.first + Eigen::Vector2d(shift, 0.0),
                                k == 0 ? EdgeSide::kLeft : EdgeSide::kRight, w});
      }
    }
  }
}

// ----------------------------------------------------------------------------
// Corners

// The rectangle's corners in the world, clockwise from the one nearest
// 112.5 deg, each with its nearest kept sample; and the rectangle's size
// and rotation.
// The rectangle's corners in the board plane, counter-clockwise from
// c + a e1 + b e2.
std::array<Eigen::Vector2d, 4> RectCorners(const Rect& rect) {
  const Eigen::Vector2d e1(std::cos(rect.phi), std::sin(rect.phi));
  const Eigen::Vector2d e2(-std::sin(rect.phi), std::cos(rect.phi));
  return {rect.c + rect.a * e1 + rect.b * e2, rect.c - rect.a * e1 + rect.b * e2,
          rect.c - rect.a * e1 - rect.b * e2, rect.c + rect.a * e1 - rect.b * e2};
}

Status CornersFromRect(const Rect& rect, const Eigen::Matrix<double, 5, 5>& rect_covariance,
                       const BoardFrame& f, const std::vector<Eigen::Vector3d>& pts,
                       const std::vector<size_t>& keep, BoardCorners* out) {
  const Eigen::Vector3d& u = f.u;
  const Eigen::Vector3d& v = f.v;
  const Eigen::Vector3d& c = f.c;
  const std::array<Eigen::Vector2d, 4> uv = RectCorners(rect);
  std::array<double, 4> ang;
  for (int k = 0; k < 4; ++k) ang[k] = std::atan2(uv[k].y() - rect.c.y(), uv[k].x() - rect.c.x());
  int first = 0;
  for (int k = 1; k < 4; ++k) {
    if (std::abs(std::remainder(ang[k] - 5 * M_PI / 8, 2 * M_PI)) <
        std::abs(std::remainder(ang[first] - 5 * M_PI / 8, 2 * M_PI))) {
      first = k;
    }
  }
  // uv[] runs counter-clockwise (first axis, then +90 deg steps); walk it
  // backwards. G: the world corners' derivatives by the rectangle's
  // parameters (central differences), for their covariance G C G^T.
  Eigen::Matrix<double, 12, 5> g;
  for (int q = 0; q < 5; ++q) {
    const std::array<Eigen::Vector2d, 4> a = RectCorners(Perturbed(rect, q, -kRectStep));
    const std::array<Eigen::Vector2d, 4> b = RectCorners(Perturbed(rect, q, kRectStep));
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d d =
          (b[(first - k + 4) % 4] - a[(first - k + 4) % 4]) / (2.0 * kRectStep);
      g.block<3, 1>(3 * k, q) = d.x() * u + d.y() * v;
    }
  }
  out->covariance = g * rect_covariance * g.transpose();
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d& p = uv[(first - k + 4) % 4];
    out->corners[k] = c + p.x() * u + p.y() * v;
    if (!out->corners[k].allFinite()) return Status::Error("board fit: corners are not finite");
    double best = std::numeric_limits<double>::infinity();
    for (size_t i : keep) {
      const double d = (pts[i] - out->corners[k]).squaredNorm();
      if (d < best) best = d, out->nearest[k] = i;
    }
  }
  // Report the rectangle with its rotation in [-pi/4, pi/4).
  double phi = std::remainder(rect.phi, M_PI / 2);
  const bool swapped = std::abs(std::remainder(rect.phi - phi, M_PI)) > 1e-9;
  if (phi >= M_PI / 4) phi -= M_PI / 2;
  out->rotation_rad = phi;
  out->size_m = swapped ? Eigen::Vector2d(2 * rect.b, 2 * rect.a)
                        : Eigen::Vector2d(2 * rect.a, 2 * rect.b);
  return Status::Ok();
}

}  // namespace

Status FitBoardCorners(const std::vector<LidarObservation>& samples, const RobotGeometry& geometry,
                       const MountingError& calibration, double board_thickness_m,
                       BoardCorners* out) {
  if (!(board_thickness_m >= 0.0)) return Status::Error("board fit: the board's thickness must be >= 0");
  if (samples.size() < 20) {
    return Status::Error("board fit: " + std::to_string(samples.size()) +
                         " samples, need at least 20");
  }
  const Rigid3d body_from_lidar = BodyFromLidar(geometry, calibration);
  std::vector<Eigen::Vector3d> pts;
  std::vector<double> band;  // membership band of each sample
  ProjectWithBands(samples, geometry, calibration, &pts, &band);
  // The board's scan lines.
  Plane plane = RansacBoardPlane(pts);
  ScaleBandsToNoise(pts, plane, &band);
  BoardFrame frame;
  std::vector<Line> lines;
  std::vector<size_t> keep;
  Status s = FindBoardLines(samples, pts, band, &plane, &frame, &lines, &keep);
  if (!s.ok()) return s;
  // Edge extraction.
  std::vector<EdgePoint> edge_points;
  size_t mixed = 0;
  s = LineEndPoints(samples, pts, band, lines, plane, frame, body_from_lidar, board_thickness_m,
                    &edge_points, &mixed);
  if (!s.ok()) return s;
  Rect rect = BoundingRect(edge_points);
  AddSidePoints(lines, rect, &edge_points);
  // The corner model and its solve.
  std::vector<int> edge;
  double cost = 0.0;
  std::vector<bool> rejected, off_a_sample;
  s = FitRectangle(edge_points, &rect, &edge, &cost, &rejected, &off_a_sample);
  if (!s.ok()) return s;
  std::vector<bool> shifted(edge_points.size());
  for (size_t j = 0; j < shifted.size(); ++j) shifted[j] = rejected[j] || off_a_sample[j];
  s = CornersFromRect(rect,
                      RectCovariance(rect, edge_points, edge) +
                          EdgeShiftCovariance(rect, edge_points, edge, shifted),
                      frame, pts, keep, out);
  if (!s.ok()) return s;
  size_t used = 0;
  for (int e : edge) used += e >= 0;
  out->edge_points = used;
  out->rejected_edge_points = static_cast<size_t>(std::count(rejected.begin(), rejected.end(), true));
  out->shifted_edge_points =
      static_cast<size_t>(std::count(off_a_sample.begin(), off_a_sample.end(), true));
  out->mixed_edge_samples = mixed;
  double wsum = 0.0;
  for (size_t j = 0; j < edge_points.size(); ++j) wsum += edge[j] >= 0 ? edge_points[j].weight : 0;
  out->edge_rms_m = wsum > 0.0 ? std::sqrt(cost / wsum) : 0.0;
  out->plane = plane;
  out->points = keep.size();
  out->scans = lines.size();
  return Status::Ok();
}

TargetSightings CollectTargetSightings(const SampleStore& store, const RobotGeometry& geometry,
                                       const MountingError& calibration,
                                       const Eigen::AlignedBox3d& region, double gap_s,
                                       size_t min_count) {
  TargetSightings out;
  std::vector<CloudPoint> cloud;
  cloud.reserve(store.observations().size());
  for (const auto& o : store.observations()) {
    const Eigen::Vector3d p = ProjectObservation(o, geometry, calibration);
    CloudPoint q;
    q.x = static_cast<float>(p.x());
    q.y = static_cast<float>(p.y());
    q.z = static_cast<float>(p.z());
    q.time_ns = o.time_ns;
    cloud.push_back(q);
  }
  out.windows = FindPassWindows(cloud, region, gap_s, min_count);
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!region.contains(Eigen::Vector3d(cloud[i].x, cloud[i].y, cloud[i].z))) continue;
    const int k = PassOfTime(out.windows, cloud[i].time_ns);
    if (k >= 0) out.passes[k % 2].push_back(store.observations()[i]);
  }
  return out;
}

double CornerRms(const BoardCorners& a, const BoardCorners& b) {
  double s = 0.0;
  for (int k = 0; k < 4; ++k) s += (a.corners[k] - b.corners[k]).squaredNorm();
  return std::sqrt(s / 4.0);
}

}  // namespace sweepscan
