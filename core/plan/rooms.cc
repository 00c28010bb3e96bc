// Room outlines (rooms.h): the raster, its regions, and each region's
// boundary snapped to the face lines that bound it.
#include "core/plan/rooms.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>

#include "core/geometry/polyline.h"

namespace sweepscan::plan {
namespace {

// A face is extended by this at both ends: two faces fitted to a corner's
// walls stop a few centimetres short of it (the corner's points are shared
// and the runs' ends are their last points), and a gap of a cell lets a
// room flow into its neighbour. Longer than any such gap, shorter than a
// door (0.6 m), which stays open for the opening's own line to close.
constexpr double kCornerGap = 0.15;
// A boundary point takes a face's line within this distance: the traced
// boundary runs one to two cells (5-10 cm) off the face, and a door closed
// on its wall's centre line half a wall (<= 0.2 m) further.
constexpr double kSnap = 0.25;
// Runs of one line shorter than this are absorbed by their neighbours (the
// staircase of a raster corner; a jamb's end).
constexpr double kMinSide = 0.2;
// Two consecutive lines closer to parallel than this are a jog, not a corner.
constexpr double kMinCornerSine = 0.34;  // 20 deg
// A face bounds a region when the point this far in front of it (on its free
// side) lies in the region: past the barrier's one-cell growth.
constexpr double kProbe = 0.15;
constexpr double kProbeStep = 0.1;
constexpr int kMinProbes = 3;
// A region is a room when faces seen from inside bound this much of its
// traced perimeter.
constexpr double kMinSeenPerimeter = 0.5;
// Above this many cells the raster is coarsened (a 700 m square floor at
// 5 cm): memory stays below ~100 MB whatever the plan.
constexpr int64_t kMaxCells = 50'000'000;

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

class Raster {
 public:
  Raster(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double cell) {
    const double margin = 3 * cell + kCornerGap;
    origin_ = lo - Eigen::Vector2d::Constant(margin);
    const Eigen::Vector2d size = hi - lo + Eigen::Vector2d::Constant(2 * margin);
    cell_ = cell;
    while (static_cast<int64_t>(std::ceil(size.x() / cell_)) * static_cast<int64_t>(std::ceil(size.y() / cell_)) >
           kMaxCells) {
      cell_ *= 2.0;
    }
    nx_ = static_cast<int>(std::ceil(size.x() / cell_));
    ny_ = static_cast<int>(std::ceil(size.y() / cell_));
    label_.assign(static_cast<size_t>(nx_) * ny_, kFree);
  }

  static constexpr int kFree = -1;
  static constexpr int kBarrier = -2;
  static constexpr int kOutside = -3;

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double cell() const { return cell_; }
  bool Inside(int i, int j) const { return i >= 0 && j >= 0 && i < nx_ && j < ny_; }
  int& At(int i, int j) { return label_[static_cast<size_t>(j) * nx_ + i]; }
  int At(int i, int j) const { return label_[static_cast<size_t>(j) * nx_ + i]; }
  // The label of the cell holding p (kOutside off the raster).
  int Of(const Eigen::Vector2d& p) const {
    const int i = static_cast<int>(std::floor((p.x() - origin_.x()) / cell_));
    const int j = static_cast<int>(std::floor((p.y() - origin_.y()) / cell_));
    return Inside(i, j) ? At(i, j) : kOutside;
  }
  Eigen::Vector2d Corner(int i, int j) const { return origin_ + cell_ * Eigen::Vector2d(i, j); }

  // Marks every cell the segment a -> b passes through (quarter-cell steps).
  void Segment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const int steps = std::max(1, static_cast<int>(std::ceil(4.0 * (b - a).norm() / cell_)));
    for (int k = 0; k <= steps; ++k) Mark(a + (b - a) * (static_cast<double>(k) / steps));
  }
  // Marks the band of half width w either side of a -> b.
  void Band(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double w) {
    const Eigen::Vector2d u = (b - a).normalized(), n(-u.y(), u.x());
    const int across = std::max(1, static_cast<int>(std::ceil(4.0 * w / cell_)));
    for (int k = -across; k <= across; ++k) {
      const Eigen::Vector2d shift = n * (w * k / across);
      Segment(a + shift, b + shift);
    }
  }
  // Every barrier grown by one cell (8-neighbours).
  void Grow() {
    std::vector<int> grown = label_;
    for (int j = 0; j < ny_; ++j) {
      for (int i = 0; i < nx_; ++i) {
        if (At(i, j) != kBarrier) continue;
        for (int dj = -1; dj <= 1; ++dj) {
          for (int di = -1; di <= 1; ++di) {
            if (Inside(i + di, j + dj)) grown[static_cast<size_t>(j + dj) * nx_ + i + di] = kBarrier;
          }
        }
      }
    }
    label_ = std::move(grown);
  }

