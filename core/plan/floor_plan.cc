// The floor plan's steps, in order (BuildFloorPlanFromSection):
//
// (1) Lines: sequential RANSAC on the section (line_fit.h), then per line a
//     total least-squares refit on the full points within the tolerance,
//     trimmed twice to 3 sigma of its residuals (at least 5 mm): noise in
//     range is a few mm, so 3 sigma keeps the face and drops a cabinet 5 cm
//     in front of it.
// (2) Runs: the line's points sorted by t = u . (p - c) and split where two
//     neighbours are >= opening_width apart; runs shorter than
//     min_face_length or with fewer than min_face_points points are dropped
//     (door jambs, a table leg, clutter that happens to be collinear), and
//     so are runs whose own fit is not parallel to the line (Oblique: the
//     slice of another surface crossing the line's band at a small angle).
//     Assumes a wall is seen continuously at the cut height: gaps shorter
//     than an opening (a missing return, a corner's abutting wall) are bridged.
// (3) Shadows: a gap between two kept runs is a shadow, not an opening, when
//     section points within kShadowDepth in front of or behind the line
//     project onto at least kShadowCover of it (a cabinet in front of the
//     wall hid it from the scanner). A shadow joins the runs into one face.
// (4) Faces: each run refitted on its own points (total least squares), its
//     ends the projections of its first and last point.
// (5) Openings: the gaps left between consecutive faces of a line, up to
//     max_opening_width; the jambs are the faces' facing ends.
// (6) Facing: a face's free side is the side the scanner saw it from. From
//     stations every 0.1 m along the face, rays go both ways to the first
//     obstacle (an occupied 2 cm cell or another face). A side whose rays
//     mostly hit nothing is outside the scanned area (the outer side of an
//     outer wall): the face faces the other side. When both sides' rays
//     mostly miss, a side none hit from is outside if at least 5 % of the
//     other's (3 or more) hit. If both sides hit, the
//     free side is the one with the larger median distance (the thin wall's
//     other face is 0.1 m behind, the room metres in front).
// (7) Walls: faces i, j parallel within parallel_tolerance, back to back
//     (n_i . n_j < 0 and (c_j - c_i) . n_i < 0), min_wall_thickness <=
//     distance <= max_wall_thickness, overlapping by at least
//     min_face_length. thickness = mean of the two line-to-point distances
//     at the overlap's middle; the centre line halves them.
// (8) Openings in walls: an opening of face i and one of face j of the same
//     wall that overlap are one opening: its jambs are the intersection of
//     the two gaps on the centre line (every point seen on either face is
//     wall, so the door is at most the intersection).
// (8b) Structure: a face is a wall's (structural) when it is one of a wall
//     pair, or nothing was seen behind it (the outer shell), or it is at
//     least kMinStructuralLength long and not within kFurnitureDepth in
//     front of a parallel face facing the same way; otherwise it is
//     furniture (a cabinet's front, shelves against a wall).
// (9) Dimensions: structural faces i, j parallel, facing each other
//     (n_i . n_j < 0 and (c_j - c_i) . n_i > 0), overlapping; from stations
//     every 5 cm along the overlap a ray along n_i must reach line j without
//     an obstacle (an occupied cell, another face, an opening: an inner
//     dimension stays in its room); each run of at least kMinClear metres of
//     clear stations is a candidate, drawn at its middle. Per pair of lines
//     the longest candidate of each room is kept (two candidates are in one
//     room unless a structural face crosses the segment between them).
//     distance = mean of the distances of each face's station point to the
//     other face's line (the two lines are parallel only within 2 deg).
// (10) Rooms: rooms.h.
#include "core/plan/floor_plan.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_set>
#include <utility>

#include "core/plan/line_fit.h"
#include "core/plan/rooms.h"

