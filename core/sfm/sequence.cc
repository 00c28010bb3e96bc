#include "core/sfm/sequence.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <set>

#include "core/sfm/refine.h"

namespace sweepscan::sfm {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Lines of one scan, moved into the rig frame (the scan plane is the
// lidar's z = 0 plane). The spread along the line, sigma^2 = mean squared
// projection of the samples on the line direction (lambda_max / N).
void ExtractRigLines(const Scan& scan, int scan_index, int frame, const Rig& rig, const LineExtractionOptions& o,
                     std::vector<ScanLine>* scan_lines, std::vector<LineObs>* out) {
  *scan_lines = ExtractLines(scan.points, o);
  const Rigid3d& T = rig.rig_from_lidar[scan.lidar];
  const bool deskewed = scan.deskewed.size() == scan.points.size();
  for (size_t k = 0; k < scan_lines->size(); ++k) {
    const ScanLine& l = (*scan_lines)[k];
    LineObs obs;
    obs.frame = frame;
    obs.scan = scan_index;
    obs.line = static_cast<int>(k);
    Eigen::Vector3d centroid(l.centroid.x(), l.centroid.y(), 0.0);
    Eigen::Vector3d direction(l.direction.x(), l.direction.y(), 0.0);
    if (deskewed) {
      // Total least squares in 3D on the deskewed samples: centroid and
      // principal axis of their scatter (the same fit as FitScanLine's).
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      int n = 0;
      for (int i : l.indices) {
        if (!scan.deskewed[i].allFinite()) continue;
        mean += scan.deskewed[i];
        ++n;
      }
      if (n >= 2) {
        mean /= n;
        Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
        for (int i : l.indices) {
          if (!scan.deskewed[i].allFinite()) continue;
          const Eigen::Vector3d q = scan.deskewed[i] - mean;
          S += q * q.transpose();
        }
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S);
        Eigen::Vector3d u = es.eigenvectors().col(2).normalized();
        if (u.dot(direction) < 0.0) u = -u;
        centroid = mean;
        direction = u;
      }
    }
    obs.centroid = T * centroid;
    obs.direction = (T.rotation() * direction).normalized();
    double s2 = 0.0, lo = 0.0, hi = 0.0;
    for (int i : l.indices) {
      const double a = deskewed && scan.deskewed[i].allFinite() ? (scan.deskewed[i] - centroid).dot(direction)
                                                                : (scan.points[i] - l.centroid).dot(l.direction);
      s2 += a * a;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
    obs.count = static_cast<int>(l.indices.size());
    obs.sigma = std::sqrt(s2 / std::max(1, obs.count));
    obs.half_length = deskewed ? 0.5 * (hi - lo) : 0.5 * l.length;
    out->push_back(obs);
  }
}

// The plane through a set of lines by least squares on their samples, from
// the compact form: scatter S = sum_l N_l [(c_l - c)(c_l - c)^T + sigma_l^2
// u_l u_l^T] about the weighted centroid c; the normal is the eigenvector of
// the smallest eigenvalue. Lines are given in the world (c, u).
WorldPlane FitPlane(const std::vector<Eigen::Vector3d>& c, const std::vector<Eigen::Vector3d>& u,
                    const std::vector<double>& sigma, const std::vector<int>& count) {
  double w = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < c.size(); ++i) {
    mean += count[i] * c[i];
    w += count[i];
  }
  mean /= w;
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < c.size(); ++i) {
    S += count[i] * ((c[i] - mean) * (c[i] - mean).transpose() + sigma[i] * sigma[i] * u[i] * u[i].transpose());
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S);
  WorldPlane p;
  p.normal = es.eigenvectors().col(0).normalized();
  p.d = -p.normal.dot(mean);
  return p;
}

