// Coarse registration from planes (both frames gravity-aligned).
//
// Each session's frame has z up, levelled by the IMU, so target_from_source
// is a yaw about z plus a small tilt (the two IMUs' levelling errors). The
// tilt is the smallest rotation R_tilt taking the source floor's normal onto
// the target floor's; if the floors' normals differ by more than
// floor_agreement_deg the frames are not what this method assumes and it
// refuses. Then R = Rz(yaw) R_tilt.
//
// Hypotheses: a plane n . p + d = 0 of the source maps under T = (R, t) to
// (R n) . q + d - (R n) . t = 0. Matching source walls (i, j) at an angle
// of at least min_wall_angle_deg to target walls (k, l) at the same angle,
// with signs s_k, s_l such that m_k = s_k n_k ~ Rz(yaw) R_tilt n_i:
//   yaw = mean of atan2(m_k) - atan2(R_tilt n_i) and atan2(m_l) - ...,
//   m_k . t = d_i - s_k d_k,  m_l . t = d_j - s_l d_l,  n_F . t = d_f - d_F
// (the last row from the floors f, F, normals up): a 3x3 system for t.
// Both orders (i->k, j->l) and (i->l, j->k) and both consistent sign pairs
// (a 180-degree turn) are tried, so a rectangular room yields its four
// 90-degree turns among the hypotheses; content decides between them.
//
// Score: the fraction of a subsample of the source's non-horizontal points
// (walls and furniture sides: the floor and ceiling match under any yaw, so
// they would only dilute the score) that land within inlier_plane_m of the
// target surface (point-to-plane distance to the nearest target point, that
// point within inlier_distance_m, normals within 30 degrees). Scored first
// on coarse_samples points, the best rescore_count again on score_samples.
//
// Refusals (the Status says which; `result` keeps the diagnosis):
//  * no floor in a cloud, or floors disagreeing (frames not levelled);
//  * only parallel walls (a corridor): the translation along them is free;
//    free_direction is the target's wall direction;
//  * best score below min_overlap: the clouds share nothing recognisable;
//  * best / next distinct below min_score_ratio: ambiguous (a symmetric room
//    seen without the furniture that tells its turns apart).
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "core/evaluation/evaluation.h"
#include "core/registration/internal.h"
#include "core/registration/registration.h"

namespace sweepscan {

using registration_internal::Control;
using registration_internal::NormalSums;
using registration_internal::Surface;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr size_t kMaxWalls = 10;

struct Wall {
  Eigen::Vector3d n;  // horizontal unit normal
  double d = 0.0;
  size_t count = 0;
};

struct Layout {
  bool has_floor = false;
  Plane floor;  // normal up
  std::vector<Wall> walls;  // largest first
};

Layout Classify(const std::vector<EvaluatedPlane>& planes, const PlaneAlignOptions& o) {
  Layout layout;
  const double cos_level = std::cos(o.classify_angle_deg * kDeg);
  const double sin_plumb = std::sin(o.classify_angle_deg * kDeg);
  size_t biggest = 0;
  for (const EvaluatedPlane& p : planes) {
    if (std::abs(p.plane.normal.z()) >= cos_level) biggest = std::max(biggest, p.plane.count);
  }
  for (const EvaluatedPlane& ep : planes) {
    Plane p = ep.plane;
    if (std::abs(p.normal.z()) >= cos_level) {
      if (p.normal.z() < 0.0) {
        p.normal = -p.normal;
        p.d = -p.d;
      }
      // The floor: the lowest of the large level planes (desk tops are
      // smaller, the ceiling is higher).
      if (4 * p.count >= biggest && (!layout.has_floor || -p.d < -layout.floor.d)) {
        layout.floor = p;
        layout.has_floor = true;
      }
    } else if (std::abs(p.normal.z()) <= sin_plumb) {
      layout.walls.push_back({p.normal, p.d, p.count});
    }
  }
  std::stable_sort(layout.walls.begin(), layout.walls.end(),
                   [](const Wall& a, const Wall& b) { return a.count > b.count; });
  if (layout.walls.size() > kMaxWalls) layout.walls.resize(kMaxWalls);
  return layout;
}

// Acute angle between two walls' lines (radians, [0, pi/2]).
double LineAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.dot(b))));
}
double Heading(const Eigen::Vector3d& n) { return std::atan2(n.y(), n.x()); }