namespace sweepscan::plan {
namespace {

constexpr double kShadowDepth = 1.5;   // m either side of the line
constexpr double kShadowCover = 0.3;   // fraction of the gap (in 5 cm bins)
constexpr double kOccupancyCell = 0.02;
constexpr double kRayStep = 0.01;
constexpr double kRayStart = 0.04;     // skip the face's own points (noise)
constexpr double kMaxRay = 30.0;
constexpr double kMinClear = 0.3;      // m of clear stations for a dimension
// A face not in a wall, with something seen behind it, is furniture when it
// is shorter than this or stands within kFurnitureDepth in front of a
// parallel face that faces the same way (a cabinet, shelves against a wall).
constexpr double kMinStructuralLength = 1.0;
constexpr double kFurnitureDepth = 1.5;
constexpr double kTailDistance = 0.06;
constexpr size_t kTailRatio = 5;

uint64_t CellKey(const Eigen::Vector2d& p) {
  const int64_t i = static_cast<int64_t>(std::floor(p.x() / kOccupancyCell));
  const int64_t j = static_cast<int64_t>(std::floor(p.y() / kOccupancyCell));
  return (static_cast<uint64_t>(static_cast<uint32_t>(i)) << 32) | static_cast<uint32_t>(j);
}

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

struct Run {
  std::vector<size_t> idx;  // into the section, sorted by t
  double t0 = 0.0, t1 = 0.0;
};

// The plan's working state: the section and its occupancy.
class Planner {
 public:
  Planner(const std::vector<Eigen::Vector2d>& pts, const FloorPlanOptions& o)
      : pts_(pts), o_(o), claimed_(pts.size(), 0) {
    for (const Eigen::Vector2d& p : pts_) occupied_.insert(CellKey(p));
  }

  void FacesOfLine(const Line2d& detected, int line_id, FloorPlan* plan);
  void Facing(FloorPlan* plan) const;
  void Walls(FloorPlan* plan) const;
  void Structure(FloorPlan* plan) const;
  void WallOpenings(FloorPlan* plan) const;
  void Dimensions(FloorPlan* plan) const;

 private:
  // Distance along the ray from p in direction d to the first obstacle: an
  // occupied cell or a face other than `skip_a`, `skip_b`; kMaxRay if none.
  double FirstHit(const Eigen::Vector2d& p, const Eigen::Vector2d& d, const FloorPlan& plan, int skip_a,
                  int skip_b, double limit, bool openings_block = false) const;
  bool Shadow(const Line2d& line, double t0, double t1) const;
  bool Oblique(const Line2d& line, const Run& run) const;

