// sweepscan-cli calibrate: argument parsing and printing around the
// calibration workflows in core (SolveAutomatic, CalibrateFromPicks).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_outputs.h"
#include "app/cli_recording.h"
#include "core/calibration/automatic.h"
#include "core/calibration/calibration_file.h"
#include "core/calibration/combine.h"
#include "core/calibration/passes.h"
#include "core/calibration/picks.h"
#include "core/calibration/samples.h"
#include "core/calibration/workflow.h"
#include "core/common/checked_file.h"
#include "core/pose/pose_estimator.h"

namespace sweepscan::app {

const char* const kCalibrateUsage =
    "usage: sweepscan-cli calibrate SESSION|--scenario FILE\n"
    "           (--pairs PAIRS.json [--refine [--board-thickness M] [--board-only]] | --auto)\n"
    "                               [--out CALIB.json] [--pose-source ekf|odometry|truth]\n"
    "                               [--no-smooth] [--json]\n"
    "\n"
    "Solves the lidar's mounting error (alpha, beta, gamma) from a circle drive with\n"
    "Levenberg-Marquardt (docs/calibration.md).\n"
    "\n"
    "Options:\n"
    "  --scenario FILE   simulate this scenario in-process instead of reading a SESSION\n"
    "  --seed N          override the scenario's seed\n"
    "  --pairs FILE      picked corner pairs (docs/calibration.md, \"Pairs file\"), at least 4\n"
    "  --refine          with --pairs: replace each pick by the board corner fitted in its pass\n"
    "                    (all sightings of the target, alternately near and far; reports the\n"
    "                    raw picks as the paper's baseline too). Best with a thin board turned\n"
    "                    45 deg and three turns at 0.05 m/s: see docs/calibration.md\n"
    "  --board-thickness M  with --refine: the target board's thickness in metres (default\n"
    "                    0.005; 0 for a sheet): beams that pass an edge can hit its edge face\n"
    "  --board-only      with --refine: the board's angles alone; by default, on EKF or\n"
    "                    odometry poses, they are combined with the room's planes' (the\n"
    "                    automatic mode on the same drive) by their covariances, which pins\n"
    "                    the alpha + beta the board reads loosely, unless the two disagree\n"
    "                    beyond chance (then the board's alone, with a warning)\n"
    "  --auto            no picks: planes seen in both passes (floor, ceiling, walls, board);\n"
    "                    refuses a drive that is not a circle, and a result at the angle\n"
    "                    bounds, with collapsed residuals or with residuals far above the\n"
    "                    lidar's noise model (exit 1, no file written)\n"
    "  --out FILE        write the calibration file (JSON)\n"
    "  --pose-source S   ekf (default), odometry, or truth (simulated input only)\n"
    "  --no-smooth       EKF poses from the forward filter alone; by default they are\n"
    "                    smoothed over the whole recording (Rauch-Tung-Striebel), which\n"
    "                    takes the IMU's yaw noise out of alpha (docs/calibration.md)\n"
    "  --strict          refuse a session with damaged records (default: skip them, with a warning)\n"
    "  --json            print the result as JSON\n"
    "\n"
    "On EKF poses both modes refuse an IMU whose tilt readings are far noisier than its\n"
    "data sheet (more than 1 deg RMS; exit 1, no file written).\n";

namespace {

// The EKF's poses are smoothed over the recording unless --no-smooth: a
// calibration drive is recorded whole, so every pose can use every reading
// (core/pose/ekf.h, "Smoothing"); odometry and truth are used as they are.
bool SmoothedPoses(const Args& args) {
  return args.Get("pose-source", "ekf") == "ekf" && !args.Flag("no-smooth");
}

// The forward filter's heading error, which alpha absorbs (automatic.h,
// pose_heading_sigma_rad; the defaults are the smoothed poses'): 1 mrad,
// from the robustness sweep (docs/results.md: 0.54 mrad RMS, up to 1.4,
// over 60 two-turn drives on forward EKF poses).
constexpr double kForwardEkfHeadingSigmaRad = 0.001;

nlohmann::json AnglesJson(const MountingError& c) {
  return {{"alpha", c.alpha}, {"beta", c.beta}, {"gamma", c.gamma}};
}

// Checks the cheap inputs (options, the pairs file) before the expensive
// ones. Returns an exit code; kExitOk with *done set after --help.
int ParseCalibrateArgs(const Args& args, std::vector<PickPair>* picks, bool* done) {
  *done = false;
  if (args.Flag("help")) {
    std::cout << kCalibrateUsage;
    *done = true;
    return kExitOk;
  }
  if (args.Has("pairs") == args.Flag("auto")) {
    PrintError(SeeHelp("give exactly one of --pairs FILE and --auto", "calibrate"));
    return kExitBadInput;
  }
  if (args.Flag("refine") && !args.Has("pairs")) {
    PrintError("--refine needs --pairs FILE");
    return kExitBadInput;
  }
  if (args.Flag("board-only") && !args.Flag("refine")) {
    PrintError("--board-only needs --refine (only the refined corners are combined with the "
               "room's planes)");
    return kExitBadInput;
  }
  if (args.Has("board-thickness")) {
    double t = 0.0;
    std::string error;
    if (!args.Flag("refine")) {
      PrintError("--board-thickness needs --refine (only the board fit uses it)");
      return kExitBadInput;
    }
    if (!args.GetDouble("board-thickness", &t, &error)) {
      PrintError(error);
      return kExitBadInput;
    }
    if (!(t >= 0.0 && t <= 0.05)) {
      PrintError("--board-thickness: " + args.Get("board-thickness") +
                 " is not a thickness in metres within 0-0.05");
      return kExitBadInput;
    }
  }
  if (args.Has("out")) {
    // Before the solve, and never over what it reads: `--out` once replaced
    // the pairs file it was given, or the session's meta.json (which the
    // session then could not be opened without).
    const std::string out = args.Get("out");
    std::vector<CommandInput> inputs = {{"the --pairs file", args.Get("pairs")},
                                        {"the --scenario file", args.Get("scenario")}};
    if (!args.positional().empty()) {
      inputs.push_back(
          {"the session folder " + args.positional()[0] + ", which holds the recording",
           args.positional()[0], true});
    }
    if (const int refused = RefuseOutputOverInput({{"--out", out}}, inputs); refused != kExitOk) {
      return refused;
    }
    if (const Status w = CheckCanWrite(out); !w.ok()) {
      PrintError(w.message());
      return kExitFailure;
    }
  }
  if (args.Has("pairs")) {
    const Status s = LoadPairsFile(args.Get("pairs"), picks);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    if (picks->size() < 4) {
      PrintError(args.Get("pairs") + ": need at least 4 pairs, got " + std::to_string(picks->size()));
      return kExitBadInput;
    }
  }
  return kExitOk;
}

// The solve: automatic, or the picks workflow. Returns an exit code and
// prints one error line on failure.
// Odometry poses for the automatic mode: how far their heading departs from
// the EKF's (which fuses the IMU's yaw) over the drive, at most this, or the
// calibration is refused (docs/calibration.md, "What the automatic mode
// refuses"): unequal wheel radii turn the odometry's circle by tens of
// mrad a turn, which the angles absorbed (alpha 6-120 mrad off, beta up to
// 72 mrad, in the robustness sweep's drives).
constexpr double kMaxOdometryDepartureRad = 0.01;

// What a calibration gives beside its result: the raw picks' baseline
// (--refine) and, when the board was combined with the room's planes, the
// two it was made of.
struct Beside {
  std::unique_ptr<CalibrationSummary> baseline;     // raw picks, with --refine
  std::unique_ptr<CalibrationSummary> board_alone;  // combined: the board's own
  std::unique_ptr<CalibrationSummary> planes;       // the room's planes (path scale)
  double planes_chi2 = -1.0;  // the two's disagreement, chi^2 over 3 angles
};

int SolveCalibration(const Args& args, const RecordingInput& in, const SampleStore& store,
                     const std::vector<PickPair>& picks, double odometry_departure_rad,
                     CalibrationSummary* summary, Beside* beside) {
  // EKF poses take roll and pitch from the IMU: a tilt far noisier than the
  // data sheet bends beta and gamma unseen (workflow.h, CheckImuTiltNoise).
  // Odometry and truth poses do not use the IMU's tilt.
  if (args.Get("pose-source", "ekf") == "ekf") {
    const Status tilt = CheckImuTiltNoise(in.log);
    if (!tilt.ok()) {
      PrintError("calibration " + tilt.message());
      return kExitFailure;
    }
  }
  if (args.Flag("auto")) {
    // A drive that is not a circle is refused before solving, a degenerate
    // result after (docs/calibration.md): one line, exit 1, no file.
    AutoCalibrationOptions options;
    // The poses' heading error that alpha absorbs (automatic.h): the EKF's
    // by default; none for simulated truth; odometry's is its departure
    // from the EKF's heading on top of the EKF's own.
    const std::string source = args.Get("pose-source", "ekf");
    if (source == "truth") options.pose_heading_sigma_rad = options.pose_tilt_sigma_rad = 0.0;
    if (source != "truth" && !SmoothedPoses(args)) {
      options.pose_heading_sigma_rad = kForwardEkfHeadingSigmaRad;
    }
    if (source == "odometry") {
      if (odometry_departure_rad > kMaxOdometryDepartureRad) {
        char text[320];
        std::snprintf(text, sizeof(text),
                      "calibration refused: the odometry's heading departs %.1f mrad from the "
                      "EKF's (IMU-fused) over the drive, more than %.0f: unequal wheel radii or "
                      "slip would bend the calibration; use --pose-source ekf",
                      1e3 * odometry_departure_rad, 1e3 * kMaxOdometryDepartureRad);
        PrintError(text);
        return kExitFailure;
      }
      options.pose_heading_sigma_rad =
          std::hypot(options.pose_heading_sigma_rad, std::max(0.0, odometry_departure_rad));
    }
    const Status s = SolveAutomatic(store, in.geometry, {}, options, summary);
    if (!s.ok()) {
      const bool refused = s.message().rfind("refused: ", 0) == 0;
      PrintError((refused ? "calibration " : "calibration failed: ") + s.message());
      return kExitFailure;
    }
    return kExitOk;
  }
  PickCalibrationOptions options;
  options.refine = args.Flag("refine");
  if (args.Has("board-thickness")) {
    std::string unused;  // checked in ParseCalibrateArgs
    args.GetDouble("board-thickness", &options.solver.board_thickness_m, &unused);
  }
  // The EKF's (or the odometry's) distance scale from the room's planes
  // first (workflow.h); simulated truth needs none.
  options.path_scale_from_planes = args.Get("pose-source", "ekf") != "truth";
  options.combine_with_planes = options.path_scale_from_planes && !args.Flag("board-only");
  if (args.Get("pose-source", "ekf") == "truth") {
    options.pose_heading_sigma_rad = options.pose_tilt_sigma_rad = 0.0;
  } else if (!SmoothedPoses(args)) {
    options.pose_heading_sigma_rad = kForwardEkfHeadingSigmaRad;
  }
  PickCalibrationResult result;
  const Status s = CalibrateFromPicks(store, in.geometry, picks, options, &result);
  using Failure = PickCalibrationResult::Failure;
  switch (result.failure) {
    case Failure::kNone:
      break;
    case Failure::kNoValidPick:
    case Failure::kUnresolvedPicks:
    case Failure::kImplausible:
      PrintError(args.Get("pairs") + ": " + s.message());
      return kExitBadInput;
    case Failure::kTargetNotSeenTwice:
      PrintError(s.message());
      return kExitBadInput;
    case Failure::kSolveFailed:
      PrintError("calibration failed: " + s.message());
      return kExitFailure;
  }
  *summary = result.summary;
  summary->path_scale = result.path_scale;  // applied to the poses first (1: none)
  if (result.has_baseline) beside->baseline = std::make_unique<CalibrationSummary>(result.baseline);
  if (result.has_board_alone) {
    beside->board_alone = std::make_unique<CalibrationSummary>(result.board_alone);
  }
  if (result.has_planes) beside->planes = std::make_unique<CalibrationSummary>(result.planes);
  beside->planes_chi2 = result.planes_chi2;
  return kExitOk;
}

nlohmann::json CalibrationReport(const Args& args, const RecordingInput& in,
                                 const CalibrationSummary& summary, const Beside& beside) {
  const CalibrationSummary* baseline = beside.baseline.get();
  nlohmann::json report;
  report["input"] = in.name;
  report["pose_source"] = args.Get("pose-source", "ekf");
  report["poses_smoothed"] = SmoothedPoses(args);
  report["method"] = summary.method;
  report["converged"] = summary.converged;
  report["mounting_error_rad"] = AnglesJson(summary.angles);
  report["sigma_rad"] = {{"alpha", summary.sigma_rad[0]},
                         {"beta", summary.sigma_rad[1]},
                         {"gamma", summary.sigma_rad[2]}};
  report["rms_before_m"] = summary.initial_rms_m;
  report["rms_after_m"] = summary.final_rms_m;
  report["residual_blocks"] = summary.residual_blocks;
  report["planes"] = summary.planes;
  report["outer_iterations"] = summary.outer_iterations;
  report["lm_iterations"] = summary.trace.size();
  report["condition_number"] = summary.condition_number;
  if (summary.method.rfind("refined-corners", 0) == 0) {
    report["board_thickness_m"] = summary.board_thickness_m;
    report["edge_points"] = summary.edge_points;
    report["rejected_edge_points"] = summary.rejected_edge_points;
    report["shifted_edge_points"] = summary.shifted_edge_points;
    report["mixed_edge_samples"] = summary.mixed_edge_samples;
    report["range_offsets_m"] = {summary.range_offsets_m[0], summary.range_offsets_m[1]};
    report["sigma_range_rad"] = {{"alpha", summary.sigma_range_rad[0]},
                                 {"beta", summary.sigma_range_rad[1]},
                                 {"gamma", summary.sigma_range_rad[2]}};
  }
  if (summary.method != "auto-planes" && summary.path_scale != 1.0) {
    report["path_scale"] = summary.path_scale;
  }
  if (summary.method == "auto-planes") {
    report["path_scale"] = summary.path_scale;
    report["rms_sigmas"] = summary.rms_sigmas;
    report["sigma_iid_rad"] = {{"alpha", summary.sigma_iid_rad[0]},
                               {"beta", summary.sigma_iid_rad[1]},
                               {"gamma", summary.sigma_iid_rad[2]}};
  }
  report["warnings"] = summary.warnings;
  nlohmann::json trace = nlohmann::json::array();
  for (const auto& it : summary.trace) {
    trace.push_back({it.iteration, it.angles.alpha, it.angles.beta, it.angles.gamma, it.cost});
  }
  report["trace_columns"] = {"iteration", "alpha", "beta", "gamma", "cost"};
  report["trace"] = trace;
  if (in.has_truth) {
    const MountingError& t = in.scenario.mounting_error;
    report["truth_rad"] = AnglesJson(t);
    report["error_rad"] = AnglesJson({summary.angles.alpha - t.alpha, summary.angles.beta - t.beta,
                                      summary.angles.gamma - t.gamma});
  }
  if (baseline) {
    nlohmann::json b;
    b["method"] = "pairs (raw-sample picks)";
    b["mounting_error_rad"] = AnglesJson(baseline->angles);
    b["rms_before_m"] = baseline->initial_rms_m;
    b["rms_after_m"] = baseline->final_rms_m;
    if (in.has_truth) {
      const MountingError& t = in.scenario.mounting_error;
      b["error_rad"] = AnglesJson({baseline->angles.alpha - t.alpha,
                                   baseline->angles.beta - t.beta,
                                   baseline->angles.gamma - t.gamma});
    }
    report["baseline"] = b;
  }
  // The combination's parts: the board alone and the room's planes alone.
  for (const auto& [key, part] : {std::make_pair("board_alone", beside.board_alone.get()),
                                  std::make_pair("room_planes", beside.planes.get())}) {
    // The planes' angles are shown as a part of the combination only.
    if (part == nullptr || (key == std::string("room_planes") && !beside.board_alone)) continue;
    nlohmann::json b;
    b["method"] = part->method;
    b["mounting_error_rad"] = AnglesJson(part->angles);
    b["sigma_rad"] = AnglesJson({part->sigma_rad[0], part->sigma_rad[1], part->sigma_rad[2]});
    if (in.has_truth) {
      const MountingError& t = in.scenario.mounting_error;
      b["error_rad"] = AnglesJson(
          {part->angles.alpha - t.alpha, part->angles.beta - t.beta, part->angles.gamma - t.gamma});
    }
    report[key] = b;
  }
  if (beside.planes_chi2 >= 0.0) report["planes_chi2"] = beside.planes_chi2;
  if (args.Has("out")) report["out"] = args.Get("out");
  return report;
}

void PrintCalibration(const Args& args, const RecordingInput& in,
                      const CalibrationSummary& summary, const Beside& beside,
                      const nlohmann::json& report) {
  const CalibrationSummary* baseline = beside.baseline.get();
  std::cout << summary.FullReport();
  if (in.has_truth) {
    std::printf("  error vs truth:   %+.3f %+.3f %+.3f mrad\n",
                1e3 * report["error_rad"]["alpha"].get<double>(),
                1e3 * report["error_rad"]["beta"].get<double>(),
                1e3 * report["error_rad"]["gamma"].get<double>());
  }
  if (baseline) {
    std::printf("  raw-sample picks (the paper's baseline): %+.6f %+.6f %+.6f rad",
                baseline->angles.alpha, baseline->angles.beta, baseline->angles.gamma);
    if (in.has_truth) {
      std::printf(", error %+.3f %+.3f %+.3f mrad",
                  1e3 * report["baseline"]["error_rad"]["alpha"].get<double>(),
                  1e3 * report["baseline"]["error_rad"]["beta"].get<double>(),
                  1e3 * report["baseline"]["error_rad"]["gamma"].get<double>());
    }
    std::printf("\n");
  }
  for (const auto& [key, name] : {std::make_pair("board_alone", "the board alone:        "),
                                  std::make_pair("room_planes", "the room's planes alone:")}) {
    if (!report.contains(key)) continue;
    const nlohmann::json& part = report[key];
    std::printf("  %s %+.6f %+.6f %+.6f rad, 1-sigma %.2f %.2f %.2f mrad", name,
                part["mounting_error_rad"]["alpha"].get<double>(),
                part["mounting_error_rad"]["beta"].get<double>(),
                part["mounting_error_rad"]["gamma"].get<double>(),
                1e3 * part["sigma_rad"]["alpha"].get<double>(),
                1e3 * part["sigma_rad"]["beta"].get<double>(),
                1e3 * part["sigma_rad"]["gamma"].get<double>());
    if (in.has_truth) {
      std::printf(", error %+.3f %+.3f %+.3f mrad", 1e3 * part["error_rad"]["alpha"].get<double>(),
                  1e3 * part["error_rad"]["beta"].get<double>(),
                  1e3 * part["error_rad"]["gamma"].get<double>());
    }
    std::printf("\n");
  }
  if (report.contains("planes_chi2")) {
    std::printf("  board vs planes:  chi^2 %.2f over 3 angles (combined up to %.2f)\n",
                report["planes_chi2"].get<double>(), kMaxCombineChi2);
  }
  if (args.Has("out")) std::printf("  written:          %s\n", args.Get("out").c_str());
}

}  // namespace

int RunCalibrate(int argc, char** argv) {
  Args args({"json", "auto", "refine", "help", "strict", "no-smooth", "board-only"},
            {"scenario", "pairs", "out", "pose-source", "seed", "board-thickness"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "calibrate"));
    return kExitBadInput;
  }
  std::vector<PickPair> picks;
  bool done = false;
  int code = ParseCalibrateArgs(args, &picks, &done);
  if (code != kExitOk || done) return code;
  RecordingInput in;
  code = LoadRecording(args, &in);
  if (code != kExitOk) return code;
  ReconstructionResult recon;
  code = RecordingPoses(args, in, MountingError{}, SmoothedPoses(args), &recon);
  if (code != kExitOk) return code;
  const SampleStore store(in.log, recon.poses);
  double odometry_departure_rad = -1.0;
  if (args.Flag("auto") && args.Get("pose-source", "ekf") == "odometry") {
    // The EKF's poses of the same recording (no cloud needed).
    PoseEstimatorOptions ekf;
    ekf.initial_pose = in.start;
    odometry_departure_rad =
        MaxHeadingDeparture(recon.poses, EstimatePoses(in.log, ekf, in.geometry).poses());
  }

  CalibrationSummary summary;
  Beside beside;
  code = SolveCalibration(args, in, store, picks, odometry_departure_rad, &summary, &beside);
  if (code != kExitOk) return code;
  if (args.Has("out")) {
    const Status w = SaveCalibrationFile(args.Get("out"), summary.angles, &summary);
    if (!w.ok()) {
      PrintError(w.message());
      return kExitFailure;
    }
  }
  const nlohmann::json report = CalibrationReport(args, in, summary, beside);
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  PrintCalibration(args, in, summary, beside, report);
  return kExitOk;
}

}  // namespace sweepscan::app