// Constant-velocity prediction: the last motion (in the rig frame) applied
// again, scaled to the time step.
Rigid3d Predict(const std::vector<Rigid3d>& poses, const std::vector<double>& times, int k) {
  if (k < 2) return poses[k - 1];
  const Rigid3d delta = poses[k - 2].inverse() * poses[k - 1];
  const double dt_prev = times[k - 1] - times[k - 2];
  const double ratio = dt_prev > 1e-9 ? (times[k] - times[k - 1]) / dt_prev : 1.0;
  const Eigen::AngleAxisd aa(delta.rotation());
  const Rigid3d scaled(ratio * delta.translation(),
                       Eigen::Quaterniond(Eigen::AngleAxisd(ratio * aa.angle(), aa.axis())));
  return poses[k - 1] * scaled;
}

struct Tracker {
  const std::vector<Scan>& scans;
  const Rig& rig;
  const SequenceOptions& o;
  SequenceResult* r;
  std::vector<WorldPlane> planes;  // mirrors r->planes[i].plane during tracking
  std::mt19937_64 rng;

  Tracker(const std::vector<Scan>& s, const Rig& g, const SequenceOptions& opt, SequenceResult* res)
      : scans(s), rig(g), o(opt), r(res), rng(opt.seed) {}

  bool WithinExtent(const LineObs& l, const Rigid3d& pose, int plane) const {
    const FoundPlane& fp = r->planes[plane];
    if (fp.extent_min.x() > fp.extent_max.x()) return true;  // nothing seen yet
    const Eigen::Vector3d c = pose * l.centroid;
    const Eigen::Vector3d lo = fp.extent_min.array() - o.extent_margin_m - l.half_length;
    const Eigen::Vector3d hi = fp.extent_max.array() + o.extent_margin_m + l.half_length;
    return (c.array() >= lo.array()).all() && (c.array() <= hi.array()).all();
  }

  void GrowExtent(const LineObs& l, const Rigid3d& pose, int plane) {
    FoundPlane& fp = r->planes[plane];
    const Eigen::Vector3d c = pose * l.centroid, v = pose.rotation() * l.direction;
    for (double s : {-1.0, 1.0}) {
      const Eigen::Vector3d e = c + s * l.half_length * v;
      fp.extent_min = fp.extent_min.cwiseMin(e);
      fp.extent_max = fp.extent_max.cwiseMax(e);
    }
  }

  // Eq. 38-39: the nearest plane passing the distance and angle gates (and
  // the extent check), or -1.
  int Associate(const LineObs& l, const Rigid3d& pose, double dist, double angle_deg) const {
    int best = -1;
    double best_d = dist;
    const double sin_gate = std::sin(angle_deg * kDeg);
    for (size_t j = 0; j < planes.size(); ++j) {
      double dmax, s;
      LinePlaneDistance(l, pose, planes[j], &dmax, &s);
      if (dmax <= best_d && s <= sin_gate && WithinExtent(l, pose, static_cast<int>(j))) {
        best = static_cast<int>(j);
        best_d = dmax;
      }
    }
    return best;
  }

  // Assigns every line of [begin, end) at `pose`; returns the assigned lines.
  std::vector<const LineObs*> AssignAll(size_t begin, size_t end, const Rigid3d& pose, double dist, double angle) {
    std::vector<const LineObs*> assigned;
    for (size_t i = begin; i < end; ++i) {
      LineObs& l = r->lines[i];
      l.plane = Associate(l, pose, dist, angle);
      if (l.plane >= 0) assigned.push_back(&l);
    }
    return assigned;
  }