  const std::vector<Eigen::Vector2d>& pts_;
  const FloorPlanOptions& o_;
  std::unordered_set<uint64_t> occupied_;
  std::vector<char> claimed_;  // points of an earlier (better supported) line's faces
  mutable std::vector<double> back_;  // per face: median distance to the first obstacle behind it
};

// A far face's range noise (sigma = 2 mm + 0.2 % of the range for the X4)
// leaves a tail of points beyond the 3 sigma band that can line up into a
// weak second face a few centimetres behind it. Such a face lies within
// kTailDistance of a parallel, overlapping, earlier face with kTailRatio
// times its points: a surface is not seen so much worse than its neighbour.
bool NoiseTail(const WallFace& f, const FloorPlan& plan) {
  const Eigen::Vector2d u = (f.b - f.a).normalized(), n(-u.y(), u.x()), c = 0.5 * (f.a + f.b);
  for (const WallFace& g : plan.faces) {
    const Eigen::Vector2d ug = (g.b - g.a).normalized();
    if (std::abs(Cross(u, ug)) > 0.035 || g.points < kTailRatio * f.points) continue;
    if (std::abs(n.dot(g.a - c)) > kTailDistance) continue;
    const double t0 = u.dot(g.a - f.a), t1 = u.dot(g.b - f.a);
    if (std::min(f.Length(), std::max(t0, t1)) - std::max(0.0, std::min(t0, t1)) > 0.5 * f.Length()) return true;
  }
  return false;
}

bool Planner::Shadow(const Line2d& line, double t0, double t1) const {
  const int bins = std::max(1, static_cast<int>(std::ceil((t1 - t0) / 0.05)));
  std::vector<char> covered(bins, 0);
  for (const Eigen::Vector2d& p : pts_) {
    const double r = std::abs(line.Distance(p));
    const double t = line.Along(p);
    if (r <= o_.line_tolerance_m || r > kShadowDepth || t <= t0 || t >= t1) continue;
    covered[std::min(bins - 1, static_cast<int>((t - t0) / 0.05))] = 1;
  }
  int n = 0;
  for (char c : covered) n += c;
  return n >= kShadowCover * bins;
}

// A surface that crosses the line's band at a small angle leaves a run of
// its own points in the band: the slice of another line. Two such slices
// far apart (a cabinet's front and a board 2.7 m on, 5 deg off the line
// through both) would otherwise be joined by step (3) into a slanted wall.
// A run of the line's own surface is parallel to it within the plan's
// parallel tolerance plus 3 sigma of its own direction: a TLS fit of n
// points with residual rms s over a length L has a direction sigma of
// s sqrt(12 / n) / L (the slope's variance over points spread evenly on L).
bool Planner::Oblique(const Line2d& line, const Run& run) const {
  Line2d own;
  double rms = 0.0;
  if (!FitLine(pts_, run.idx, &own, &rms)) return false;
  const double length = std::max(run.t1 - run.t0, 1e-3);
  const double sigma =
      std::max(rms, 0.002) * std::sqrt(12.0 / static_cast<double>(run.idx.size())) / length;
  return std::abs(Cross(own.u, line.u)) > std::sin(o_.parallel_tolerance_rad) + 3.0 * sigma;
}

void Planner::FacesOfLine(const Line2d& detected, int line_id, FloorPlan* plan) {
  // (1) Refit on the full points, trimmed to 3 sigma.
  Line2d line = detected;
  std::vector<size_t> idx;
  double band = o_.line_tolerance_m;
  for (int round = 0; round < 3; ++round) {
    idx.clear();
    for (size_t i = 0; i < pts_.size(); ++i) {
      if (!claimed_[i] && std::abs(line.Distance(pts_[i])) <= band) idx.push_back(i);
    }
    double rms = 0.0;
    if (!FitLine(pts_, idx, &line, &rms)) return;
    band = std::clamp(3.0 * rms, 0.005, o_.line_tolerance_m);
  }
  // (2) Runs.
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return line.Along(pts_[a]) < line.Along(pts_[b]); });
  std::vector<Run> runs;
  for (size_t k = 0; k < idx.size(); ++k) {
    const double t = line.Along(pts_[idx[k]]);
    if (runs.empty() || t - runs.back().t1 >= o_.opening_width_m) runs.push_back(Run{{}, t, t});
    runs.back().idx.push_back(idx[k]);
    runs.back().t1 = t;
  }
  runs.erase(std::remove_if(runs.begin(), runs.end(),
                            [&](const Run& r) {
                              return r.t1 - r.t0 < o_.min_face_length_m ||
                                     static_cast<int>(r.idx.size()) < o_.min_face_points ||
                                     Oblique(line, r);
                            }),
             runs.end());
  // (3) Shadows join runs.
  std::vector<Run> joined;
  for (Run& r : runs) {
    if (!joined.empty() && Shadow(line, joined.back().t1, r.t0)) {
      joined.back().idx.insert(joined.back().idx.end(), r.idx.begin(), r.idx.end());
      joined.back().t1 = r.t1;
    } else {
      joined.push_back(std::move(r));
    }
  }
  // (4) Faces, (5) openings between them.
  int previous = -1;
  for (const Run& r : joined) {
    Line2d own;
    double rms = 0.0;
    if (!FitLine(pts_, r.idx, &own, &rms)) continue;
    if (own.u.dot(line.u) < 0) own.u = -own.u;  // keep the line's direction
    WallFace f;
    f.a = own.At(own.Along(pts_[r.idx.front()]));
    f.b = own.At(own.Along(pts_[r.idx.back()]));
    f.line = line_id;
    f.points = r.idx.size();
    f.rms_m = rms;
    if (NoiseTail(f, *plan)) continue;
    plan->faces.push_back(f);
    for (size_t i : r.idx) claimed_[i] = 1;
    const int id = static_cast<int>(plan->faces.size()) - 1;
    if (previous >= 0) {
      const WallFace& p = plan->faces[previous];
      const double width = (f.a - p.b).norm();
      if (width >= o_.opening_width_m && width <= o_.max_opening_width_m) {
        plan->openings.push_back(Opening{p.b, f.a, width, previous, -1});
      }
    }
    previous = id;
  }
}

