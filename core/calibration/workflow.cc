// Picks -> mounting error, as sweepscan-cli's `calibrate --pairs` and the
// desktop app's calibration panel run it (workflow.h).
#include "core/calibration/workflow.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/calibration/automatic.h"
#include "core/calibration/combine.h"
#include "core/calibration/internal.h"

namespace sweepscan {

Eigen::AlignedBox3d TargetRegionFromPicks(const std::vector<PickPair>& picks,
                                          const SampleStore& store, const RobotGeometry& geometry,
                                          const MountingError& calibration) {
  Eigen::AlignedBox3d region;
  for (const PickPair& p : picks) {
    for (const Pick* k : {&p.pass1, &p.pass2}) {
      LidarObservation o;
      if (!k->has_sample) {
        region.extend(k->world);
      } else if (FindPickedSample(*k, store, &o).ok()) {
        region.extend(ProjectObservation(o, geometry, calibration));
      }
    }
  }
  if (region.isEmpty()) return region;
  Eigen::Vector3d grow = Eigen::Vector3d::Constant(0.25);
  int thin;
  const Eigen::Vector3d extent = region.sizes();
  if (extent.minCoeff(&thin) < 0.1) grow[thin] = 0.08;
  region.min() -= grow;
  region.max() += grow;
  return region;
}

namespace {

// The board's angles and the room's planes' made into one (combine.h), the
// board's kept in result->board_alone; or, when the two disagree beyond
// chance, the board's alone with a warning that says so.
void CombineWithPlanes(const PickCalibrationOptions& options, PickCalibrationResult* result) {
  CalibrationSummary& summary = result->summary;
  const CalibrationSummary& planes = result->planes;
  // The poses' errors, independent between the two for the check (combine.h).
  const Eigen::Vector3d pose(options.pose_heading_sigma_rad, options.pose_tilt_sigma_rad,
                             options.pose_tilt_sigma_rad);
  const Eigen::Matrix3d unmodelled = 2.0 * pose.cwiseAbs2().asDiagonal().toDenseMatrix();
  const CombinedAngles c = CombineAngleEstimates(
      summary.angles, summary.covariance_rad2, planes.angles, planes.covariance_rad2, unmodelled);
  result->planes_chi2 = c.chi2 > 0.0 ? c.chi2 : -1.0;
  if (!c.combined) {
    if (c.chi2 > 0.0) {
      char text[400];
      std::snprintf(text, sizeof(text),
                    "the board and the room's planes disagree (chi^2 %.1f over the three angles, "
                    "above %.1f; planes: alpha %+.2f, beta %+.2f, gamma %+.2f mrad): the board's "
                    "angles alone are given; check the picks and that the room's surfaces are flat",
                    c.chi2, kMaxCombineChi2, 1e3 * planes.angles.alpha, 1e3 * planes.angles.beta,
                    1e3 * planes.angles.gamma);
      summary.warnings.push_back(text);
    }
    return;
  }
  result->has_board_alone = true;
  result->board_alone = summary;
  summary.method = "refined-corners+planes";
  summary.angles = c.angles;
  summary.covariance_rad2 = c.covariance_rad2;
  summary.sigma_rad = c.sigma_rad;
}

}  // namespace

Status CalibrateFromPicks(const SampleStore& recorded, const RobotGeometry& geometry,
                          const std::vector<PickPair>& picks,
                          const PickCalibrationOptions& options, PickCalibrationResult* result) {
  using Failure = PickCalibrationResult::Failure;
  *result = PickCalibrationResult();
  const MountingError& initial = options.initial;
  // The poses' distance scale first, from the room's planes (options).
  std::string scale_warning;
  SampleStore scaled;
  bool use_scaled = false;
  if (options.path_scale_from_planes) {
    CalibrationSummary& planes = result->planes;
    AutoCalibrationOptions auto_options;
    auto_options.solver.progress = options.solver.progress;
    auto_options.pose_heading_sigma_rad = options.pose_heading_sigma_rad;
    auto_options.pose_tilt_sigma_rad = options.pose_tilt_sigma_rad;
    const Status a = SolveAutomatic(recorded, geometry, initial, auto_options, &planes);
    if (a.ok()) {
      scaled = recorded.ScaledAbout(planes.path_centre, planes.path_scale);
      use_scaled = true;
      result->path_scale = planes.path_scale;
      result->has_planes = true;
    } else {
      scale_warning = "the poses' distance scale was not corrected (the room's planes gave none: " +
                      a.message() + ")";
    }
  }
  const SampleStore& store = use_scaled ? scaled : recorded;
  result->region = TargetRegionFromPicks(picks, store, geometry, initial);
  if (result->region.isEmpty()) {
    result->failure = Failure::kNoValidPick;
    return Status::Error("no pick refers to a valid sample of the recording");
  }
  // The region's points split by time gaps give the passes.
  result->sightings = CollectTargetSightings(store, geometry, initial, result->region);
  const std::vector<PassWindow>& windows = result->sightings.windows;
  CalibrationSummary& summary = result->summary;
  Status s;
  if (options.refine) {
    if (windows.size() < 2) {
      result->failure = Failure::kTargetNotSeenTwice;
      return Status::Error("the target region around the picks was seen in " +
                           std::to_string(windows.size()) + " pass(es), need 2");
    }
    // Every sample pick must be the recording's, as without refine: a pick
    // of another recording only left the region (and the baseline) quietly,
    // and three of four such gave a confident wrong result. Which sighting
    // it is in does not matter here (the picks only mark the target; every
    // sighting is fitted), so a pick in the third turn is fine.
    for (size_t k = 0; k < picks.size(); ++k) {
      for (const auto& [pick, name] :
           {std::make_pair(&picks[k].pass1, "pass1"), std::make_pair(&picks[k].pass2, "pass2")}) {
        LidarObservation o;
        const Status found = pick->has_sample ? FindPickedSample(*pick, store, &o) : Status::Ok();
        if (!found.ok()) {
          result->failure = Failure::kUnresolvedPicks;
          return Status::Error(calibration_internal::PairName(k) + " " + name + ": " +
                               found.message());
        }
      }
    }
    s = SolveRefinedCorners(result->sightings.passes[0], result->sightings.passes[1], geometry,
                            initial, options.solver, &summary);
    // The paper's baseline on the same picks, reported beside the result.
    std::vector<ObservationPair> pairs;
    CalibrationSummary raw;
    raw.method = "pairs";
    if (ResolvePairs(picks, store, windows, geometry, initial, &pairs).ok() &&
        SolvePairs(pairs, geometry, initial, options.solver, &raw).ok()) {
      result->has_baseline = true;
      result->baseline = raw;
    }
  } else {
    std::vector<ObservationPair> pairs;
    s = ResolvePairs(picks, store, windows, geometry, initial, &pairs);
    // A pair given twice, or both picks of a pair in one pass, is the
    // file's mistake (exit 2), not a solve that failed (it said exit 1).
    if (s.ok()) s = CheckObservationPairs(pairs, geometry, initial);
    if (!s.ok()) {
      result->failure = Failure::kUnresolvedPicks;
      return s;
    }
    summary.method = "pairs";
    s = SolvePairs(pairs, geometry, initial, options.solver, &summary);
  }
  if (!s.ok()) {
    result->failure = Failure::kSolveFailed;
    return s;
  }
  const Eigen::Vector3d angles(summary.angles.alpha, summary.angles.beta, summary.angles.gamma);
  char text[400];
  if (!(angles.cwiseAbs().maxCoeff() <= kMaxPickAngleRad)) {
    result->failure = Failure::kImplausible;
    std::snprintf(
        text, sizeof(text),
        "the solve ended at alpha %.4f, beta %.4f, gamma %.4f rad with the pairs %.3f m apart "
        "(RMS): no mounting error (at most %.2f rad); the picks most likely pair different "
        "corners in the two passes (check their order)",
        angles[0], angles[1], angles[2], summary.final_rms_m, kMaxPickAngleRad);
    return Status::Error(text);
  }
  if (!(summary.final_rms_m <= kMaxPickRmsM)) {
    // Said, not refused: poses that drift (odometry alone) also leave the
    // pairs apart, and the angles may still be the best there are.
    std::snprintf(
        text, sizeof(text),
        "the pairs are still %.3f m apart (RMS) after the solve: check that each pair is one "
        "corner in both passes",
        summary.final_rms_m);
    summary.warnings.push_back(text);
  }
  if (!scale_warning.empty()) summary.warnings.push_back(scale_warning);
  if (options.refine && options.combine_with_planes && result->has_planes) {
    CombineWithPlanes(options, result);
  }
  for (CalibrationSummary* sum : {&summary, &result->baseline, &result->board_alone}) {
    if (sum->sigma_rad.minCoeff() < 0.0) continue;  // unknown
    sum->sigma_rad[0] = std::hypot(sum->sigma_rad[0], options.pose_heading_sigma_rad);
    sum->sigma_rad[1] = std::hypot(sum->sigma_rad[1], options.pose_tilt_sigma_rad);
    sum->sigma_rad[2] = std::hypot(sum->sigma_rad[2], options.pose_tilt_sigma_rad);
  }
  // The pairs and corners under the result, for display.
  std::vector<ObservationPair> resolved;
  if (!ResolvePairs(picks, store, windows, geometry, initial, &resolved).ok()) return s;
  BoardCorners before[2];
  if (options.refine) {
    result->has_corners = true;
    for (int k = 0; k < 2; ++k) {
      result->has_corners =
          result->has_corners &&
          FitBoardCorners(result->sightings.passes[k], geometry, initial,
                          options.solver.board_thickness_m, &before[k]).ok() &&
          FitBoardCorners(result->sightings.passes[k], geometry, summary.angles,
                          options.solver.board_thickness_m, &result->corners[k])
              .ok();
    }
  }
  // Combined: the corners' distance under the combined angles, as the pair
  // checks below show it (the board's own stays in board_alone).
  if (result->has_board_alone && result->has_corners) {
    summary.final_rms_m = CornerRms(result->corners[0], result->corners[1]);
  }
  for (const ObservationPair& pair : resolved) {
    PickCalibrationResult::PairCheck check;
    const Eigen::Vector3d a0 = ProjectObservation(pair.pass1, geometry, initial);
    if (result->has_corners) {
      // Refined: the pair stands for the fitted corner nearest its pick;
      // its gap is that corner's, fitted in each pass (what was solved).
      int nearest = 0;
      for (int c = 1; c < 4; ++c) {
        if ((before[0].corners[c] - a0).norm() < (before[0].corners[nearest] - a0).norm()) {
          nearest = c;
        }
      }
      check.pass1_world = result->corners[0].corners[nearest];
      check.pass2_world = result->corners[1].corners[nearest];
      check.before_m = (before[0].corners[nearest] - before[1].corners[nearest]).norm();
    } else {
      check.pass1_world = ProjectObservation(pair.pass1, geometry, summary.angles);
      check.pass2_world = ProjectObservation(pair.pass2, geometry, summary.angles);
      check.before_m = (a0 - ProjectObservation(pair.pass2, geometry, initial)).norm();
    }
    check.after_m = (check.pass1_world - check.pass2_world).norm();
    result->pair_checks.push_back(check);
  }
  return s;
}

ImuTiltNoise MeasureImuTiltNoise(const SensorLog& log, double max_gap_s) {
  std::vector<double> droll, dpitch;
  const ImuMeasurement* previous = nullptr;
  for (const ImuMeasurement& m : log.imu) {
    if (!m.has_attitude) continue;
    if (previous != nullptr && ToSeconds(m.time - previous->time) <= max_gap_s) {
      droll.push_back(std::abs(WrapAngle(m.roll - previous->roll)));
      dpitch.push_back(std::abs(WrapAngle(m.pitch - previous->pitch)));
    }
    previous = &m;
  }
  ImuTiltNoise noise;
  noise.pairs = static_cast<int>(droll.size());
  if (droll.empty()) return noise;
  // sigma of a difference of two independent readings is sqrt(2) sigma; the
  // median of |N(0, s^2)| is s / 1.4826.
  auto sigma = [](std::vector<double>* d) {
    std::nth_element(d->begin(), d->begin() + d->size() / 2, d->end());
    return 1.4826 * (*d)[d->size() / 2] / std::sqrt(2.0);
  };
  noise.roll_rad = sigma(&droll);
  noise.pitch_rad = sigma(&dpitch);
  return noise;
}

Status CheckImuTiltNoise(const SensorLog& log, double max_rad) {
  const ImuTiltNoise noise = MeasureImuTiltNoise(log);
  if (noise.pairs < 100 || noise.worst_rad() <= max_rad) return Status::Ok();
  char text[400];
  std::snprintf(text, sizeof(text),
                "refused: the IMU's tilt readings scatter %.2f deg (roll) and %.2f deg (pitch) "
                "RMS (measured between consecutive readings), more than %.1f deg (the HI219's "
                "data sheet: 0.1-0.5): the EKF's roll and pitch would wander and bend beta and "
                "gamma; check the IMU and its mounting (vibration)",
                noise.roll_rad * 180.0 / M_PI, noise.pitch_rad * 180.0 / M_PI,
                max_rad * 180.0 / M_PI);
  return Status::Error(text);
}

void UseMeasuredTiltNoise(const SensorLog& log, EkfOptions* ekf) {
  const ImuTiltNoise noise = MeasureImuTiltNoise(log);
  if (noise.pairs >= 100) ekf->imu_tilt_sigma = std::max(ekf->imu_tilt_sigma, noise.worst_rad());
}

}  // namespace sweepscan
