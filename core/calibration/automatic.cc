// The automatic mode (automatic.h). Per round: project the samples under the
// current angles; associate them with planes (RANSAC segmentation, members
// over all samples, the pass split that keeps surfaces seen from more than
// one place, offset scan-line runs dropped, residual points chosen); solve
// (PlaneProblem, whose Ceres part is in pairs_solver.cc).
#include "core/calibration/automatic.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/calibration/combine.h"
#include "core/calibration/internal.h"
#include "core/calibration/passes.h"
#include "core/evaluation/plane_scoring.h"
#include "core/geometry/plane.h"

namespace sweepscan {

using calibration_internal::AngleChange;
using calibration_internal::FromArray;
using calibration_internal::kNsPerS;
using calibration_internal::PlaneProblem;
using calibration_internal::Prepare;
using calibration_internal::Prepared;
using calibration_internal::ProjectWith;

bool AutoCalibrationOptions::IsValid(std::string* error) const {
  if (!solver.IsValid(error)) return false;
  if (!(pose_heading_sigma_rad >= 0.0 && pose_heading_sigma_rad < 1.0) ||
      !(pose_tilt_sigma_rad >= 0.0 && pose_tilt_sigma_rad < 1.0)) {
    *error = "automatic calibration: pose_heading_sigma_rad and pose_tilt_sigma_rad must be in [0, 1) rad";
    return false;
  }
  if (max_segmentation_points < 100 || max_points_per_plane < 10 || max_planes < 1 ||
      ransac_iterations < 1) {
    *error = "automatic calibration: point and plane counts too small";
    return false;
  }
  if (!(min_plane_fraction > 0.0 && min_plane_fraction < 1.0)) {
    *error = "automatic calibration: min_plane_fraction must be in (0, 1)";
    return false;
  }
  if (!(final_band_m > 0.0) || !(initial_band_m >= final_band_m) ||
      !std::isfinite(initial_band_m)) {
    *error = "automatic calibration: need 0 < final_band_m <= initial_band_m";
    return false;
  }
  if (!(min_range_m >= 0.0)) {
    *error = "automatic calibration: min_range_m must be >= 0";
    return false;
  }
  if (!(range_noise_m >= 0.0) || !(range_noise_fraction >= 0.0) || !(model_noise_m >= 0.0) ||
      !(range_noise_m + model_noise_m > 0.0) || !(membership_sigmas > 0.0) ||
      !(edge_margin_m >= 0.0) || !(surface_step_m > 0.0) || !(robust_scale_sigmas > 0.0) ||
      !(covariance_block_s > 0.0) || !(max_abs_angle_rad > 0.0) || !(min_rms_sigmas >= 0.0) ||
      !(lm_angle_tolerance_rad >= 0.0) ||
      !(min_sigma_rad >= 0.0) || !(max_rms_sigmas > min_rms_sigmas) ||
      !std::isfinite(max_rms_sigmas + range_noise_m + range_noise_fraction + model_noise_m + membership_sigmas +
                     edge_margin_m + robust_scale_sigmas + covariance_block_s +
                     max_abs_angle_rad + min_rms_sigmas + min_sigma_rad + lm_angle_tolerance_rad)) {
    *error =
        "automatic calibration: noise model, membership, edge margin, robust scale, "
        "covariance block, LM angle tolerance and refusal thresholds must be finite and positive";
    return false;
  }
  return true;
}

namespace {

struct FoundPlane {
  Plane plane;
  std::vector<size_t> members;  // indices into the segmentation sample
};

// Sequential RANSAC (seeded): the largest plane first, its inliers removed,
// until the best plane holds fewer than min_count points. Point i is an
// inlier when |n . p_i + d| < threshold[i]. The hypotheses of a plane are
// drawn in order from `rng` and scored at once on every core by the
// evaluation's vectorised count (core/evaluation/plane_scoring.h, in float
// over a structure of arrays); the first with the most inliers wins, as in
// a serial loop, so the result does not depend on the thread count.
std::vector<FoundPlane> SegmentPlanes(const std::vector<Eigen::Vector3d>& pts,
                                      const std::vector<double>& threshold, size_t min_count,
                                      int max_planes, int iterations, std::mt19937_64* rng) {
  std::vector<FoundPlane> out;
  std::vector<size_t> remaining(pts.size());
  for (size_t i = 0; i < remaining.size(); ++i) remaining[i] = i;
  PointsSoa soa;
  std::vector<Eigen::Vector4f> hypotheses;
  std::vector<size_t> counts;
  while (static_cast<int>(out.size()) < max_planes && remaining.size() >= min_count) {
    soa.Resize(remaining.size());
    soa.band.resize(remaining.size());
    for (size_t k = 0; k < remaining.size(); ++k) {
      const Eigen::Vector3d& p = pts[remaining[k]];
      soa.Set(k, static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
      soa.band[k] = static_cast<float>(threshold[remaining[k]]);
    }
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    hypotheses.clear();
    std::vector<Eigen::Vector4d> models;
    for (int it = 0; it < iterations; ++it) {
      const Eigen::Vector3d& a = pts[remaining[pick(*rng)]];
      const Eigen::Vector3d& b = pts[remaining[pick(*rng)]];
      const Eigen::Vector3d& c = pts[remaining[pick(*rng)]];
      Eigen::Vector3d n = (b - a).cross(c - a);
      if (n.norm() < 1e-6) continue;
      n.normalize();
      models.emplace_back(n.x(), n.y(), n.z(), -n.dot(a));
      hypotheses.push_back(models.back().cast<float>());
    }
    ScoreHypotheses(soa, hypotheses, -1.0f, true, &counts);
    size_t best_count = 0;
    Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ();
    double best_d = 0.0;
    for (size_t h = 0; h < models.size(); ++h) {
      if (counts[h] > best_count) {
        best_count = counts[h];
        best_n = models[h].head<3>();
        best_d = models[h][3];
      }
    }
    if (best_count < min_count) break;
    // Refine by least squares on the inliers, then take the final inliers.
    std::vector<Eigen::Vector3d> in;
    for (size_t i : remaining) {
      if (std::abs(best_n.dot(pts[i]) + best_d) < threshold[i]) in.push_back(pts[i]);
    }
    FoundPlane fp;
    if (!FitPlane(in, &fp.plane)) break;
    std::vector<size_t> rest;
    for (size_t i : remaining) {
      (std::abs(fp.plane.SignedDistance(pts[i])) < threshold[i] ? fp.members : rest).push_back(i);
    }
    if (fp.members.size() < min_count) break;
    remaining.swap(rest);
    out.push_back(std::move(fp));
  }
  return out;
}

// The samples the automatic mode uses, with what the solve needs of them.
struct AutoSamples {
  std::vector<size_t> sample;     // indices into store.observations(), not nearer than min_range_m
  std::vector<size_t> seg_index;  // the even subsample RANSAC runs on (indices into `sample`)
  std::vector<Prepared> prepared;  // per entry of `sample`
  std::vector<double> sigma;  // per entry of `sample`, metres (the noise model in the header)
  // Per entry of `sample`, copied out of the observations once: the rounds
  // read them for every member of every plane, and a LidarObservation is
  // a cache line and a half.
  std::vector<int64_t> time_ns;
  std::vector<uint32_t> scan;
  int64_t t0 = 0;             // time of the first sample
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // mean body position (the path scale's centre)
};

Status SelectAutoSamples(const SampleStore& store, const RobotGeometry& geometry,
                         const AutoCalibrationOptions& options, AutoSamples* out) {
  std::vector<size_t>& sample = out->sample;
  {
    std::vector<size_t> valid;
    for (size_t i = 0; i < store.observations().size(); ++i) {
      if (store.observations()[i].p_lidar.norm() >= options.min_range_m) valid.push_back(i);
    }
    sample = std::move(valid);
  }
  // RANSAC runs on an even subsample (seg_index into `sample`); the planes'
  // members, and so the residuals, come from every sample: the walls seen
  // sideways (x = 0, x = 10), which carry alpha and beta, hold only ~1 % of
  // the recording each.
  std::vector<size_t>& seg_index = out->seg_index;
  {
    const size_t stride = std::max<size_t>(
        1, (sample.size() + options.max_segmentation_points - 1) / options.max_segmentation_points);
    for (size_t i = 0; i < sample.size(); i += stride) seg_index.push_back(i);
  }
  if (sample.size() < 100) {
    return Status::Error("automatic calibration: only " + std::to_string(sample.size()) +
                         " samples in the recording");
  }
  std::vector<Prepared>& prepared = out->prepared;
  std::vector<double>& sigma = out->sigma;
  prepared.reserve(sample.size());
  sigma.reserve(sample.size());
  out->time_ns.reserve(sample.size());
  out->scan.reserve(sample.size());
  for (size_t i : sample) {
    const LidarObservation& o = store.observations()[i];
    prepared.push_back(Prepare(o, geometry));
    out->time_ns.push_back(o.time_ns);
    out->scan.push_back(o.ref.scan);
    const double rho = o.p_lidar.norm();
    sigma.push_back(std::sqrt(options.range_noise_m * options.range_noise_m +
                              std::pow(options.range_noise_fraction * rho, 2) +
                              options.model_noise_m * options.model_noise_m));
  }
  out->t0 = store.observations()[sample.front()].time_ns;
  for (const Prepared& p : prepared) out->centre += p.t_wb;
  out->centre /= static_cast<double>(prepared.size());
  return Status::Ok();
}

// p_W of every sample under the angles c.
std::vector<Eigen::Vector3d> ProjectSamples(const std::vector<Prepared>& prepared,
                                            const MountingError& c) {
  const Eigen::Matrix3d r_c = MountingRotation(c).toRotationMatrix();
  std::vector<Eigen::Vector3d> pts(prepared.size());
  for (size_t i = 0; i < prepared.size(); ++i) pts[i] = ProjectWith(prepared[i], r_c);
  return pts;
}

// Planes by RANSAC on the segmentation subsample, then their members over
// all samples, each to the first plane (largest first) whose band holds it,
// as SegmentPlanes assigns them.
std::vector<FoundPlane> SegmentSurfaces(const std::vector<Eigen::Vector3d>& pts,
                                        const std::vector<double>& threshold,
                                        const std::vector<size_t>& seg_index,
                                        const AutoCalibrationOptions& options) {
  const size_t min_count = static_cast<size_t>(options.min_plane_fraction * seg_index.size());
  // Same seed every round: the segmentation depends on the points only.
  std::mt19937_64 rng(options.seed);
  std::vector<Eigen::Vector3d> seg_pts;
  std::vector<double> seg_threshold;
  for (size_t i : seg_index) seg_pts.push_back(pts[i]), seg_threshold.push_back(threshold[i]);
  std::vector<FoundPlane> planes =
      SegmentPlanes(seg_pts, seg_threshold, std::max<size_t>(min_count, 50), options.max_planes,
                    options.ransac_iterations, &rng);
  std::vector<char> taken(pts.size(), 0);
  for (auto& fp : planes) {
    fp.members.clear();
    for (size_t i = 0; i < pts.size(); ++i) {
      if (!taken[i] && std::abs(fp.plane.SignedDistance(pts[i])) < threshold[i]) {
        fp.members.push_back(i);
        taken[i] = 1;
      }
    }
  }
  return planes;
}

// The pass split: keep surfaces seen from more than one place, at least two
// sightings (time gaps > 1 s) or one long sighting (floor, ceiling: seen
// from every heading of the circle). sightings[s]: the kept surface's count.
void KeepSurfacesSeenTwice(std::vector<FoundPlane>* planes, const AutoSamples& in,
                           std::vector<FoundPlane>* used, std::vector<int>* sightings) {
  for (auto& fp : *planes) {
    std::vector<int64_t> times;
    times.reserve(fp.members.size());
    for (size_t m : fp.members) times.push_back(in.time_ns[m]);
    const auto windows = SplitByTimeGaps(times, 1.0, 20);
    double span = 0.0;
    for (const auto& w : windows) span += w.duration_s();
    if (windows.size() >= 2 || span >= 5.0) {
      used->push_back(std::move(fp));
      sightings->push_back(static_cast<int>(windows.size()));
    }
  }
}

// At the final band, drop whole scan-line runs that sit off the plane:
// a run (consecutive members of one scan line) is a piece of one
// surface, and a run whose mean offset exceeds surface_step_m belongs to
// a parallel surface a little in front or behind (the board 2 cm in
// front of the sill), which the per-point band cannot separate at 3
// sigma. Two rounds of reject-and-refit.
void DropOffsetRuns(const AutoSamples& in, const std::vector<Eigen::Vector3d>& pts,
                    const AutoCalibrationOptions& options, std::vector<FoundPlane>* used) {
  const std::vector<double>& sigma = in.sigma;
  for (auto& fp : *used) {
    for (int round = 0; round < 2; ++round) {
      std::vector<size_t> keep;
      size_t begin = 0;
      const auto& mem = fp.members;  // ascending sample index = time order
      for (size_t i = 1; i <= mem.size(); ++i) {
        const bool split = i == mem.size() || in.scan[mem[i]] != in.scan[mem[i - 1]] ||
                           mem[i] - mem[i - 1] > 1;  // a sample between them is off this plane
        if (!split) continue;
        double sum = 0.0, var = 0.0;
        for (size_t k = begin; k < i; ++k) {
          sum += fp.plane.SignedDistance(pts[mem[k]]);
          var += sigma[mem[k]] * sigma[mem[k]];
        }
        const double n_run = static_cast<double>(i - begin);
        const double mean = sum / n_run;
        // Off by more than the step and more than 3 standard errors.
        if (std::abs(mean) <= std::max(options.surface_step_m, 3.0 * std::sqrt(var) / n_run)) {
          keep.insert(keep.end(), mem.begin() + begin, mem.begin() + i);
        }
        begin = i;
      }
      if (keep.size() == mem.size() || keep.size() < 50) break;
      std::vector<Eigen::Vector3d> in;
      for (size_t m : keep) in.push_back(pts[m]);
      Plane refit;
      if (!FitPlane(in, &refit)) break;
      fp.plane = refit;
      fp.members.swap(keep);
    }
  }
}

// Residual points: members not within edge_margin_m of another kept
// plane (edges where two surfaces meet, where membership is a guess),
// then evenly subsampled to max_points_per_plane.
std::vector<std::vector<size_t>> ChooseResidualPoints(const std::vector<FoundPlane>& used,
                                                      const std::vector<Eigen::Vector3d>& pts,
                                                      const AutoCalibrationOptions& options) {
  std::vector<std::vector<size_t>> chosen(used.size());
  for (size_t s = 0; s < used.size(); ++s) {
    std::vector<size_t> clean;
    for (size_t m : used[s].members) {
      bool ambiguous = false;
      for (size_t t = 0; t < used.size() && !ambiguous; ++t) {
        ambiguous =
            t != s && std::abs(used[t].plane.SignedDistance(pts[m])) < options.edge_margin_m;
      }
      if (!ambiguous) clean.push_back(m);
    }
    const size_t stride = std::max<size_t>(
        1, (clean.size() + options.max_points_per_plane - 1) / options.max_points_per_plane);
    for (size_t k = 0; k < clean.size(); k += stride) chosen[s].push_back(clean[k]);
  }
  return chosen;
}

// The residual rows, surface by surface in chosen order: each row's
// covariance block (time since the first sample, in covariance_block_s
// blocks), and the sum of squared distances to the planes before the solve.
void ResidualRows(const AutoSamples& in,
                  const std::vector<FoundPlane>& used,
                  const std::vector<std::vector<size_t>>& chosen,
                  const std::vector<Eigen::Vector3d>& pts, const AutoCalibrationOptions& options,
                  std::vector<int>* group_of_row, double* sq_before) {
  for (size_t s = 0; s < used.size(); ++s) {
    const Plane& pl = used[s].plane;
    for (size_t m : chosen[s]) {
      group_of_row->push_back(
          static_cast<int>((in.time_ns[m] - in.t0) /
                           static_cast<int64_t>(options.covariance_block_s * kNsPerS)));
      const double r = pl.SignedDistance(pts[m]);
      *sq_before += r * r;
    }
  }
}

// Final statistics on the last problem: the kept planes, the RMS distance,
// observability and the angles' sigma (the larger of the iid and the
// cluster-robust estimate).
void ReportFinalStatistics(PlaneProblem* problem, const double* abg, const AutoSamples& in,
                           const std::vector<FoundPlane>& used, const std::vector<int>& sightings,
                           const std::vector<std::vector<size_t>>& chosen, int residuals,
                           const std::vector<int>& group_of_row, double final_cost,
                           const CalibrationOptions& so_opts, CalibrationSummary* summary) {
  const std::vector<Prepared>& prepared = in.prepared;
  const std::vector<double>& sigma = in.sigma;
  summary->final_cost = final_cost;
  summary->planes = static_cast<int>(used.size());
  summary->residual_blocks = residuals;
  const Eigen::Matrix3d r_c = MountingRotation(FromArray(abg)).toRotationMatrix();
  double sq = 0.0, sq_norm = 0.0;
  for (size_t s = 0; s < used.size(); ++s) {
    CalibrationSummary::PlaneReport rep;
    const std::array<double, 4>& params = problem->plane(s);
    rep.normal = Eigen::Vector3d(params[0], params[1], params[2]);
    rep.d = params[3];
    rep.points = static_cast<int>(chosen[s].size());
    rep.sightings = sightings[s];
    double ps = 0.0, pn = 0.0;
    for (size_t m : chosen[s]) {
      const double r = rep.normal.dot(ProjectWith(prepared[m], r_c)) + rep.d;
      ps += r * r;
      pn += (r / sigma[m]) * (r / sigma[m]);
    }
    sq += ps;
    sq_norm += pn;
    rep.rms_m = std::sqrt(ps / std::max<size_t>(1, chosen[s].size()));
    rep.rms_sigmas = std::sqrt(pn / std::max<size_t>(1, chosen[s].size()));
    summary->plane_reports.push_back(rep);
  }
  summary->final_rms_m = std::sqrt(sq / residuals);
  summary->rms_sigmas = std::sqrt(sq_norm / residuals);
  problem->CheckObservability(so_opts, summary);
  if (so_opts.compute_covariance) {
    // The iid estimate, with s^2 from the normalised residuals themselves
    // (not the robust cost), and the cluster-robust one; report the larger
    // per angle.
    const double s2 = sq_norm / std::max(1, residuals - 3);
    Eigen::Matrix3d iid, clustered;
    if (problem->AngleCovariances(group_of_row, s2, &iid, &clustered)) {
      summary->sigma_iid_rad = iid.diagonal().cwiseMax(0.0).cwiseSqrt();
      summary->sigma_rad =
          summary->sigma_iid_rad.cwiseMax(clustered.diagonal().cwiseMax(0.0).cwiseSqrt());
      summary->covariance_rad2 = WithSigmas(clustered, summary->sigma_rad);
    } else {
      summary->warnings.push_back("covariance could not be computed (rank-deficient Jacobian)");
    }
  }
}

// The robot's path as the samples saw it: one pose per scan (the first
// sample's), for the circle check.
PoseBuffer PathOfSamples(const SampleStore& store) {
  PoseBuffer path;
  bool first = true;
  uint32_t scan = 0;
  for (const LidarObservation& o : store.observations()) {
    if (!first && o.ref.scan == scan) continue;
    first = false;
    scan = o.ref.scan;
    path.Add(TimeFromNanoseconds(o.time_ns), o.world_from_body);
  }
  return path;
}

// After the solve: a result at or beyond the angle bound, or with collapsed
// residuals or sigma, cannot be trusted. Empty when the result stands.
std::string RefuseResult(const CalibrationSummary& s, const AutoCalibrationOptions& options) {
  const double angles[3] = {s.angles.alpha, s.angles.beta, s.angles.gamma};
  const char* names[3] = {"alpha", "beta", "gamma"};
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(angles[k]) < options.max_abs_angle_rad)) {
      return "refused: " + std::string(names[k]) + " = " + std::to_string(angles[k]) +
             " rad is at or beyond the bound +-" + std::to_string(options.max_abs_angle_rad) +
             " rad (a mounting error is a few degrees): check the lidar's angle convention and "
             "the poses, and drive a slow circle";
    }
  }
  char text[400];
  if (s.rms_sigmas >= 0.0 && s.rms_sigmas < options.min_rms_sigmas) {
    std::snprintf(text, sizeof(text),
                  "refused: the residuals collapsed (RMS %.3g m, %.3g of the range noise): the cloud "
                  "folded onto a plane, not a calibration",
                  s.final_rms_m, s.rms_sigmas);
    return text;
  }
  if (s.rms_sigmas > options.max_rms_sigmas) {
    std::snprintf(text, sizeof(text),
                  "refused: the residuals are %.2f times the lidar's noise model (RMS %.3g m, more "
                  "than %.2f): the planes' bands and sigma assume that model, so neither sigma nor "
                  "the angles can be trusted; check the lidar's window and range noise, and the poses",
                  s.rms_sigmas, s.final_rms_m, options.max_rms_sigmas);
    return text;
  }
  if (s.sigma_rad.minCoeff() >= 0.0 && s.sigma_rad.minCoeff() < options.min_sigma_rad) {
    return "refused: the 1-sigma collapsed (" + std::to_string(s.sigma_rad.minCoeff()) +
           " rad): a degenerate solution, not a calibration";
  }
  return std::string();
}

}  // namespace