  // Relocalisation by the minimal solver: lines paired with planes under
  // loose gates at the prediction, random triples on three planes of
  // independent normals, each candidate pose scored by the number of lines
  // it associates under the tight gates. Returns the best pose's score.
  int RelocaliseP3l(size_t begin, size_t end, const Rigid3d& predicted, Rigid3d* pose) {
    struct Pair {
      size_t line;
      int plane;
    };
    std::vector<Pair> pairs;
    for (size_t i = begin; i < end; ++i) {
      for (size_t j = 0; j < planes.size(); ++j) {
        double dmax, s;
        LinePlaneDistance(r->lines[i], predicted, planes[j], &dmax, &s);
        if (dmax < 0.5 && s < std::sin(20.0 * kDeg)) pairs.push_back({i, static_cast<int>(j)});
      }
    }
    if (pairs.size() < 3) return -1;
    std::uniform_int_distribution<size_t> pick(0, pairs.size() - 1);
    int best_score = -1;
    for (int trial = 0; trial < 60; ++trial) {
      const Pair a = pairs[pick(rng)], b = pairs[pick(rng)], c = pairs[pick(rng)];
      if (a.plane == b.plane || a.plane == c.plane || b.plane == c.plane) continue;
      const Eigen::Vector3d &na = planes[a.plane].normal, &nb = planes[b.plane].normal, &nc = planes[c.plane].normal;
      if (std::abs(na.cross(nb).dot(nc)) < 0.1) continue;  // normals nearly sharing a direction
      std::array<WorldPlane, 3> P = {planes[a.plane], planes[b.plane], planes[c.plane]};
      std::array<RigLine, 3> L;
      const size_t idx[3] = {a.line, b.line, c.line};
      for (int k = 0; k < 3; ++k) {
        const LineObs& l = r->lines[idx[k]];
        L[k].point = l.centroid;
        L[k].direction = l.direction;
        L[k].points = {l.centroid - l.half_length * l.direction, l.centroid, l.centroid + l.half_length * l.direction};
      }
      Disambiguation dis;
      dis.has_previous = true;
      dis.previous_R = predicted.rotation().toRotationMatrix();
      dis.previous_t = predicted.translation();
      std::vector<PoseCandidate> cands;
      if (!SolveP3l(P, L, {}, dis, &cands).ok()) continue;
      for (const PoseCandidate& cand : cands) {
        const Rigid3d candidate(cand.t, Eigen::Quaterniond(cand.R));
        int score = 0;
        for (size_t i = begin; i < end; ++i) {
          if (Associate(r->lines[i], candidate, o.assoc_tight_distance_m, o.assoc_tight_angle_deg) >= 0) ++score;
        }
        if (score > best_score) {
          best_score = score;
          *pose = candidate;
        }
      }
    }
    return best_score;
  }