 private:
  void Mark(const Eigen::Vector2d& p) {
    const int i = static_cast<int>(std::floor((p.x() - origin_.x()) / cell_));
    const int j = static_cast<int>(std::floor((p.y() - origin_.y()) / cell_));
    if (Inside(i, j)) At(i, j) = kBarrier;
  }

  Eigen::Vector2d origin_;
  double cell_ = 0.05;
  int nx_ = 0, ny_ = 0;
  std::vector<int> label_;  // kFree, kBarrier, kOutside or a region's index
};

struct Region {
  std::vector<std::pair<int, int>> cells;
  bool touches_edge = false;
};

// (2) 4-connected free regions, labelled in place; regions touching the
// raster's edge relabelled kOutside.
std::vector<Region> Regions(Raster* r) {
  std::vector<Region> regions;
  std::deque<std::pair<int, int>> queue;
  for (int j = 0; j < r->ny(); ++j) {
    for (int i = 0; i < r->nx(); ++i) {
      if (r->At(i, j) != Raster::kFree) continue;
      const int id = static_cast<int>(regions.size());
      regions.emplace_back();
      Region& region = regions.back();
      r->At(i, j) = id;
      queue.emplace_back(i, j);
      while (!queue.empty()) {
        const auto [ci, cj] = queue.front();
        queue.pop_front();
        region.cells.emplace_back(ci, cj);
        region.touches_edge = region.touches_edge || ci == 0 || cj == 0 || ci == r->nx() - 1 || cj == r->ny() - 1;
        const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
        for (int k = 0; k < 4; ++k) {
          const int ni = ci + di[k], nj = cj + dj[k];
          if (r->Inside(ni, nj) && r->At(ni, nj) == Raster::kFree) {
            r->At(ni, nj) = id;
            queue.emplace_back(ni, nj);
          }
        }
      }
    }
  }
  for (Region& region : regions) {
    if (!region.touches_edge) continue;
    for (const auto& [i, j] : region.cells) r->At(i, j) = Raster::kOutside;
  }
  return regions;
}

// (3) The region's outer boundary: directed cell edges with the region on
// the left, chained at lattice corners (a left turn first where two edges
// leave one corner, so that regions touching diagonally stay apart); the
// loop of largest positive area is the outer one (holes run clockwise).
std::vector<Eigen::Vector2d> OuterBoundary(const Raster& r, int id, const Region& region) {
  struct Edge {
    int x0, y0, x1, y1;
  };
  std::vector<Edge> edges;
  const auto in = [&](int i, int j) { return r.Inside(i, j) && r.At(i, j) == id; };
  for (const auto& [i, j] : region.cells) {
    if (!in(i, j - 1)) edges.push_back({i, j, i + 1, j});
    if (!in(i + 1, j)) edges.push_back({i + 1, j, i + 1, j + 1});
    if (!in(i, j + 1)) edges.push_back({i + 1, j + 1, i, j + 1});
    if (!in(i - 1, j)) edges.push_back({i, j + 1, i, j});
  }
  const auto key = [](int x, int y) { return (static_cast<uint64_t>(static_cast<uint32_t>(x)) << 32) | static_cast<uint32_t>(y); };
  std::unordered_map<uint64_t, std::vector<size_t>> from;
  for (size_t e = 0; e < edges.size(); ++e) from[key(edges[e].x0, edges[e].y0)].push_back(e);
  std::vector<char> used(edges.size(), 0);
  std::vector<Eigen::Vector2d> best;
  double best_area = 0.0;
  for (size_t start = 0; start < edges.size(); ++start) {
    if (used[start]) continue;
    std::vector<std::pair<int, int>> loop;
    size_t e = start;
    while (!used[e]) {
      used[e] = 1;
      loop.emplace_back(edges[e].x0, edges[e].y0);
      const int dx = edges[e].x1 - edges[e].x0, dy = edges[e].y1 - edges[e].y0;
      size_t next = e;
      int next_turn = -2;
      for (size_t c : from[key(edges[e].x1, edges[e].y1)]) {
        if (used[c] && c != start) continue;
        const int cx = edges[c].x1 - edges[c].x0, cy = edges[c].y1 - edges[c].y0;
        const int turn = dx * cy - dy * cx;  // +1 left, 0 straight, -1 right
        if (turn > next_turn) {
          next_turn = turn;
          next = c;
        }
      }
      if (next == e) break;
      e = next;
    }
    double twice_area = 0.0;
    for (size_t k = 0; k < loop.size(); ++k) {
      const auto& [x0, y0] = loop[k];
      const auto& [x1, y1] = loop[(k + 1) % loop.size()];
      twice_area += static_cast<double>(x0) * y1 - static_cast<double>(x1) * y0;
    }
    if (twice_area > best_area) {
      best_area = twice_area;
      best.clear();
      for (const auto& [x, y] : loop) best.push_back(r.Corner(x, y));
    }
  }
  return best;
}

// A face line bounding a region: the points-weighted mean of its faces'
// (collinear faces of one fitted line) and their extent along it.
struct BoundLine {
  Eigen::Vector2d c = Eigen::Vector2d::Zero(), u = Eigen::Vector2d::UnitX();
  double t0 = 0.0, t1 = 0.0;
  Eigen::Vector2d n() const { return {-u.y(), u.x()}; }
  Eigen::Vector2d Foot(const Eigen::Vector2d& p) const { return c + u * u.dot(p - c); }
};

void DouglasPeucker(const std::vector<Eigen::Vector2d>& p, size_t a, size_t b, double tol, std::vector<char>* keep) {
  if (b <= a + 1) return;
  const Eigen::Vector2d d = p[b] - p[a];
  const double len = d.norm();
  double worst = -1.0;
  size_t at = a;
  for (size_t k = a + 1; k < b; ++k) {
    const double dist = len > 1e-12 ? std::abs(Cross(d, p[k] - p[a])) / len : (p[k] - p[a]).norm();
    if (dist > worst) {
      worst = dist;
      at = k;
    }
  }
  if (worst <= tol) return;
  (*keep)[at] = 1;
  DouglasPeucker(p, a, at, tol, keep);
  DouglasPeucker(p, at, b, tol, keep);
}

// The outline from the traced boundary and the lines bounding the region.
std::vector<Eigen::Vector2d> Outline(const std::vector<Eigen::Vector2d>& boundary,
                                     const std::vector<BoundLine>& lines, double cell) {
  const size_t n = boundary.size();
  std::vector<int> label(n, -1);
  for (size_t k = 0; k < n; ++k) {
    double best = kSnap;
    for (size_t l = 0; l < lines.size(); ++l) {
      const double t = lines[l].u.dot(boundary[k] - lines[l].c);
      if (t < lines[l].t0 - kSnap || t > lines[l].t1 + kSnap) continue;
      const double d = std::abs(lines[l].n().dot(boundary[k] - lines[l].c));
      if (d <= best) {
        best = d;
        label[k] = static_cast<int>(l);
      }
    }
  }
  // A face seen only in part (its corner hidden behind a cabinet, the far
  // end of a corridor out of reach) still bounds the room up to the next
  // wall: each labelled stretch grows along the boundary over unlabelled
  // points that stay within snap distance of its line.
  for (bool grown = true; grown;) {
    grown = false;
    for (size_t k = 0; k < n; ++k) {
      if (label[k] >= 0) continue;
      for (const size_t nb : {(k + n - 1) % n, (k + 1) % n}) {
        const int l = label[nb];
        if (l >= 0 && std::abs(lines[l].n().dot(boundary[k] - lines[l].c)) <= kSnap) {
          label[k] = l;
          grown = true;
          break;
        }
      }
    }
  }
  // Runs, cyclic, starting at a change of label (one label all round: no
  // polygon to make; the raster's boundary is kept, simplified).
  struct Run {
    size_t first = 0, count = 0;
    int line = -1;
  };
  const auto runs_of = [&]() {
    std::vector<Run> runs;
    size_t start = 0;
    while (start < n && label[start] == label[(start + n - 1) % n]) ++start;
    if (start == n) return runs;
    for (size_t s = 0; s < n; ++s) {
      const size_t k = (start + s) % n;
      if (runs.empty() || label[k] != runs.back().line) runs.push_back(Run{k, 0, label[k]});
      ++runs.back().count;
    }
    return runs;
  };
  const size_t min_count = std::max<size_t>(2, static_cast<size_t>(std::ceil(kMinSide / cell)));
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<Run> runs = runs_of();
    if (runs.size() < 3) break;
    // The shortest run under a side takes the label of its longer neighbour.
    size_t shortest = runs.size();
    for (size_t k = 0; k < runs.size(); ++k) {
      if (runs[k].count < min_count && (shortest == runs.size() || runs[k].count < runs[shortest].count)) shortest = k;
    }
    if (shortest == runs.size()) break;
    const Run& prev = runs[(shortest + runs.size() - 1) % runs.size()];
    const Run& next = runs[(shortest + 1) % runs.size()];
    const int take = prev.count >= next.count ? prev.line : next.line;
    for (size_t s = 0; s < runs[shortest].count; ++s) label[(runs[shortest].first + s) % n] = take;
    changed = true;
  }
  const std::vector<Run> runs = runs_of();
  std::vector<Eigen::Vector2d> out;
  if (runs.size() < 3) {
    std::vector<char> keep(n + 1, 0);
    std::vector<Eigen::Vector2d> closed = boundary;
    closed.push_back(boundary.front());
    keep[0] = keep[n] = 1;
    DouglasPeucker(closed, 0, n, 1.5 * cell, &keep);
    for (size_t k = 0; k < n; ++k) {
      if (keep[k]) out.push_back(boundary[k]);
    }
    return out;
  }
  for (size_t r = 0; r < runs.size(); ++r) {
    const Run& a = runs[r];
    const Run& b = runs[(r + 1) % runs.size()];
    if (a.line < 0) {  // an unseen stretch: its own points, simplified
      std::vector<Eigen::Vector2d> pts;
      for (size_t s = 0; s < a.count; ++s) pts.push_back(boundary[(a.first + s) % n]);
      std::vector<char> keep(pts.size(), 0);
      keep.front() = keep.back() = 1;
      DouglasPeucker(pts, 0, pts.size() - 1, 1.5 * cell, &keep);
      for (size_t s = 1; s + 1 < pts.size(); ++s) {
        if (keep[s]) out.push_back(pts[s]);
      }
    }
    // The corner between run a and run b, at the boundary point where b starts.
    const Eigen::Vector2d q = boundary[b.first];
    if (a.line >= 0 && b.line >= 0) {
      const BoundLine& la = lines[a.line];
      const BoundLine& lb = lines[b.line];
      const double den = Cross(la.u, lb.u);
      if (std::abs(den) >= kMinCornerSine) {
        // la.c + s la.u = lb.c + w lb.u  =>  s = ((lb.c - la.c) x lb.u) / (la.u x lb.u)
        const Eigen::Vector2d x = la.c + la.u * (Cross(lb.c - la.c, lb.u) / den);
        if ((x - q).norm() <= 2.0 * kSnap) {
          out.push_back(x);
          continue;
        }
      }
      out.push_back(la.Foot(q));
      out.push_back(lb.Foot(q));
    } else if (a.line >= 0) {
      out.push_back(lines[a.line].Foot(q));
    } else if (b.line >= 0) {
      out.push_back(lines[b.line].Foot(q));
    } else {
      out.push_back(q);
    }
  }
  // Corners closer than a millimetre are one; a corner on the straight line
  // between its neighbours is none.
  std::vector<Eigen::Vector2d> clean;
  for (const Eigen::Vector2d& p : out) {
    if (clean.empty() || (p - clean.back()).norm() > 1e-3) clean.push_back(p);
  }
  while (clean.size() > 1 && (clean.front() - clean.back()).norm() <= 1e-3) clean.pop_back();
  for (bool changed = true; changed && clean.size() > 3;) {
    changed = false;
    for (size_t k = 0; k < clean.size() && clean.size() > 3; ++k) {
      const Eigen::Vector2d& p = clean[(k + clean.size() - 1) % clean.size()];
      const Eigen::Vector2d& nx = clean[(k + 1) % clean.size()];
      const double len = (nx - p).norm();
      if (len > 1e-9 && std::abs(Cross(nx - p, clean[k] - p)) / len < 1e-3) {
        clean.erase(clean.begin() + static_cast<std::ptrdiff_t>(k));
        changed = true;
        break;
      }
    }
  }
  return clean;
}