bool HasNonParallelPair(const std::vector<Wall>& walls, double min_angle) {
  for (size_t i = 0; i < walls.size(); ++i) {
    for (size_t j = i + 1; j < walls.size(); ++j) {
      if (LineAngle(walls[i].n, walls[j].n) >= min_angle) return true;
    }
  }
  return false;
}

struct Score {
  double inliers = 0.0;    // fraction of the samples on target surfaces
  double conflicts = 0.0;  // fraction near target points but off their surface
  double value = 0.0;      // inliers - conflict_weight * conflicts
};

struct Hypothesis {
  double yaw = 0.0;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Rigid3d pose;  // ToRigid(yaw, t), then polished (see below)
  Score score;
};

struct Sample {
  Eigen::Vector3f p, n;
};

struct Scorer {
  const Surface* target;
  const PlaneAlignOptions* o;
  // The samples under T against the target surface; sums the inliers'
  // point-to-plane normal equations if `sums` is given.
  Score Evaluate(const Rigid3d& t, const std::vector<Sample>& samples, NormalSums* sums) const {
    const Eigen::Matrix3f r = t.rotation().toRotationMatrix().cast<float>();
    const Eigen::Vector3f tr = t.translation().cast<float>();
    const float inlier2 = static_cast<float>(o->inlier_distance_m * o->inlier_distance_m);
    const float seen2 = static_cast<float>(o->conflict_distance_m * o->conflict_distance_m);
    const float cos_normal = static_cast<float>(std::cos(30.0 * kDeg));
    size_t inliers = 0, conflicts = 0;
    for (const Sample& s : samples) {
      const Eigen::Vector3f q = r * s.p + tr;
      uint32_t idx = 0;
      float d2 = 0.0f;
      // Farther than conflict_distance_m from every target point: a part the
      // target did not see, neither for nor against.
      if (target->index.Knn(q.data(), 1, &idx, &d2) < 1 || d2 > seen2) continue;
      // On an edge or a corner the target's normal says little: neutral.
      if (target->variation[idx] > 0.1f) continue;
      const Eigen::Vector3f& nt = target->normals[idx];
      const float* tp = target->index.sorted_point(idx);
      const float res = nt.dot(q - Eigen::Vector3f(tp[0], tp[1], tp[2]));
      const bool parallel = std::abs(nt.dot(r * s.n)) >= cos_normal;
      if (d2 > inlier2 || std::abs(res) > o->inlier_plane_m || !parallel) {
        // Parallel and just behind or before a target surface: the other
        // face of a thin wall, which the target may never have seen.
        if (!(parallel && std::abs(res) < o->thin_wall_m)) ++conflicts;
        continue;
      }
      ++inliers;
      if (sums != nullptr) sums->Add(q.cast<double>(), nt.cast<double>(), res, 1.0);
    }
    Score score;
    if (samples.empty()) return score;
    score.inliers = static_cast<double>(inliers) / static_cast<double>(samples.size());
    score.conflicts = static_cast<double>(conflicts) / static_cast<double>(samples.size());
    score.value = score.inliers - o->conflict_weight * score.conflicts;
    return score;
  }
};

// Evenly spaced non-horizontal surface points of the source.
std::vector<Sample> Subsample(const Surface& s, size_t count) {
  std::vector<uint32_t> usable;
  for (uint32_t i = 0; i < s.index.size(); ++i) {
    if (std::abs(s.normals[i].z()) < 0.7f && s.variation[i] < 0.1f) usable.push_back(i);
  }
  std::vector<Sample> out;
  const size_t n = std::min(count, usable.size());
  for (size_t k = 0; k < n; ++k) {
    const uint32_t i = usable[k * usable.size() / n];
    const float* p = s.index.sorted_point(i);
    out.push_back({Eigen::Vector3f(p[0], p[1], p[2]), s.normals[i]});
  }
  return out;
}