  // Section 4, new planes: from the unassigned lines (world, at their
  // frames' poses) the plane through a random pair of non-parallel lines
  // with the most inlier lines (every point within the bound), refitted.
  void DetectPlanes(std::vector<size_t>* pending, int frame) {
    for (int round = 0; round < 3; ++round) {
      if (static_cast<int>(pending->size()) < o.new_plane_min_lines) return;
      const size_t n = pending->size();
      // World centroid, direction and scan-plane normal of each line. All
      // lines of one scan lie in its scan plane, and nearby frames' scan
      // planes nearly coincide, so the scan plane itself would collect
      // inliers: a line supports a candidate only if its scan plane is at
      // least 15 deg from it.
      std::vector<Eigen::Vector3d> c(n), v(n), m(n);
      for (size_t i = 0; i < n; ++i) {
        const LineObs& l = r->lines[(*pending)[i]];
        const Rigid3d& pose = r->tracked[l.frame];
        c[i] = pose * l.centroid;
        v[i] = pose.rotation() * l.direction;
        m[i] = pose.rotation() * (rig.rig_from_lidar[scans[l.scan].lidar].rotation() * Eigen::Vector3d::UnitZ());
      }
      const double scan_plane_cos = std::cos(15.0 * kDeg);
      auto inlier = [&](size_t i, const WorldPlane& p) {
        const LineObs& l = r->lines[(*pending)[i]];
        const double bound = o.new_plane_inlier_m;
        return std::abs(p.normal.dot(m[i])) < scan_plane_cos && std::abs(p.SignedDistance(c[i])) <= bound &&
               std::abs(p.SignedDistance(c[i] + l.half_length * v[i])) <= bound &&
               std::abs(p.SignedDistance(c[i] - l.half_length * v[i])) <= bound;
      };
      std::uniform_int_distribution<size_t> pick(0, n - 1);
      const double min_sin = std::sin(o.new_plane_min_pair_angle_deg * kDeg);
      int best_count = 0;
      WorldPlane best;
      for (int trial = 0; trial < o.new_plane_max_pairs; ++trial) {
        const size_t i = pick(rng), j = pick(rng);
        if (i == j) continue;
        const Eigen::Vector3d cr = v[i].cross(v[j]);
        WorldPlane p;
        if (cr.norm() >= min_sin) {
          p.normal = cr.normalized();
        } else if (o.new_plane_parallel_separation_m > 0.0) {
          // Parallel lines: the plane through both, n = u_i x (c_j - c_i)
          // with the part of c_j - c_i along the lines removed.
          Eigen::Vector3d w = c[j] - c[i];
          w -= w.dot(v[i]) * v[i];
          if (w.norm() < o.new_plane_parallel_separation_m) continue;
          p.normal = v[i].cross(w).normalized();
        } else {
          continue;
        }
        p.d = -p.normal.dot(c[i]);
        if (!inlier(i, p) || !inlier(j, p)) continue;
        int count = 0;
        for (size_t k = 0; k < n; ++k) count += inlier(k, p) ? 1 : 0;
        if (count > best_count) {
          best_count = count;
          best = p;
        }
      }
      if (best_count < o.new_plane_min_inliers) return;
      // Refit on the inliers, then take the inliers of the refitted plane.
      for (int pass = 0; pass < 2; ++pass) {
        std::vector<Eigen::Vector3d> cc, uu;
        std::vector<double> ss;
        std::vector<int> nn;
        for (size_t k = 0; k < n; ++k) {
          if (!inlier(k, best)) continue;
          const LineObs& l = r->lines[(*pending)[k]];
          cc.push_back(c[k]);
          uu.push_back(v[k]);
          ss.push_back(l.sigma);
          nn.push_back(l.count);
        }
        if (cc.size() < 2) return;
        best = FitPlane(cc, uu, ss, nn);
      }
      std::vector<size_t> members;
      std::set<int> frames;
      double side = 0.0;
      for (size_t k = 0; k < n; ++k) {
        if (!inlier(k, best)) continue;
        members.push_back(k);
        const LineObs& l = r->lines[(*pending)[k]];
        frames.insert(l.frame);
        side += best.SignedDistance(r->tracked[l.frame].translation());
      }
      if (static_cast<int>(members.size()) < o.new_plane_min_inliers ||
          static_cast<int>(frames.size()) < o.new_plane_min_frames) {
        return;
      }
      // Eq. 37: the rig stands in front of the plane (n . t + d < 0).
      if (side > 0.0) {
        best.normal = -best.normal;
        best.d = -best.d;
      }
      // An existing plane (its extent check failed as it grew)?
      int target = -1;
      for (size_t j = 0; j < planes.size(); ++j) {
        if (planes[j].normal.dot(best.normal) > std::cos(3.0 * kDeg)) {
          double worst = 0.0;
          for (size_t k : members) worst = std::max(worst, std::abs(planes[j].SignedDistance(c[k])));
          if (worst < o.new_plane_inlier_m) target = static_cast<int>(j);
        }
      }
      if (target < 0) {
        FoundPlane fp;
        fp.plane = best;
        fp.first_frame = frame;
        r->planes.push_back(fp);
        planes.push_back(best);
        target = static_cast<int>(planes.size()) - 1;
      }
      std::vector<bool> taken(n, false);
      for (size_t k : members) {
        LineObs& l = r->lines[(*pending)[k]];
        l.plane = target;
        GrowExtent(l, r->tracked[l.frame], target);
        taken[k] = true;
      }
      std::vector<size_t> rest;
      for (size_t k = 0; k < n; ++k) {
        if (!taken[k]) rest.push_back((*pending)[k]);
      }
      pending->swap(rest);
    }
  }
};

}  // namespace