double Planner::FirstHit(const Eigen::Vector2d& p, const Eigen::Vector2d& d, const FloorPlan& plan, int skip_a,
                         int skip_b, double limit, bool openings_block) const {
  double best = limit;
  // Ray p + s d against segment a + w (b - a), 0 <= w <= 1.
  const auto segment = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d e = b - a;
    const double den = Cross(d, e);
    if (std::abs(den) < 1e-12) return;
    const Eigen::Vector2d ap = a - p;
    const double s = Cross(ap, e) / den, w = Cross(ap, d) / den;
    if (s > kRayStart && w >= 0.0 && w <= 1.0) best = std::min(best, s);
  };
  for (size_t k = 0; k < plan.faces.size(); ++k) {
    if (static_cast<int>(k) != skip_a && static_cast<int>(k) != skip_b) segment(plan.faces[k].a, plan.faces[k].b);
  }
  if (openings_block) {
    for (const Opening& o : plan.openings) segment(o.a, o.b);
  }
  for (double s = kRayStart; s < best; s += kRayStep) {
    if (occupied_.count(CellKey(p + s * d))) return s;
  }
  return best;
}

void Planner::Facing(FloorPlan* plan) const {
  back_.assign(plan->faces.size(), kMaxRay);
  for (size_t i = 0; i < plan->faces.size(); ++i) {
    WallFace& f = plan->faces[i];
    const Eigen::Vector2d u = (f.b - f.a).normalized();
    const Eigen::Vector2d n(-u.y(), u.x());
    const int stations = std::max(3, static_cast<int>(f.Length() / 0.1));
    std::vector<double> side[2];
    for (int k = 0; k < stations; ++k) {
      const Eigen::Vector2d p = f.a + (k + 0.5) / stations * (f.b - f.a);
      side[0].push_back(FirstHit(p, n, *plan, static_cast<int>(i), -1, kMaxRay));
      side[1].push_back(FirstHit(p, -n, *plan, static_cast<int>(i), -1, kMaxRay));
    }
    double median[2];
    bool hits[2];
    int count[2] = {0, 0};
    for (int s = 0; s < 2; ++s) {
      std::sort(side[s].begin(), side[s].end());
      median[s] = side[s][side[s].size() / 2];
      hits[s] = median[s] < kMaxRay;
      for (const double d : side[s]) count[s] += d < kMaxRay;
    }
    if (!hits[0] && !hits[1]) {
      // Both sides mostly open: a wall at the end of a room seen only from
      // afar (a straight drive's scan plane crosses the far wall's section
      // a few times). A side no ray hit anything from is still outside when
      // the other side's rays met the scanned room at a few stations; else
      // a lone line, no side known.
      const int least = std::max(3, static_cast<int>(std::ceil(0.05 * stations)));
      if (count[1] == 0 && count[0] >= least) {
        hits[0] = true;
      } else if (count[0] == 0 && count[1] >= least) {
        hits[1] = true;
      } else {
        continue;
      }
    }
    const int free_side = !hits[1] ? 0 : !hits[0] ? 1 : (median[0] >= median[1] ? 0 : 1);
    f.normal = free_side == 0 ? n : Eigen::Vector2d(-n);
    f.normal_known = true;
    back_[i] = median[1 - free_side];
  }
}