Rigid3d ToRigid(const Hypothesis& h, const Eigen::Quaterniond& tilt) {
  return Rigid3d(h.t, Eigen::Quaterniond(Eigen::AngleAxisd(h.yaw, Eigen::Vector3d::UnitZ())) * tilt);
}

}  // namespace

Status AlignByPlanes(const std::vector<Eigen::Vector3f>& source_in,
                     const std::vector<Eigen::Vector3f>& target_in, const PlaneAlignOptions& o,
                     RegistrationResult* result, const RegistrationControl& control_in) {
  std::string error;
  if (!o.IsValid(&error)) return Status::Error("planes: " + error);
  *result = RegistrationResult();
  result->method = "planes";
  Control control(control_in, o.threads);
  const auto cancelled = [] { return Status::Error(kRegistrationCancelled); };
  if (!control.Report(RegistrationStage::kPrepare, 0.0, 0, 0.0, true)) return cancelled();

  const std::vector<Eigen::Vector3f> source = VoxelCentroids(source_in, o.voxel_m);
  const std::vector<Eigen::Vector3f> target = VoxelCentroids(target_in, o.voxel_m);
  if (source.size() < 100 || target.size() < 100) {
    return Status::Error("planes: too few points (source " + std::to_string(source.size()) +
                         ", target " + std::to_string(target.size()) + " voxels)");
  }
  EvaluationOptions eo;
  eo.plane_distance_m = o.plane_distance_m;
  eo.max_planes = o.max_planes;
  eo.min_plane_fraction = o.min_plane_fraction;
  eo.threads = o.threads;
  std::vector<EvaluatedPlane> source_planes, target_planes;
  if (!control.Report(RegistrationStage::kPlanes, 0.05)) return cancelled();
  Status s = ExtractPlanes(source, eo, &source_planes, nullptr);
  if (!s.ok()) return Status::Error("planes: source: " + s.message());
  if (!control.Report(RegistrationStage::kPlanes, 0.15)) return cancelled();
  s = ExtractPlanes(target, eo, &target_planes, nullptr);
  if (!s.ok()) return Status::Error("planes: target: " + s.message());
  if (!control.Report(RegistrationStage::kPlanes, 0.25)) return cancelled();

  Layout src = Classify(source_planes, o);
  const Layout tgt = Classify(target_planes, o);
  if (!src.has_floor || !tgt.has_floor) {
    return Status::Error(std::string("planes: no floor found in the ") +
                         (!src.has_floor ? "source" : "target") + " cloud");
  }
  const double floor_angle = std::acos(std::min(1.0, src.floor.normal.dot(tgt.floor.normal)));
  if (floor_angle > o.floor_agreement_deg * kDeg) {
    char buf[240];
    std::snprintf(buf, sizeof(buf),
                  "planes: the floors' normals differ by %.2f deg (more than %.2f): the sessions' "
                  "frames are not both levelled, which this method assumes; pick pairs instead",
                  floor_angle / kDeg, o.floor_agreement_deg);
    return Status::Error(buf);
  }
  const Eigen::Quaterniond tilt =
      Eigen::Quaterniond::FromTwoVectors(src.floor.normal, tgt.floor.normal);
  for (Wall& w : src.walls) {
    w.n = tilt * w.n;
    w.n.z() = 0.0;
    w.n.normalize();
  }

  const double min_angle = o.min_wall_angle_deg * kDeg;
  const bool src_ok = HasNonParallelPair(src.walls, min_angle);
  const bool tgt_ok = HasNonParallelPair(tgt.walls, min_angle);
  if (!src_ok || !tgt_ok) {
    const std::vector<Wall>& walls = !tgt_ok ? tgt.walls : src.walls;
    if (walls.empty()) {
      return Status::Error(std::string("planes: no walls found in the ") +
                           (!tgt_ok ? "target" : "source") + " cloud");
    }
    // The walls' common direction: horizontal, perpendicular to the normal.
    const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(walls[0].n).normalized();
    result->degenerate = true;
    if (!tgt_ok) result->free_direction = axis;
    return Status::Error(
        std::string("planes: only parallel walls in the ") + (!tgt_ok ? "target" : "source") +
        " cloud (a corridor): the translation along " +
        registration_internal::FormatDirection(axis) + " in the " +
        (!tgt_ok ? "target" : "source") + " frame is free; pick pairs on something across it");
  }

  // Hypotheses from pairs of non-parallel walls.
  const double tol = o.angle_tolerance_deg * kDeg;
  std::vector<Hypothesis> hyps;
  const auto add = [&](const Wall& wi, const Wall& wj, const Wall& wk, const Wall& wl) {
    for (double sk : {1.0, -1.0}) {
      for (double sl : {1.0, -1.0}) {
        const Eigen::Vector3d mk = sk * wk.n, ml = sl * wl.n;
        const double yk = WrapAngle(Heading(mk) - Heading(wi.n));
        const double yl = WrapAngle(Heading(ml) - Heading(wj.n));
        if (std::abs(WrapAngle(yl - yk)) > tol) continue;
        Hypothesis h;
        h.yaw = WrapAngle(yk + 0.5 * WrapAngle(yl - yk));
        Eigen::Matrix3d a;
        a.row(0) = mk.transpose();
        a.row(1) = ml.transpose();
        a.row(2) = tgt.floor.normal.transpose();
        const Eigen::Vector3d b(wi.d - sk * wk.d, wj.d - sl * wl.d, src.floor.d - tgt.floor.d);
        h.t = a.colPivHouseholderQr().solve(b);
        for (const Hypothesis& e : hyps) {
          if (std::abs(WrapAngle(e.yaw - h.yaw)) < o.same_yaw_deg * kDeg &&
              (e.t - h.t).norm() < o.same_translation_m) {
            return;
          }
        }
        hyps.push_back(h);
      }
    }
  };
  for (size_t i = 0; i < src.walls.size(); ++i) {
    for (size_t j = i + 1; j < src.walls.size(); ++j) {
      const double as = LineAngle(src.walls[i].n, src.walls[j].n);
      if (as < min_angle) continue;
      for (size_t k = 0; k < tgt.walls.size(); ++k) {
        for (size_t l = k + 1; l < tgt.walls.size(); ++l) {
          if (std::abs(LineAngle(tgt.walls[k].n, tgt.walls[l].n) - as) > tol) continue;
          add(src.walls[i], src.walls[j], tgt.walls[k], tgt.walls[l]);
          add(src.walls[i], src.walls[j], tgt.walls[l], tgt.walls[k]);
        }
      }
    }
  }
  if (hyps.empty()) {
    return Status::Error("planes: no pair of source walls matches a pair of target walls at the "
                         "same angle");
  }

  // Score them.
  if (!control.Report(RegistrationStage::kHypotheses, 0.3)) return cancelled();
  Surface source_surface, target_surface;
  if (!registration_internal::BuildSurface(source, 10, &control, &source_surface) ||
      !registration_internal::BuildSurface(target, 10, &control, &target_surface)) {
    return cancelled();
  }
  const Scorer scorer{&target_surface, &o};
  const std::vector<Sample> coarse = Subsample(source_surface, o.coarse_samples);
  const std::vector<Sample> fine = Subsample(source_surface, o.score_samples);
  std::atomic<size_t> done{0};
  if (!control.For(hyps.size(), 1, [&](size_t, size_t begin, size_t end) {
        for (size_t h = begin; h < end; ++h) {
          hyps[h].score = scorer.Evaluate(ToRigid(hyps[h], tilt), coarse, nullptr);
          control.Report(RegistrationStage::kHypotheses,
                         0.35 + 0.5 * static_cast<double>(++done) / hyps.size());
        }
      })) {
    return cancelled();
  }
  const auto by_score = [](const Hypothesis& a, const Hypothesis& b) { return a.score.value > b.score.value; };
  std::stable_sort(hyps.begin(), hyps.end(), by_score);

  const auto distinct = [&](const Hypothesis& a, const Hypothesis& b) {
    return std::abs(WrapAngle(a.yaw - b.yaw)) >= o.distinct_yaw_deg * kDeg ||
           (a.t - b.t).norm() >= o.distinct_translation_m;
  };
  // Rescore the best few, and the best distinct from the first if it is
  // not among them, on the larger sample.
  std::vector<Hypothesis> top(hyps.begin(),
                              hyps.begin() + std::min<size_t>(hyps.size(), o.rescore_count));
  const bool top_has_distinct = std::any_of(
      top.begin(), top.end(), [&](const Hypothesis& e) { return distinct(e, hyps[0]); });
  for (size_t h = top.size(); h < hyps.size() && !top_has_distinct; ++h) {
    if (distinct(hyps[h], hyps[0])) {
      top.push_back(hyps[h]);
      break;
    }
  }
  // Each of them polished by a few Gauss-Newton steps on its own inliers
  // (point-to-plane, the ICP's step) before its final score: a hypothesis
  // from two walls' offsets is off by those walls' fits (centimetres, a
  // fraction of a degree), which costs the true pose inliers within
  // inlier_plane_m, while polishing gains a look-alike pose little: its
  // conflicts stay where they are. Verification after local refinement, as
  // global registration pipelines do (without it the true pose of two
  // sessions of the office floor scored only 1.25 x its look-alike).
  if (!control.For(top.size(), 1, [&](size_t, size_t begin, size_t end) {
        for (size_t h = begin; h < end; ++h) {
          Rigid3d pose = ToRigid(top[h], tilt);
          for (int it = 0; it < o.polish_iterations; ++it) {
            NormalSums sums;
            scorer.Evaluate(pose, fine, &sums);
            if (sums.count < 50) break;
            const auto d = registration_internal::AnalyseDegeneracy(sums, 1e-3);
            pose = registration_internal::LeftUpdate(registration_internal::GaussNewtonStep(sums, d), pose);
          }
          top[h].pose = pose;
          top[h].yaw = std::atan2(pose.rotation().toRotationMatrix()(1, 0), pose.rotation().toRotationMatrix()(0, 0));
          top[h].t = pose.translation();
          top[h].score = scorer.Evaluate(pose, fine, nullptr);
        }
      })) {
    return cancelled();
  }
  std::stable_sort(top.begin(), top.end(), by_score);
  const Hypothesis& best = top[0];

  double second = 0.0;
  for (const Hypothesis& h : top) {
    if (distinct(h, best)) {
      second = std::max(0.0, h.score.value);
      break;
    }
  }

  result->target_from_source = best.pose;
  result->best_score = best.score.value;
  result->second_score = second;
  result->overlap = best.score.inliers;
  result->iterations = static_cast<int>(hyps.size());
  NormalSums sums;
  scorer.Evaluate(result->target_from_source, fine, &sums);
  const auto degeneracy = registration_internal::AnalyseDegeneracy(sums, 1e-3);
  result->covariance = registration_internal::Covariance(sums, degeneracy);
  result->correspondences = sums.count;
  result->rms_m = sums.count > 0 ? std::sqrt(sums.r2 / static_cast<double>(sums.count)) : 0.0;
  result->eigenvalues = degeneracy.eigenvalues;

  char buf[320];
  if (best.score.inliers < o.min_overlap) {
    std::snprintf(buf, sizeof(buf),
                  "planes: the clouds share too little: the best of %zu hypotheses puts %.1f %% "
                  "of the source's wall points on target surfaces and %.1f %% against them "
                  "(at least %.1f %% needed)",
                  hyps.size(), 100.0 * best.score.inliers, 100.0 * best.score.conflicts,
                  100.0 * o.min_overlap);
    return Status::Error(buf);
  }
  if (second > 0.0 && best.score.value < o.min_score_ratio * second) {
    std::snprintf(buf, sizeof(buf),
                  "planes: ambiguous: the best hypothesis scores %.3f and a distinct one %.3f "
                  "(ratio %.2f < %.2f): the shared part looks alike in several poses; pick pairs",
                  best.score.value, second, best.score.value / second, o.min_score_ratio);
    return Status::Error(buf);
  }
  control.Report(RegistrationStage::kDone, 1.0, 0, result->rms_m, true);
  return Status::Ok();
}

}  // namespace sweepscan