double SignedArea(const std::vector<Eigen::Vector2d>& poly) {
  double twice = 0.0;
  for (size_t k = 0; k < poly.size(); ++k) twice += Cross(poly[k], poly[(k + 1) % poly.size()]);
  return 0.5 * twice;
}

// Where the room's name goes: the cell nearest the region's centroid among
// those at least half as deep inside it as its deepest (4-neighbour distance
// from its boundary), so that it fits even in an L-shaped room whose
// centroid is outside it, and whose label's box (the name over the area,
// kLabelHalfWidth x kLabelHalfHeight about the point, as drawn at the
// default text height: 0.12 m in the DXF, 2.5 mm at 1:50 in the SVG) keeps
// kLabelClear (less in a narrow room) from every dimension line (drawn
// through a room's middle too, its value 0.05 m beside it and 0.125 m
// high). The clearance was once from the point alone: "Room 2 / 32.00 m2"
// then sat on a dimension's value.
constexpr double kLabelClear = 0.2;
constexpr double kLabelHalfWidth =
    0.33;  // "32.00 m2" and "Room 12", about 0.6 text heights a glyph
constexpr double kLabelHalfHeight = 0.2;  // name (1.2 heights) over area (1 height)
constexpr double kLabelDepthShare = 0.5;

// Distance from the segment a-b to the box |x - c.x| <= hw, |y - c.y| <= hh
// (0 if they meet).
double SegmentToBox(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                    double hw, double hh) {
  const Eigen::Vector2d lo = c - Eigen::Vector2d(hw, hh), hi = c + Eigen::Vector2d(hw, hh);
  const auto inside = [&](const Eigen::Vector2d& p) {
    return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  };
  if (inside(a) || inside(b)) return 0.0;
  // The segment crosses the box if it crosses one of its sides (Liang-Barsky clip).
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = b - a;
  bool crosses = true;
  for (int k = 0; k < 2 && crosses; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      crosses = a[k] >= lo[k] && a[k] <= hi[k];
      continue;
    }
    double u0 = (lo[k] - a[k]) / d[k], u1 = (hi[k] - a[k]) / d[k];
    if (u0 > u1) std::swap(u0, u1);
    t0 = std::max(t0, u0);
    t1 = std::min(t1, u1);
    crosses = t0 <= t1;
  }
  if (crosses) return 0.0;
  // Apart: the nearest pair is a segment end and the box, or a box corner and the segment.
  const auto to_box = [&](const Eigen::Vector2d& p) {
    return (p - p.cwiseMax(lo).cwiseMin(hi)).norm();
  };
  double best = std::min(to_box(a), to_box(b));
  for (const Eigen::Vector2d& corner :
       {lo, hi, Eigen::Vector2d(lo.x(), hi.y()), Eigen::Vector2d(hi.x(), lo.y())}) {
    best = std::min(best, DistanceToSegment(corner, a, b));
  }
  return best;
}