Status SolveAutomatic(const SampleStore& store, const RobotGeometry& geometry,
                      const MountingError& initial, const AutoCalibrationOptions& options,
                      CalibrationSummary* summary) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(error);
  if (!geometry.IsValid(&error)) return Status::Error(error);
  *summary = CalibrationSummary();
  summary->method = "auto-planes";
  summary->initial = initial;
  summary->angles = initial;
  AutoSamples in;
  const Status selected = SelectAutoSamples(store, geometry, options, &in);
  if (!selected.ok()) return selected;
  if (options.require_circle_drive) {
    CircleDrive circle;
    std::string why;
    if (!FitCircleDrive(PathOfSamples(store), &circle, &why)) {
      return Status::Error("refused: not a calibration drive: " + why +
                           "; drive three slow turns of a circle (docs/calibration.md)");
    }
  }
  const std::vector<size_t>& sample = in.sample;

  MountingError c = initial;
  int final_rounds = 0;
  double band = options.initial_band_m;
  std::vector<CalibrationIteration> trace;
  const CalibrationOptions& so_opts = options.solver;
  std::vector<double> threshold(sample.size());
  for (int outer = 0; outer < so_opts.max_outer_iterations; ++outer) {
    const std::vector<Eigen::Vector3d> pts = ProjectSamples(in.prepared, c);
    const bool last_band = band <= options.final_band_m;
    // While the ghosts are being pulled together a wide band keeps both
    // copies of a wall in one plane; at the final band, membership follows
    // each point's own noise, so surfaces a few cm apart separate.
    for (size_t i = 0; i < sample.size(); ++i) {
      threshold[i] = last_band ? std::min(band, options.membership_sigmas * in.sigma[i]) : band;
    }
    // Plane association.
    std::vector<FoundPlane> planes = SegmentSurfaces(pts, threshold, in.seg_index, options);
    std::vector<FoundPlane> used;
    std::vector<int> sightings;
    KeepSurfacesSeenTwice(&planes, in, &used, &sightings);
    if (used.size() < 2) {
      summary->trace = trace;
      return Status::Error("refused: automatic calibration: found " + std::to_string(used.size()) +
                           " plane(s) seen in both passes, need at least 2");
    }
    if (last_band) DropOffsetRuns(in, pts, options, &used);
    const std::vector<std::vector<size_t>> chosen = ChooseResidualPoints(used, pts, options);

    // The solve.
    std::vector<int> group_of_row;
    double sq_before = 0.0;
    ResidualRows(in, used, chosen, pts, options, &group_of_row, &sq_before);
    const int residuals = static_cast<int>(group_of_row.size());
    std::vector<Plane> start;
    for (const FoundPlane& fp : used) start.push_back(fp.plane);
    const RobustLoss loss = so_opts.loss == RobustLoss::kNone ? RobustLoss::kHuber : so_opts.loss;
    double abg[3] = {c.alpha, c.beta, c.gamma};
    double scale = 1.0;  // this round's path scale, folded into the poses below
    PlaneProblem problem(abg, start, chosen, in.prepared, in.sigma, loss,
                         options.robust_scale_sigmas, &scale, in.centre,
                         options.estimate_path_scale);
    if (residuals == 0) return Status::Error("automatic calibration: no residual points left");
    if (outer == 0) {
      // Before solving: do the planes seen in both passes constrain all three
      // angles? The condition of the angles' Schur complement (the planes
      // projected out) at the start; a direction it leaves (nearly) free
      // would be filled by noise and pose errors.
      CalibrationSummary pre;
      problem.CheckObservability(so_opts, &pre);
      if (!(pre.condition_number <= so_opts.max_condition_number)) {
        static const char* kNames[3] = {"alpha", "beta", "gamma"};
        const int w = std::max(0, pre.weakest_angle);
        char numbers[64];
        std::snprintf(numbers, sizeof(numbers), "%.1f > %.0f", pre.condition_number,
                      so_opts.max_condition_number);
        return Status::Error(
            "refused: the drive leaves " + std::string(kNames[w]) +
            " weakly determined (Jacobian condition number " + numbers + ", " +
            std::to_string(used.size()) +
            " planes seen in both passes): drive the circle where the floor and walls facing "
            "different ways are within the lidar's range from both sides of it");
      }
    }
    if (outer == 0) summary->initial_rms_m = std::sqrt(sq_before / residuals);
    std::vector<CalibrationIteration> inner_trace;
    const PlaneProblem::Outcome cs =
        problem.Solve(so_opts, options.lm_angle_tolerance_rad, &inner_trace);
    for (auto it : inner_trace) {
      it.iteration = static_cast<int>(trace.size());
      trace.push_back(it);
    }
    summary->outer_iterations = outer + 1;
    summary->message = cs.message;
    if (outer == 0) summary->initial_cost = cs.initial_cost;
    if (cs.cancelled) {
      summary->trace = trace;
      return Status::Error("calibration cancelled");
    }
    if (!cs.lm_converged || !Eigen::Vector3d(abg[0], abg[1], abg[2]).allFinite()) {
      summary->trace = trace;
      return Status::Error("automatic calibration did not converge: " + cs.message);
    }
    const MountingError next = FromArray(abg);
    const double change = AngleChange(c, next);
    c = next;
    if (scale != 1.0) {
      // The poses of the next round's segmentation (and of the statistics):
      // t_WB -> centre + scale (t_WB - centre).
      for (Prepared& p : in.prepared) p.t_wb = in.centre + scale * (p.t_wb - in.centre);
      summary->path_scale *= scale;
      summary->path_centre = in.centre;
    }
    if (last_band) ++final_rounds;
    // Re-segmenting can flip a few boundary points in or out of a plane, so
    // the angles settle to within ~1e-5 rad, not to the LM tolerance: stop
    // when a round at the final band moves them less than
    // max(outer_tolerance_rad, 1e-5), or after three rounds at that band.
    const bool settled = change < std::max(so_opts.outer_tolerance_rad, 1e-5);
    if (last_band && (settled || final_rounds >= 3 || outer + 1 == so_opts.max_outer_iterations)) {
      summary->converged = settled || final_rounds >= 3;
      ReportFinalStatistics(&problem, abg, in, used, sightings, chosen, residuals, group_of_row,
                            cs.final_cost, so_opts, summary);
      break;
    }
    band = std::max(options.final_band_m, 0.5 * band);
  }
  summary->angles = c;
  summary->trace = trace;
  if (!summary->converged) {
    return Status::Error("automatic calibration did not settle in " +
                         std::to_string(so_opts.max_outer_iterations) + " outer iterations");
  }
  summary->message = "angles stopped changing at the final inlier band";
  summary->sigma_rad[0] = std::hypot(summary->sigma_rad[0], options.pose_heading_sigma_rad);
  summary->sigma_rad[1] = std::hypot(summary->sigma_rad[1], options.pose_tilt_sigma_rad);
  summary->sigma_rad[2] = std::hypot(summary->sigma_rad[2], options.pose_tilt_sigma_rad);
  const std::string refused = RefuseResult(*summary, options);
  if (!refused.empty()) {
    summary->converged = false;
    summary->message = refused;
    return Status::Error(refused);
  }
  return Status::Ok();
}

}  // namespace sweepscan