void Planner::Walls(FloorPlan* plan) const {
  const std::vector<WallFace>& fs = plan->faces;
  for (size_t i = 0; i < fs.size(); ++i) {
    for (size_t j = i + 1; j < fs.size(); ++j) {
      if (!fs[i].normal_known || !fs[j].normal_known) continue;
      const Eigen::Vector2d ui = (fs[i].b - fs[i].a).normalized(), uj = (fs[j].b - fs[j].a).normalized();
      if (std::abs(Cross(ui, uj)) > std::sin(o_.parallel_tolerance_rad)) continue;
      const Eigen::Vector2d ci = 0.5 * (fs[i].a + fs[i].b), cj = 0.5 * (fs[j].a + fs[j].b);
      if (fs[i].normal.dot(fs[j].normal) >= 0 || (cj - ci).dot(fs[i].normal) >= 0) continue;
      // Overlap on i's line.
      const double tj0 = ui.dot(fs[j].a - fs[i].a), tj1 = ui.dot(fs[j].b - fs[i].a);
      const double t0 = std::max(0.0, std::min(tj0, tj1)), t1 = std::min(fs[i].Length(), std::max(tj0, tj1));
      if (t1 - t0 < o_.min_face_length_m) continue;
      const Eigen::Vector2d nj(-uj.y(), uj.x());
      const Eigen::Vector2d mi = fs[i].a + 0.5 * (t0 + t1) * ui;
      const double dij = std::abs(nj.dot(mi - fs[j].a));
      const Eigen::Vector2d mj = fs[j].a + uj * uj.dot(mi - fs[j].a);  // mi's foot on j
      const double dji = std::abs(fs[i].normal.dot(mj - fs[i].a));
      const double thickness = 0.5 * (dij + dji);
      if (thickness < o_.min_wall_thickness_m || thickness > o_.max_wall_thickness_m) continue;
      // Centre line: i's overlap ends moved half the thickness towards j.
      const Eigen::Vector2d shift = -0.5 * thickness * fs[i].normal;
      plan->walls.push_back(Wall{fs[i].a + t0 * ui + shift, fs[i].a + t1 * ui + shift, thickness,
                                 static_cast<int>(i), static_cast<int>(j)});
    }
  }
}

void Planner::Structure(FloorPlan* plan) const {
  std::vector<char> in_wall(plan->faces.size(), 0);
  for (const Wall& w : plan->walls) in_wall[w.face_a] = in_wall[w.face_b] = 1;
  std::vector<WallFace>& fs = plan->faces;
  for (size_t i = 0; i < fs.size(); ++i) {
    WallFace& f = fs[i];
    f.structural = false;
    if (!f.normal_known) continue;
    if (in_wall[i] || back_[i] >= kMaxRay) {
      f.structural = true;  // half of a wall, or the outer shell (nothing seen behind it)
      continue;
    }
    if (f.Length() < kMinStructuralLength) continue;  // a cabinet's side
    const Eigen::Vector2d u = (f.b - f.a).normalized(), c = 0.5 * (f.a + f.b);
    bool in_front_of_wall = false;
    for (size_t k = 0; k < fs.size() && !in_front_of_wall; ++k) {
      if (k == i || !fs[k].normal_known || fs[k].normal.dot(f.normal) <= 0) continue;
      const Eigen::Vector2d uk = (fs[k].b - fs[k].a).normalized();
      if (std::abs(Cross(u, uk)) > std::sin(o_.parallel_tolerance_rad)) continue;
      const double behind = (c - fs[k].a).dot(fs[k].normal);
      const double tk0 = u.dot(fs[k].a - f.a), tk1 = u.dot(fs[k].b - f.a);
      const double overlap = std::min(f.Length(), std::max(tk0, tk1)) - std::max(0.0, std::min(tk0, tk1));
      in_front_of_wall = behind > o_.line_tolerance_m && behind <= kFurnitureDepth && overlap >= 0.5 * f.Length();
    }
    f.structural = !in_front_of_wall;
  }
}