Eigen::Vector2d LabelPoint(const Raster& r, int id, const Region& region, const std::vector<Dimension>& dimensions) {
  std::unordered_map<uint64_t, int> depth;
  const auto key = [](int i, int j) { return (static_cast<uint64_t>(static_cast<uint32_t>(i)) << 32) | static_cast<uint32_t>(j); };
  std::deque<std::pair<int, int>> queue;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
  for (const auto& [i, j] : region.cells) {
    centroid += r.Corner(i, j);
    bool edge = false;
    for (int k = 0; k < 4; ++k) edge = edge || !r.Inside(i + di[k], j + dj[k]) || r.At(i + di[k], j + dj[k]) != id;
    if (edge) {
      depth[key(i, j)] = 0;
      queue.emplace_back(i, j);
    }
  }
  centroid /= static_cast<double>(region.cells.size());
  int deepest = 0;
  while (!queue.empty()) {
    const auto [i, j] = queue.front();
    queue.pop_front();
    const int d = depth[key(i, j)];
    deepest = std::max(deepest, d);
    for (int k = 0; k < 4; ++k) {
      const int ni = i + di[k], nj = j + dj[k];
      if (!r.Inside(ni, nj) || r.At(ni, nj) != id || depth.count(key(ni, nj))) continue;
      depth[key(ni, nj)] = d + 1;
      queue.emplace_back(ni, nj);
    }
  }
  const Eigen::Vector2d half = Eigen::Vector2d::Constant(0.5 * r.cell());
  // A narrow room (a corridor, 1 m deep at most) has no point 0.5 m from
  // its dimension line at half its depth: the clearance shrinks with it.
  const double clearance = std::min(kLabelClear, 0.3 * deepest * r.cell());
  const auto clear = [&](const Eigen::Vector2d& p) {
    for (const Dimension& dim : dimensions) {
      if (SegmentToBox(dim.a, dim.b, p, kLabelHalfWidth, kLabelHalfHeight) < clearance)
        return false;
    }
    return true;
  };
  Eigen::Vector2d best = r.Corner(region.cells.front().first, region.cells.front().second) + half;
  int best_rank = -1;
  double best_dist = 0.0;
  for (const auto& [i, j] : region.cells) {
    const Eigen::Vector2d p = r.Corner(i, j) + half;
    const int d = depth[key(i, j)];
    // Deep enough and clear of dimensions ranks above any cell that is not,
    // and the centroid decides among those; then a cell clear of them whose
    // label still fits inside the room (a corridor's dimension runs down its
    // middle, where its deepest cells are); without one, the deepest cell
    // (depths within two cells of the deepest are equal: the raster's
    // staircase makes one end of a corridor a cell deeper than its middle).
    const bool is_clear = clear(p);
    const bool fits = d * r.cell() >= kLabelHalfWidth;
    const int rank = is_clear && d >= kLabelDepthShare * deepest ? deepest + 2
                     : is_clear && fits                          ? deepest + 1
                                                                 : std::min(d, deepest - 2);
    const double dist = (p - centroid).squaredNorm();
    if (rank > best_rank || (rank == best_rank && dist < best_dist)) {
      best_rank = rank;
      best_dist = dist;
      best = p;
    }
  }
  return best;
}

}  // namespace