std::vector<Eigen::Vector3d> ScanPointsInWorld(const Scan& scan, const Rig& rig, const Rigid3d& world_from_rig) {
  std::vector<Eigen::Vector3d> out;
  const Rigid3d T = world_from_rig * rig.rig_from_lidar[scan.lidar];
  if (scan.deskewed.size() == scan.points.size()) {
    for (const Eigen::Vector3d& p : scan.deskewed) {
      if (p.allFinite()) out.push_back(T * p);
    }
    return out;
  }
  for (const Eigen::Vector2d& p : scan.points) {
    if (p.allFinite()) out.push_back(T * Eigen::Vector3d(p.x(), p.y(), 0.0));
  }
  return out;
}

Status RunSequence(const std::vector<Scan>& scans, const Rig& rig, const SequenceInit& init,
                   const SequenceOptions& options, SequenceResult* result) {
  return RunSequence(scans, rig, init, options, nullptr, result);
}

Status RunSequence(const std::vector<Scan>& scans, const Rig& rig, const SequenceInit& init,
                   const SequenceOptions& options, const MotionPrior* prior, SequenceResult* result) {
  const auto start = std::chrono::steady_clock::now();
  *result = SequenceResult();
  SequenceResult& r = *result;
  if (scans.empty()) return Status::Error("no scans");
  for (size_t i = 0; i < scans.size(); ++i) {
    if (scans[i].lidar < 0 || scans[i].lidar >= static_cast<int>(rig.rig_from_lidar.size())) {
      return Status::Error("scan " + std::to_string(i) + ": unknown lidar " + std::to_string(scans[i].lidar));
    }
    if (i > 0 && scans[i].time_s < scans[i - 1].time_s) return Status::Error("scans are not in time order");
  }
  // Frames: scans of (nearly) the same time.
  for (size_t i = 0; i < scans.size(); ++i) {
    if (r.frame_times_s.empty() || scans[i].time_s - r.frame_times_s.back() > 1e-6) {
      r.frame_times_s.push_back(scans[i].time_s);
      r.frame_scans.emplace_back();
    }
    r.frame_scans.back().push_back(static_cast<int>(i));
  }
  const int num_frames = static_cast<int>(r.frame_times_s.size());
  if (prior != nullptr && static_cast<int>(prior->world_from_rig.size()) != num_frames) {
    return Status::Error("motion prior: " + std::to_string(prior->world_from_rig.size()) + " poses for " +
                         std::to_string(num_frames) + " frames");
  }
  // The prior's relative motion into frame k, and its square-root information.
  auto prior_delta = [&](int k) { return prior->world_from_rig[k - 1].inverse() * prior->world_from_rig[k]; };
  const bool constrain = prior != nullptr && prior->constrain;
  Tracker tr(scans, rig, options, result);

  // ---- Initialisation (frame 0) ----
  std::vector<std::vector<ScanLine>> first_scan_lines;  // per scan of frame 0
  std::vector<size_t> first_scan_offset;
  for (int si : r.frame_scans[0]) {
    first_scan_offset.push_back(r.lines.size());
    first_scan_lines.emplace_back();
    ExtractRigLines(scans[si], si, 0, rig, options.lines, &first_scan_lines.back(), &r.lines);
  }
  auto resolve = [&](const InitLineRef& ref, size_t* index) -> Status {
    for (size_t k = 0; k < r.frame_scans[0].size(); ++k) {
      if (scans[r.frame_scans[0][k]].lidar != ref.lidar) continue;
      const std::vector<ScanLine>& sl = first_scan_lines[k];
      if (ref.line >= 0) {
        if (ref.line >= static_cast<int>(sl.size())) {
          return Status::Error("lidar " + std::to_string(ref.lidar) + " has " + std::to_string(sl.size()) +
                               " lines in the first scan, no line " + std::to_string(ref.line));
        }
        *index = first_scan_offset[k] + ref.line;
        return Status::Ok();
      }
      // The line whose supporting samples pass nearest to `near`.
      double best = 1e300;
      for (size_t j = 0; j < sl.size(); ++j) {
        for (int i : sl[j].indices) {
          const double d = (scans[r.frame_scans[0][k]].points[i] - ref.near).norm();
          if (d < best) {
            best = d;
            *index = first_scan_offset[k] + j;
          }
        }
      }
      if (best > 0.5) return Status::Error("no line of the first scan passes within 0.5 m of the given point");
      return Status::Ok();
    }
    return Status::Error("the first frame has no scan of lidar " + std::to_string(ref.lidar));
  };
  const bool known = init.planes[0].known;
  // With a prior, no plane at all: every plane is found on the way.
  bool discover = prior != nullptr && !known;
  for (const InitPlane& p : init.planes) discover = discover && !p.known && p.lines.empty();
  for (const InitPlane& p : init.planes) {
    if (discover) break;
    if (p.known != known) return Status::Error("init: give all three planes or none");
    if (p.lines.empty() || (!known && p.lines.size() < 2)) {
      return Status::Error(known ? "init: every plane needs at least one line of the first frame"
                                 : "init: a plane not given needs at least two lines of the first frame");
    }
  }
  std::array<std::vector<size_t>, 3> init_lines;
  for (int j = 0; j < 3; ++j) {
    for (const InitLineRef& ref : init.planes[j].lines) {
      size_t idx = 0;
      const Status s = resolve(ref, &idx);
      if (!s.ok()) return Status::Error("init: planes[" + std::to_string(j) + "]: " + s.message());
      init_lines[j].push_back(idx);
    }
  }
  r.tracked.assign(num_frames, Rigid3d::Identity());
  if (discover) {
    r.tracked[0] = prior->world_from_rig[0];
    r.gauge_first_pose = true;
  } else if (known && prior != nullptr) {
    // The first pose is the prior's (the lines correct it below): one
    // scan of the wheeled scanner sees planes of two normal directions
    // only, for which the minimal solver is degenerate.
    r.tracked[0] = prior->world_from_rig[0];
    for (int j = 0; j < 3; ++j) {
      FoundPlane fp;
      fp.plane = init.planes[j].plane;
      fp.plane.d /= fp.plane.normal.norm();
      fp.plane.normal.normalize();
      fp.initial = true;
      r.planes.push_back(fp);
      tr.planes.push_back(fp.plane);
    }
  } else if (known) {
    // The planes are given: the first pose by the minimal solver (section 3)
    // on the first line of each plane, further lines ranking the candidates.
    std::array<WorldPlane, 3> P;
    std::array<RigLine, 3> L;
    Disambiguation dis;
    auto rig_line = [&](size_t idx) {
      const LineObs& l = r.lines[idx];
      RigLine rl;
      rl.point = l.centroid;
      rl.direction = l.direction;
      rl.points = {l.centroid - l.half_length * l.direction, l.centroid, l.centroid + l.half_length * l.direction};
      return rl;
    };
    for (int j = 0; j < 3; ++j) {
      P[j] = init.planes[j].plane;
      L[j] = rig_line(init_lines[j][0]);
      for (size_t k = 1; k < init_lines[j].size(); ++k) {
        dis.extra_lines.push_back(rig_line(init_lines[j][k]));
        dis.extra_planes.push_back(init.planes[j].plane);
      }
    }
    std::vector<PoseCandidate> cands;
    P3lOptions po;
    po.max_rotation_residual = 0.05;  // real lines are noisy
    const Status s = SolveP3l(P, L, po, dis, &cands);
    if (!s.ok()) return Status::Error("init: " + s.message());
    if (cands.empty()) return Status::Error("init: no pose puts the designated lines on their planes");
    r.tracked[0] = Rigid3d(cands[0].t, Eigen::Quaterniond(cands[0].R));
    for (int j = 0; j < 3; ++j) {
      FoundPlane fp;
      fp.plane = P[j];
      fp.plane.normal.normalize();
      fp.plane.d = P[j].d / P[j].normal.norm();
      fp.initial = true;
      r.planes.push_back(fp);
      tr.planes.push_back(fp.plane);
    }
  } else {
    // World = first rig frame: each plane fitted from its lines.
    r.gauge_first_pose = true;
    for (int j = 0; j < 3; ++j) {
      std::vector<Eigen::Vector3d> c, u;
      std::vector<double> sg;
      std::vector<int> n;
      for (size_t idx : init_lines[j]) {
        c.push_back(r.lines[idx].centroid);
        u.push_back(r.lines[idx].direction);
        sg.push_back(r.lines[idx].sigma);
        n.push_back(r.lines[idx].count);
      }
      bool spread = false;
      for (size_t a = 1; a < u.size(); ++a) spread = spread || u[0].cross(u[a]).norm() > std::sin(10.0 * kDeg);
      if (!spread) return Status::Error("init: planes[" + std::to_string(j) + "]: its lines are parallel");
      FoundPlane fp;
      fp.plane = FitPlane(c, u, sg, n);
      if (fp.plane.d > 0.0) {  // Eq. 37 with the rig at the origin
        fp.plane.normal = -fp.plane.normal;
        fp.plane.d = -fp.plane.d;
      }
      fp.initial = true;
      r.planes.push_back(fp);
      tr.planes.push_back(fp.plane);
    }
  }
  if (prior == nullptr) {
    const Eigen::Vector3d n0 = tr.planes[0].normal, n1 = tr.planes[1].normal, n2 = tr.planes[2].normal;
    if (std::abs(n0.cross(n1).dot(n2)) < 0.05) {
      return Status::Error("init: the three planes' normals share a direction; the pose is not determined");
    }
  }
  std::vector<const LineObs*> first;
  for (int j = 0; j < 3 && !discover; ++j) {
    for (size_t idx : init_lines[j]) {
      r.lines[idx].plane = j;
      first.push_back(&r.lines[idx]);
    }
  }
  if (known && prior != nullptr) {
    UpdatePose(first, tr.planes, options, prior->world_from_rig[0],
               prior->SqrtInformation(Rigid3d::Identity()), &r.tracked[0]);
  } else if (known) {
    UpdatePose(first, tr.planes, options, &r.tracked[0]);
  }
  for (const LineObs* l : first) tr.GrowExtent(*l, r.tracked[0], l->plane);
  // The other lines of the first frame.
  std::vector<size_t> pending;
  for (size_t i = 0; i < r.lines.size(); ++i) {
    LineObs& l = r.lines[i];
    if (l.plane >= 0) continue;
    l.plane = tr.Associate(l, r.tracked[0], options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
    if (l.plane >= 0) {
      tr.GrowExtent(l, r.tracked[0], l.plane);
    } else {
      pending.push_back(i);
    }
  }

  // ---- Tracking ----
  std::vector<ScanLine> scratch;
  for (int k = 1; k < num_frames; ++k) {
    if (options.cancel != nullptr && options.cancel->load()) return Status::Error("cancelled");
    const size_t begin = r.lines.size();
    for (int si : r.frame_scans[k]) ExtractRigLines(scans[si], si, k, rig, options.lines, &scratch, &r.lines);
    const size_t end = r.lines.size();
    const Rigid3d predicted = prior != nullptr && prior->predict ? r.tracked[k - 1] * prior_delta(k)
                                                                 : Predict(r.tracked, r.frame_times_s, k);
    Rigid3d pose = predicted;
    Eigen::Matrix<double, 6, 1> sqrt_info = Eigen::Matrix<double, 6, 1>::Zero();
    if (constrain) sqrt_info = prior->SqrtInformation(prior_delta(k));
    auto update = [&](const std::vector<const LineObs*>& lines) {
      return constrain ? UpdatePose(lines, tr.planes, options, predicted, sqrt_info, &pose)
                       : UpdatePose(lines, tr.planes, options, &pose);
    };
    // Eq. 38-39 at the prediction, pose update, then again with tight gates.
    std::vector<const LineObs*> assigned = tr.AssignAll(begin, end, pose, options.assoc_distance_m, options.assoc_angle_deg);
    double lambda = update(assigned);
    assigned = tr.AssignAll(begin, end, pose, options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
    lambda = update(assigned);
    constexpr double kWeak = 1e-4;
    if (prior != nullptr) {
      // No relocalisation: the prior's prediction holds what the lines leave free.
      if (lambda < kWeak) ++r.frames_weak;
      assigned = tr.AssignAll(begin, end, pose, options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
    } else if (lambda < kWeak || assigned.size() < 3) {
      // The least squares does not fix the pose: try the minimal solver.
      Rigid3d relocated = predicted;
      const int score = tr.RelocaliseP3l(begin, end, predicted, &relocated);
      if (score > static_cast<int>(assigned.size())) {
        std::vector<const LineObs*> again =
            tr.AssignAll(begin, end, relocated, options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
        const double l2 = UpdatePose(again, tr.planes, options, &relocated);
        again = tr.AssignAll(begin, end, relocated, options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
        if (again.size() >= assigned.size()) {
          pose = relocated;
          assigned = again;
          lambda = l2;
          ++r.frames_p3l;
        }
      }
      if (lambda < kWeak) ++r.frames_weak;
      // Make sure the assignment matches the final pose.
      assigned = tr.AssignAll(begin, end, pose, options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
    }
    r.tracked[k] = pose;
    for (size_t i = begin; i < end; ++i) {
      const LineObs& l = r.lines[i];
      if (l.plane >= 0) {
        tr.GrowExtent(l, pose, l.plane);
      } else {
        pending.push_back(i);
      }
    }
    // Forget old unassigned lines (their poses drift apart from the present).
    pending.erase(std::remove_if(pending.begin(), pending.end(),
                                 [&](size_t i) { return r.lines[i].frame < k - options.unassigned_max_age_frames; }),
                  pending.end());
    tr.DetectPlanes(&pending, k);
  }
  r.tracking_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  if (r.planes.empty()) {
    return Status::Error("no planes found: no " + std::to_string(options.new_plane_min_inliers) +
                         " lines of at least " + std::to_string(options.lines.min_length_m).substr(0, 4) +
                         " m on one plane");
  }
  // ---- Joint refinement (Eq. 40) ----
  r.poses = r.tracked;
  std::vector<WorldPlane> planes = tr.planes;
  RefineOptions ro;
  ro.huber_m = options.refine_huber_m;
  ro.max_iterations = options.refine_max_iterations;
  ro.threads = options.threads;
  ro.fix_first_pose = r.gauge_first_pose || constrain;
  if (!discover && !r.gauge_first_pose) ro.fixed_planes = {0, 1, 2};
  if (constrain) ro.motion = prior;
  ro.cancel = options.cancel;
  for (int pass = 0; pass < options.refine_passes; ++pass) {
    if (pass > 0) {
      // Re-associate every line with the refined poses and planes.
      tr.planes = planes;
      for (FoundPlane& fp : r.planes) {
        fp.extent_min = Eigen::Vector3d::Constant(1e300);
        fp.extent_max = Eigen::Vector3d::Constant(-1e300);
      }
      for (const LineObs& l : r.lines) {
        if (l.plane >= 0) tr.GrowExtent(l, r.poses[l.frame], l.plane);
      }
      for (LineObs& l : r.lines) {
        l.plane = tr.Associate(l, r.poses[l.frame], options.assoc_tight_distance_m, options.assoc_tight_angle_deg);
      }
    }
    const Status s = RefinePosesAndPlanes(r.lines, ro, &r.poses, &planes, &r.refine);
    if (!s.ok()) return s;
  }
  for (size_t j = 0; j < planes.size(); ++j) {
    r.planes[j].plane = planes[j];
    r.planes[j].observations = 0;
    r.planes[j].frames = 0;
  }
  std::vector<std::set<int>> seen(planes.size());
  r.lines_total = static_cast<int>(r.lines.size());
  for (const LineObs& l : r.lines) {
    if (l.plane < 0) continue;
    ++r.lines_assigned;
    ++r.planes[l.plane].observations;
    seen[l.plane].insert(l.frame);
  }
  for (size_t j = 0; j < planes.size(); ++j) r.planes[j].frames = static_cast<int>(seen[j].size());
  return Status::Ok();
}

}  // namespace sweepscan::sfm