void Planner::WallOpenings(FloorPlan* plan) const {
  std::vector<Opening> out;
  std::vector<char> used(plan->openings.size(), 0);
  for (size_t i = 0; i < plan->openings.size(); ++i) {
    if (used[i]) continue;
    const Opening& oi = plan->openings[i];
    const WallFace& fi = plan->faces[oi.face];
    const Eigen::Vector2d u = (oi.b - oi.a).normalized();
    bool merged = false;
    for (size_t j = i + 1; j < plan->openings.size() && !merged; ++j) {
      if (used[j]) continue;
      const Opening& oj = plan->openings[j];
      const WallFace& fj = plan->faces[oj.face];
      if (fi.line == fj.line || !fi.normal_known || !fj.normal_known) continue;
      for (size_t w = 0; w < plan->walls.size(); ++w) {
        const Wall& wall = plan->walls[w];
        const bool same_wall = (plan->faces[wall.face_a].line == fi.line && plan->faces[wall.face_b].line == fj.line) ||
                               (plan->faces[wall.face_a].line == fj.line && plan->faces[wall.face_b].line == fi.line);
        if (!same_wall) continue;
        // Both gaps on the centre line's coordinate s = u . (p - oi.a).
        const double a0 = 0.0, a1 = (oi.b - oi.a).norm();
        double b0 = u.dot(oj.a - oi.a), b1 = u.dot(oj.b - oi.a);
        if (b0 > b1) std::swap(b0, b1);
        const double s0 = std::max(a0, b0), s1 = std::min(a1, b1);
        if (s1 - s0 <= 0.0) continue;
        const Eigen::Vector2d shift = -0.5 * wall.thickness_m * fi.normal;
        out.push_back(Opening{oi.a + s0 * u + shift, oi.a + s1 * u + shift, s1 - s0, oi.face, static_cast<int>(w)});
        used[i] = used[j] = 1;
        merged = true;
        break;
      }
    }
    if (!merged) out.push_back(oi);
  }
  plan->openings = std::move(out);
}