void FindRooms(const FloorPlanOptions& options, FloorPlan* plan) {
  plan->rooms.clear();
  const std::vector<WallFace>& faces = plan->faces;
  if (faces.empty()) return;
  Eigen::Vector2d lo = faces.front().a, hi = lo;
  for (const WallFace& f : faces) {
    lo = lo.cwiseMin(f.a).cwiseMin(f.b);
    hi = hi.cwiseMax(f.a).cwiseMax(f.b);
  }
  // (1) Barriers.
  Raster raster(lo, hi, options.room_cell_m);
  for (const WallFace& f : faces) {
    if (!f.structural || f.Length() <= 0.0) continue;
    const Eigen::Vector2d u = (f.b - f.a).normalized();
    raster.Segment(f.a - kCornerGap * u, f.b + kCornerGap * u);
  }
  for (const Wall& w : plan->walls) {
    if ((w.b - w.a).norm() > 0.0) raster.Band(w.a, w.b, 0.5 * w.thickness_m);
  }
  for (const Opening& o : plan->openings) raster.Segment(o.a, o.b);
  raster.Grow();
  // (2) Regions.
  const std::vector<Region> regions = Regions(&raster);
  const double cell = raster.cell();
  // Which faces bound which region from inside: probes in front of the
  // face every kProbeStep. One face may bound several rooms (the building's
  // outer wall, one line behind the corridor and a room at once); it bounds
  // a region where at least kMinProbes of its probes land in it, and the
  // length it bounds there is theirs.
  std::vector<std::vector<int>> faces_of(regions.size());
  std::vector<double> seen_length(regions.size(), 0.0);
  for (size_t i = 0; i < faces.size(); ++i) {
    const WallFace& f = faces[i];
    if (!f.structural || !f.normal_known) continue;
    const int stations = std::max(3, static_cast<int>(std::round(f.Length() / kProbeStep)));
    std::map<int, int> votes;
    for (int k = 0; k < stations; ++k) {
      ++votes[raster.Of(f.a + (k + 0.5) / stations * (f.b - f.a) + kProbe * f.normal)];
    }
    for (const auto& [id, count] : votes) {
      if (id < 0 || count < kMinProbes) continue;
      faces_of[id].push_back(static_cast<int>(i));
      seen_length[id] += f.Length() * count / stations;
    }
  }
  for (size_t id = 0; id < regions.size(); ++id) {
    const Region& region = regions[id];
    if (region.touches_edge || region.cells.size() * cell * cell < options.min_room_area_m2) continue;
    const std::vector<Eigen::Vector2d> boundary = OuterBoundary(raster, static_cast<int>(id), region);
    if (boundary.size() < 4) continue;
    const double traced_perimeter = static_cast<double>(boundary.size()) * cell;
    if (seen_length[id] < kMinSeenPerimeter * traced_perimeter) continue;
    // The bounding lines: one per fitted line of the plan.
    std::map<int, std::vector<int>> by_line;
    for (int f : faces_of[id]) by_line[faces[f].line].push_back(f);
    std::vector<BoundLine> lines;
    for (const auto& [line, members] : by_line) {
      BoundLine bl;
      const WallFace& first = faces[members.front()];
      const Eigen::Vector2d u0 = (first.b - first.a).normalized();
      Eigen::Vector2d u = Eigen::Vector2d::Zero(), c = Eigen::Vector2d::Zero();
      double weight = 0.0;
      for (int f : members) {
        Eigen::Vector2d uf = (faces[f].b - faces[f].a).normalized();
        if (uf.dot(u0) < 0) uf = -uf;
        const double w = static_cast<double>(std::max<size_t>(faces[f].points, 1));
        u += w * uf;
        c += w * 0.5 * (faces[f].a + faces[f].b);
        weight += w;
      }
      bl.u = u.normalized();
      bl.c = c / weight;
      bl.t0 = bl.t1 = bl.u.dot(first.a - bl.c);
      for (int f : members) {
        for (const Eigen::Vector2d& p : {faces[f].a, faces[f].b}) {
          bl.t0 = std::min(bl.t0, bl.u.dot(p - bl.c));
          bl.t1 = std::max(bl.t1, bl.u.dot(p - bl.c));
        }
      }
      lines.push_back(bl);
    }
    Room room;
    room.outline = Outline(boundary, lines, cell);
    if (room.outline.size() < 3) continue;
    room.area_m2 = SignedArea(room.outline);
    if (room.area_m2 < 0.0) {
      std::reverse(room.outline.begin(), room.outline.end());
      room.area_m2 = -room.area_m2;
    }
    for (size_t k = 0; k < room.outline.size(); ++k) {
      room.perimeter_m += (room.outline[(k + 1) % room.outline.size()] - room.outline[k]).norm();
    }
    room.label = LabelPoint(raster, static_cast<int>(id), region, plan->dimensions);
    room.faces = faces_of[id];
    // The openings it reaches: a probe either side of the opening's middle.
    for (size_t o = 0; o < plan->openings.size(); ++o) {
      const Opening& op = plan->openings[o];
      const Eigen::Vector2d m = 0.5 * (op.a + op.b), u = (op.b - op.a).normalized(), n(-u.y(), u.x());
      const double reach = kProbe + (op.wall >= 0 ? 0.5 * plan->walls[op.wall].thickness_m : 0.0);
      if (raster.Of(m + reach * n) == static_cast<int>(id) || raster.Of(m - reach * n) == static_cast<int>(id)) {
        room.openings.push_back(static_cast<int>(o));
      }
    }
    plan->rooms.push_back(std::move(room));
  }
  // The reading order: south to north in 1 m bands, west to east.
  const auto band_key = [](const Room& r) {
    Eigen::Vector2d lo = r.outline.front();
    for (const Eigen::Vector2d& p : r.outline) lo = lo.cwiseMin(p);
    return std::make_pair(std::floor(lo.y()), lo.x());
  };
  std::stable_sort(plan->rooms.begin(), plan->rooms.end(),
                   [&](const Room& a, const Room& b) { return band_key(a) < band_key(b); });
}

std::string NoRoomsReason(const FloorPlan& plan) {
  if (!plan.rooms.empty()) return std::string();
  const bool walls = std::any_of(plan.faces.begin(), plan.faces.end(),
                                 [](const WallFace& f) { return f.structural; });
  if (!walls) return "no room: no wall faces at this cut";
  return "no room: the walls found at this cut do not close around any free floor (a wall the "
         "scans "
         "did not reach leaves a gap; the scan plane crosses the walls beside the drive, so turn "
         "in "
         "each room to reach the walls ahead and behind)";
}

}  // namespace sweepscan::plan