void Planner::Dimensions(FloorPlan* plan) const {
  const std::vector<WallFace>& fs = plan->faces;
  struct Candidate {
    double clear = 0.0;
    Dimension dim;
  };
  std::map<std::pair<int, int>, std::vector<Candidate>> by_lines;
  constexpr double kStation = 0.05;
  for (size_t i = 0; i < fs.size(); ++i) {
    for (size_t j = 0; j < fs.size(); ++j) {
      if (i == j || !fs[i].structural || !fs[j].structural || fs[i].line == fs[j].line) continue;
      if (fs[i].line > fs[j].line) continue;  // each pair of lines once, from the lower line's faces
      const Eigen::Vector2d ui = (fs[i].b - fs[i].a).normalized(), uj = (fs[j].b - fs[j].a).normalized();
      if (std::abs(Cross(ui, uj)) > std::sin(o_.parallel_tolerance_rad)) continue;
      const Eigen::Vector2d ci = 0.5 * (fs[i].a + fs[i].b), cj = 0.5 * (fs[j].a + fs[j].b);
      if (fs[i].normal.dot(fs[j].normal) >= 0 || (cj - ci).dot(fs[i].normal) <= o_.max_wall_thickness_m) continue;
      const double tj0 = ui.dot(fs[j].a - fs[i].a), tj1 = ui.dot(fs[j].b - fs[i].a);
      const double t0 = std::max(0.0, std::min(tj0, tj1)), t1 = std::min(fs[i].Length(), std::max(tj0, tj1));
      if (t1 - t0 < kMinClear) continue;
      const Eigen::Vector2d nj(-uj.y(), uj.x()), ni(-ui.y(), ui.x());
      // Every maximal run of clear stations is a candidate.
      double run_start = -1.0;
      const auto finish = [&](double last) {
        const double len = last - run_start + kStation;
        if (len >= kMinClear) {
          const Eigen::Vector2d p = fs[i].a + 0.5 * (run_start + last) * ui;
          const Eigen::Vector2d q = fs[j].a + uj * uj.dot(p - fs[j].a);  // p's foot on j
          const double d_ij = std::abs(nj.dot(p - fs[j].a)), d_ji = std::abs(ni.dot(q - fs[i].a));
          by_lines[{fs[i].line, fs[j].line}].push_back(Candidate{
              len, Dimension{p, p + d_ij * fs[i].normal, 0.5 * (d_ij + d_ji), static_cast<int>(i), static_cast<int>(j)}});
        }
        run_start = -1.0;
      };
      double last = 0.0;
      for (double t = t0 + 0.5 * kStation; t <= t1; t += kStation) {
        const Eigen::Vector2d p = fs[i].a + t * ui;
        const double to_j = std::abs(nj.dot(p - fs[j].a));
        const bool clear = FirstHit(p, fs[i].normal, *plan, static_cast<int>(i), static_cast<int>(j), to_j,
                                    /*openings_block=*/true) >= to_j - o_.line_tolerance_m - 0.03;
        if (clear && run_start < 0) run_start = t;
        if (!clear && run_start >= 0) finish(last);
        last = t;
      }
      if (run_start >= 0) finish(last);
    }
  }
  // One dimension per pair of lines and room: candidates of the same pair
  // are one room unless a wall face separates them (crosses the segment
  // joining their middles, which lie half way between the two lines). The
  // longest clear stretch is kept.
  for (auto& [key, cands] : by_lines) {
    std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) { return a.clear > b.clear; });
    std::vector<Dimension> kept;
    for (const Candidate& c : cands) {
      const Eigen::Vector2d m = 0.5 * (c.dim.a + c.dim.b);
      bool same_room = false;
      for (const Dimension& k : kept) {
        const Eigen::Vector2d mk = 0.5 * (k.a + k.b);
        const double len = (mk - m).norm();
        bool wall_between = false;
        for (const WallFace& f : fs) {
          // Segments m -> mk and f.a -> f.b cross when each one's ends lie on
          // opposite sides of the other (signs of the cross products).
          if (!f.structural) continue;
          const double s1 = Cross(f.b - f.a, m - f.a), s2 = Cross(f.b - f.a, mk - f.a);
          const double s3 = Cross(mk - m, f.a - m), s4 = Cross(mk - m, f.b - m);
          wall_between = wall_between || (s1 * s2 < 0 && s3 * s4 < 0);
        }
        same_room = same_room || len < 1e-9 || !wall_between;
      }
      if (!same_room) kept.push_back(c.dim);
    }
    for (const Dimension& k : kept) plan->dimensions.push_back(k);
  }
}

}  // namespace

bool FloorPlanOptions::IsValid(std::string* error) const {
  if (!section.IsValid(error)) return false;
  const auto positive = [&](double v, const char* name) {
    if (std::isfinite(v) && v > 0.0) return true;
    *error = std::string(name) + " must be a finite number > 0";
    return false;
  };
  if (!positive(line_tolerance_m, "line tolerance") || !positive(min_face_length_m, "minimum face length") ||
      !positive(opening_width_m, "opening width") || !positive(max_opening_width_m, "maximum opening width") ||
      !positive(min_wall_thickness_m, "minimum wall thickness") ||
      !positive(max_wall_thickness_m, "maximum wall thickness") ||
      !positive(parallel_tolerance_rad, "parallel tolerance") || !positive(drawing_cell_m, "drawing cell") ||
      !positive(room_cell_m, "room cell") || !positive(min_room_area_m2, "minimum room area")) {
    return false;
  }
  if (max_opening_width_m < opening_width_m || max_wall_thickness_m < min_wall_thickness_m) {
    *error = "a maximum (opening width, wall thickness) is below its minimum";
    return false;
  }
  if (min_face_points < 2) {
    *error = "minimum face points must be at least 2";
    return false;
  }
  return true;
}

Status BuildFloorPlan(const std::vector<Eigen::Vector3f>& cloud, const FloorPlanOptions& options, FloorPlan* plan) {
  *plan = FloorPlan();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  std::vector<Eigen::Vector2d> section;
  SectionStats stats;
  const Status s = HorizontalSection(cloud, options.section, &section, &stats);
  if (!s.ok()) return s;
  const Status b = BuildFloorPlanFromSection(section, options, plan);
  plan->section = stats;
  return b;
}

namespace {

// The drawing's extent: the section's points that have company. One stray
// return (a reflection through a window, a glitch 200 km out) made the SVG
// page kilometres wide, which no renderer draws; a point counts only if its
// 0.5 m cell and the eight around it hold at least three points (a wall's
// hold dozens, whatever the range; a room's corner may sit alone in a cell
// beside its walls'). If none does, every point counts.
void PlanExtent(const std::vector<Eigen::Vector2d>& section, FloorPlan* plan) {
  constexpr double kCellM = 0.5;
  constexpr int kMinPoints = 3;
  using Cell = std::pair<int64_t, int64_t>;
  auto cell_of = [](const Eigen::Vector2d& p) {
    const auto c = [](double v) {
      return static_cast<int64_t>(std::floor(std::clamp(v / kCellM, -1e9, 1e9)));
    };
    return Cell(c(p.x()), c(p.y()));
  };
  std::map<Cell, int> counts;
  for (const Eigen::Vector2d& p : section) ++counts[cell_of(p)];
  std::map<Cell, bool> company;  // By cell: its block of nine holds enough.
  for (const auto& [c, n] : counts) {
    int around = 0;
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = counts.find(Cell(c.first + dx, c.second + dy));
        if (it != counts.end()) around += it->second;
      }
    }
    company[c] = around >= kMinPoints;
  }
  bool any = false;
  plan->stray_points = 0;
  for (const Eigen::Vector2d& p : section) {
    if (!company[cell_of(p)]) {
      ++plan->stray_points;
      continue;
    }
    plan->min = any ? plan->min.cwiseMin(p) : p;
    plan->max = any ? plan->max.cwiseMax(p) : p;
    any = true;
  }
  if (any) return;
  plan->stray_points = 0;
  plan->min = plan->max = section.front();
  for (const Eigen::Vector2d& p : section) {
    plan->min = plan->min.cwiseMin(p);
    plan->max = plan->max.cwiseMax(p);
  }
}

}  // namespace

Status BuildFloorPlanFromSection(const std::vector<Eigen::Vector2d>& section, const FloorPlanOptions& options,
                                 FloorPlan* plan) {
  *plan = FloorPlan();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  plan->height_m = options.section.height_m;
  plan->band_m = options.section.band_m;
  plan->section.points_in = plan->section.points_out = section.size();
  for (const Eigen::Vector2d& p : section) {
    if (!p.allFinite()) return Status::Error("the section has a point that is not finite");
  }
  if (static_cast<int>(section.size()) < options.min_face_points) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "the section at %.3f m +- %.3f m holds %zu points: the cut misses the cloud",
                  options.section.height_m, options.section.band_m, section.size());
    return Status::Error(buf);
  }
  PlanExtent(section, plan);
  plan->points = DecimateGrid(section, options.drawing_cell_m);
  LineDetectionOptions lo;
  lo.tolerance_m = options.line_tolerance_m;
  lo.seed = options.seed;
  const std::vector<Line2d> lines = DetectLines(section, lo);
  Planner planner(section, options);
  for (size_t l = 0; l < lines.size(); ++l) planner.FacesOfLine(lines[l], static_cast<int>(l), plan);
  planner.Facing(plan);
  planner.Walls(plan);
  planner.Structure(plan);
  planner.WallOpenings(plan);
  planner.Dimensions(plan);
  FindRooms(options, plan);
  return Status::Ok();
}

}  // namespace sweepscan::plan
