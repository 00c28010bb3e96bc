// sweepscan-cli: the headless front end. Thin: parses arguments, calls core,
// prints text or JSON. Exit codes: 0 success, 1 failure while working
// (e.g. cannot write the output), 2 bad input (usage, invalid files).
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "core/calibration.h"
#include "core/cloud_io.h"
#include "core/evaluation.h"
#include "core/json_reader.h"
#include "core/reconstruct.h"
#include "core/scenario.h"
#include "core/sim/truth_eval.h"
#include "core/sim/world.h"
#include "hardware/simulate_session.h"
#include "hardware/telemetry_decoder.h"

namespace sweepscan::app {
namespace {

const char* kUsage =
    "usage: sweepscan-cli <command> [options]\n"
    "\n"
    "Commands:\n"
    "  simulate   record a simulated scan (scenario file) as a session and reconstruct it\n"
    "  info       describe a recorded session\n"
    "  reconstruct  build the cloud of a recorded session\n"
    "  export     write a session's decoded sensor records as CSV\n"
    "  calibrate  solve the lidar's mounting error from a circle drive (pairs or automatic)\n"
    "  evaluate   planes, deviation histograms, room dimensions and density of a cloud\n"
    "  help       show this text, or `help <command>` for one command\n"
    "\n"
    "Every command accepts --json (machine-readable output on stdout) and --help.\n"
    "Exit codes: 0 ok, 1 failed while working, 2 bad input.\n";

const char* kSimulateUsage =
    "usage: sweepscan-cli simulate --scenario FILE --out CLOUD.ply|CLOUD.pcd [options]\n"
    "\n"
    "Runs the scenario's simulated world faster than real time behind byte-exact\n"
    "emulations of the X4, HI219 and motor board and the robot agent's logic,\n"
    "records the link frames as a session (as a workstation would), reconstructs\n"
    "the cloud from the session's bytes, writes it, and reports its accuracy\n"
    "against the world's ground truth.\n"
    "\n"
    "Options:\n"
    "  --scenario FILE        scenario JSON (docs/scenario-format.md)\n"
    "  --out FILE             cloud to write (.ply binary or .pcd binary, all attributes)\n"
    "  --session DIR          session folder to record (default: next to --out, NAME.sweepscan)\n"
    "  --overwrite            replace an existing session folder\n"
    "  --direct               skip the bytes: reconstruct from the simulator's records directly\n"
    "  --truth FILE           also write ground truth JSON (scenario, trajectory, metrics)\n"
    "  --pose-source S        ekf (default), odometry (wheels only) or truth\n"
    "  --no-ekf               same as --pose-source odometry\n"
    "  --no-deskew            place each whole scan at its first sample's pose\n"
    "  --seed N               override the scenario's seed\n"
    "  --json                 print the report as JSON\n";

nlohmann::json StatsJson(const sim::SurfaceErrorStats& s) {
  return {{"count", s.count}, {"mean_m", s.mean}, {"rms_m", s.rms}, {"p95_m", s.p95}, {"max_m", s.max}};
}

int Simulate(int argc, char** argv) {
  Args args({"json", "no-ekf", "no-deskew", "help", "direct", "overwrite"},
            {"scenario", "out", "truth", "pose-source", "seed", "session"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(error + " (see sweepscan-cli help simulate)");
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kSimulateUsage;
    return kExitOk;
  }
  if (!args.positional().empty()) {
    PrintError("unexpected argument '" + args.positional().front() + "'");
    return kExitBadInput;
  }
  if (!args.Has("scenario") || !args.Has("out")) {
    PrintError("simulate needs --scenario FILE and --out CLOUD.ply (see sweepscan-cli help simulate)");
    return kExitBadInput;
  }
  const std::string out = args.Get("out");
  if (out.size() < 4 || (out.substr(out.size() - 4) != ".ply" && out.substr(out.size() - 4) != ".pcd")) {
    PrintError("--out must end in .ply or .pcd, got '" + out + "'");
    return kExitBadInput;
  }
  sim::SimConfig config;
  Status status = LoadScenario(args.Get("scenario"), &config);
  if (!status.ok()) {
    PrintError(status.message());
    return kExitBadInput;
  }
  if (args.Has("seed")) {
    const std::string s = args.Get("seed");
    char* end = nullptr;
    const unsigned long long seed = std::strtoull(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || s[0] == '-') {
      PrintError("--seed expects a non-negative integer, got '" + s + "'");
      return kExitBadInput;
    }
    config.seed = seed;
  }
  ReconstructionOptions options;
  if (args.Has("pose-source") && !ParsePoseSource(args.Get("pose-source"), &options.pose.source)) {
    PrintError("--pose-source must be ekf, odometry or truth, got '" + args.Get("pose-source") + "'");
    return kExitBadInput;
  }
  if (args.Flag("no-ekf")) options.pose.source = PoseSource::kOdometry;
  options.assembly.deskew = !args.Flag("no-deskew");
  options.pose.initial_pose = config.start;  // the cloud is expressed in the scenario's world frame
  options.assembly.min_range_m = config.lidar.min_range_m;
  options.assembly.max_range_m = config.lidar.max_range_m;

  sim::SimWorld world(config);
  const PoseBuffer truth = world.TruthPoses(1000.0);
  SensorLog log;
  std::string session_dir;
  if (args.Flag("direct")) {
    log = world.RunAll();
  } else {
    session_dir = args.Get("session", out.substr(0, out.size() - 4) + ".sweepscan");
    hardware::SimulateSessionOptions sim_options;
    sim_options.overwrite = args.Flag("overwrite");
    sim_options.notes = "sweepscan-cli simulate --scenario " + args.Get("scenario");
    hardware::SimulateSessionReport sim_report;
    status = hardware::SimulateSession(config, session_dir, sim_options, &sim_report);
    if (!status.ok()) {
      PrintError(status.message() + (args.Flag("overwrite") ? "" : " (use --overwrite to replace it)"));
      return kExitFailure;
    }
    hardware::SessionDecodeInfo info;
    status = hardware::DecodeSession(session_dir, &log, &info);
    if (!status.ok()) {
      PrintError(status.message());
      return kExitFailure;
    }
  }
  ReconstructionResult result;
  status = Reconstruct(log, config.geometry, options, &truth, &result);
  if (!status.ok()) {
    PrintError(status.message());
    return kExitFailure;
  }
  status = SaveCloud(out, result.points);
  if (!status.ok()) {
    PrintError(status.message());
    return kExitFailure;
  }

  nlohmann::json report;
  report["scenario"] = config.name;
  report["session"] = session_dir;
  report["through_bytes"] = !args.Flag("direct");
  report["seed"] = config.seed;
  report["duration_s"] = world.duration_s();
  report["pose_source"] = PoseSourceName(options.pose.source);
  report["deskew"] = options.assembly.deskew;
  report["scans"] = log.scans.size();
  report["samples"] = result.stats.samples_in;
  report["points"] = result.stats.points_out;
  report["invalid_samples"] = result.stats.invalid_range;
  report["samples_without_pose"] = result.stats.no_pose;
  report["ekf_updates"] = result.ekf_counters.updates;
  report["ekf_rejected"] = result.ekf_counters.rejected;
  report["out"] = out;
  const sim::SurfaceErrorStats surface = sim::SurfaceErrors(config.scene, result.points);
  report["surface_error"] = StatsJson(surface);
  // Final pose error (position and heading) of the estimate against truth.
  if (!result.poses.empty()) {
    const Rigid3d est = result.poses.pose(result.poses.size() - 1);
    const Rigid3d tru = world.TrueWorldFromBody(result.poses.latest());
    report["final_position_error_m"] = (est.translation() - tru.translation()).head<2>().norm();
    report["final_heading_error_rad"] =
        std::abs(WrapAngle(YawFromQuaternion(est.rotation()) - YawFromQuaternion(tru.rotation())));
  }
  for (const char* room : {"room", "stairwell"}) {
    if (config.scene.Find(room) < 0) continue;
    const sim::RoomMeasurement m = sim::MeasureRoom(config.scene, room, result.points);
    if (m.ok) {
      report["room"] = {{"label", room},
                        {"true_m", {m.true_size.x(), m.true_size.y(), m.true_size.z()}},
                        {"measured_m", {m.measured.x(), m.measured.y(), m.measured.z()}},
                        {"relative_error", {m.relative_error.x(), m.relative_error.y(), m.relative_error.z()}}};
    } else {
      report["room"] = {{"label", room}, {"error", m.error}};
    }
  }
  if (config.scene.Find("target") >= 0) {
    const sim::PassDisagreement d = sim::MeasureTargetPasses(config.scene, "target", result.points);
    if (d.ok) {
      report["target_passes"] = {{"passes", d.passes},
                                 {"points", {d.points[0], d.points[1]}},
                                 {"plane_angle_rad", d.plane_angle_rad},
                                 {"plane_offset_m", d.plane_offset_m},
                                 {"centroid_distance_m", d.centroid_distance_m},
                                 {"top_edge_shift_m", d.edge_shift_m}};
    } else {
      report["target_passes"] = {{"passes", d.passes}, {"error", d.error}};
    }
  }

  if (args.Has("truth")) {
    nlohmann::json truth_json;
    truth_json["format"] = "sweepscan-truth";
    truth_json["version"] = 1;
    truth_json["scenario"] = ScenarioToJson(config);
    truth_json["robot_time_offset_s"] = sim::SimWorld::kStartTimeS;
    nlohmann::json traj = nlohmann::json::array();
    for (double t = 0.0; t <= world.duration_s() + 1e-9; t += 0.02) {
      const Pose2d p = world.trajectory().PoseAt(t);
      traj.push_back({t + sim::SimWorld::kStartTimeS, p.x, p.y, p.yaw});
    }
    truth_json["trajectory_columns"] = {"robot_time_s", "x_m", "y_m", "yaw_rad"};
    truth_json["trajectory"] = traj;
    truth_json["report"] = report;
    status = WriteFileAtomically(args.Get("truth"), truth_json.dump(1) + "\n");
    if (!status.ok()) {
      PrintError(status.message());
      return kExitFailure;
    }
  }

  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  if (!session_dir.empty()) std::printf("recorded session %s (through the device and link bytes)\n", session_dir.c_str());
  std::printf("simulated %.1f s of '%s' (seed %llu): %zu scans, %zu samples -> %zu points in %s\n",
              world.duration_s(), config.name.c_str(), static_cast<unsigned long long>(config.seed),
              log.scans.size(), result.stats.samples_in, result.stats.points_out, out.c_str());
  std::printf("poses: %s, deskew %s; EKF updates %d, gated out %d\n", PoseSourceName(options.pose.source),
              options.assembly.deskew ? "on" : "off", result.ekf_counters.updates,
              result.ekf_counters.rejected);
  std::printf("distance to true surfaces: mean %.1f mm, rms %.1f mm, p95 %.1f mm, max %.1f mm\n",
              surface.mean * 1e3, surface.rms * 1e3, surface.p95 * 1e3, surface.max * 1e3);
  if (report.contains("final_heading_error_rad")) {
    std::printf("final pose error: %.3f m, %.3f deg\n", report["final_position_error_m"].get<double>(),
                report["final_heading_error_rad"].get<double>() * 180.0 / M_PI);
  }
  if (report.contains("room") && report["room"].contains("measured_m")) {
    const auto& r = report["room"];
    std::printf("room %s: measured %.3f x %.3f x %.3f m (true %.2f x %.2f x %.2f), error %+.3f %% %+.3f %% %+.3f %%\n",
                r["label"].get<std::string>().c_str(), r["measured_m"][0].get<double>(),
                r["measured_m"][1].get<double>(), r["measured_m"][2].get<double>(), r["true_m"][0].get<double>(),
                r["true_m"][1].get<double>(), r["true_m"][2].get<double>(),
                100 * r["relative_error"][0].get<double>(), 100 * r["relative_error"][1].get<double>(),
                100 * r["relative_error"][2].get<double>());
  }
  if (report.contains("target_passes") && report["target_passes"].contains("plane_offset_m")) {
    const auto& t = report["target_passes"];
    std::printf("target seen in %zu passes: pass-to-pass plane offset %.1f mm, angle %.2f deg, centroid shift %.1f mm, top edge shift %.1f mm\n",
                t["passes"].get<size_t>(), 1e3 * t["plane_offset_m"].get<double>(),
                t["plane_angle_rad"].get<double>() * 180.0 / M_PI, 1e3 * t["centroid_distance_m"].get<double>(),
                1e3 * t["top_edge_shift_m"].get<double>());
  }
  return kExitOk;
}

// ---------------------------------------------------------------------------
// Input shared by calibrate and evaluate: a recorded session folder, or a
// scenario simulated in-process (until `simulate` writes sessions). Both end
// as a SensorLog plus geometry; everything after that is one code path.

struct RecordingInput {
  std::string name;
  SensorLog log;
  RobotGeometry geometry;
  Pose2d start;
  bool has_truth = false;
  sim::SimConfig scenario;  // when simulated: the world and its true mounting error
  PoseBuffer truth_poses;
};

// Returns an exit code (kExitOk on success); prints one error line otherwise.
int LoadRecording(const Args& args, RecordingInput* in) {
  const bool has_scenario = args.Has("scenario");
  if (has_scenario == !args.positional().empty()) {
    PrintError(has_scenario ? "give either SESSION or --scenario FILE, not both"
                            : "missing input: give SESSION or --scenario FILE");
    return kExitBadInput;
  }
  if (args.positional().size() > 1) {
    PrintError("unexpected argument '" + args.positional()[1] + "'");
    return kExitBadInput;
  }
  if (has_scenario) {
    Status s = LoadScenario(args.Get("scenario"), &in->scenario);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    if (args.Has("seed")) {
      const std::string v = args.Get("seed");
      char* end = nullptr;
      const unsigned long long seed = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || v[0] == '-') {
        PrintError("--seed expects a non-negative integer, got '" + v + "'");
        return kExitBadInput;
      }
      in->scenario.seed = seed;
    }
    sim::SimWorld world(in->scenario);
    in->log = world.RunAll();
    in->truth_poses = world.TruthPoses(1000.0);
    in->has_truth = true;
    in->geometry = in->scenario.geometry;
    in->start = in->scenario.start;
    in->name = "scenario " + in->scenario.name;
    return kExitOk;
  }
  const std::string dir = args.positional().front();
  hardware::SessionDecodeInfo info;
  const Status s = hardware::DecodeSession(dir, &in->log, &info);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  in->geometry = info.meta.geometry;
  in->start = SessionStartPose(info.meta);
  in->name = "session " + dir;
  return kExitOk;
}

// Poses for the recording: EKF (default), odometry, or the simulation's truth.
int RecordingPoses(const Args& args, const RecordingInput& in, const MountingError& calibration,
                   ReconstructionResult* result) {
  ReconstructionOptions options;
  if (args.Has("pose-source") && !ParsePoseSource(args.Get("pose-source"), &options.pose.source)) {
    PrintError("--pose-source must be ekf, odometry or truth, got '" + args.Get("pose-source") + "'");
    return kExitBadInput;
  }
  if (options.pose.source == PoseSource::kTruth && !in.has_truth) {
    PrintError("--pose-source truth needs a simulated input (--scenario)");
    return kExitBadInput;
  }
  options.pose.initial_pose = in.start;
  options.calibration = calibration;
  const Status s = Reconstruct(in.log, in.geometry, options, &in.truth_poses, result);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  return kExitOk;
}

nlohmann::json AnglesJson(const MountingError& c) {
  return {{"alpha", c.alpha}, {"beta", c.beta}, {"gamma", c.gamma}};
}

const char* kCalibrateUsage =
    "usage: sweepscan-cli calibrate SESSION|--scenario FILE (--pairs PAIRS.json [--refine] | --auto)\n"
    "                               [--out CALIB.json] [--pose-source ekf|odometry|truth] [--json]\n"
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
    "                    45 deg and two turns at 0.05 m/s: see docs/calibration.md\n"
    "  --auto            no picks: planes seen in both passes (floor, ceiling, walls, board)\n"
    "  --out FILE        write the calibration file (JSON)\n"
    "  --pose-source S   ekf (default), odometry, or truth (simulated input only)\n"
    "  --json            print the result as JSON\n";

int Calibrate(int argc, char** argv) {
  Args args({"json", "auto", "refine", "help"}, {"scenario", "pairs", "out", "pose-source", "seed"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(error + " (see sweepscan-cli help calibrate)");
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kCalibrateUsage;
    return kExitOk;
  }
  if (args.Has("pairs") == args.Flag("auto")) {
    PrintError("give exactly one of --pairs FILE and --auto (see sweepscan-cli help calibrate)");
    return kExitBadInput;
  }
  if (args.Flag("refine") && !args.Has("pairs")) {
    PrintError("--refine needs --pairs FILE");
    return kExitBadInput;
  }
  // Check the cheap inputs before the expensive ones.
  std::vector<PickPair> picks;
  if (args.Has("pairs")) {
    const Status s = LoadPairsFile(args.Get("pairs"), &picks);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    if (picks.size() < 4) {
      PrintError(args.Get("pairs") + ": need at least 4 pairs, got " + std::to_string(picks.size()));
      return kExitBadInput;
    }
  }
  RecordingInput in;
  int code = LoadRecording(args, &in);
  if (code != kExitOk) return code;
  ReconstructionResult recon;
  code = RecordingPoses(args, in, MountingError{}, &recon);
  if (code != kExitOk) return code;
  const SampleStore store(in.log, recon.poses);

  CalibrationSummary summary;
  std::unique_ptr<CalibrationSummary> baseline;  // raw picks, with --refine
  Status s;
  if (args.Flag("auto")) {
    s = SolveAutomatic(store, in.geometry, {}, AutoCalibrationOptions(), &summary);
  } else {
    // The target's region: the picks' bounding box (uncalibrated world
    // positions) grown by 0.25 m; its points split by time gaps give the
    // two passes.
    Eigen::AlignedBox3d region;
    for (const PickPair& p : picks) {
      for (const Pick* k : {&p.pass1, &p.pass2}) {
        LidarObservation o;
        if (!k->has_sample) {
          region.extend(k->world);
        } else if (store.Find(k->sample, &o).ok()) {
          region.extend(ProjectObservation(o, in.geometry, {}));
        }
      }
    }
    if (region.isEmpty()) {
      PrintError(args.Get("pairs") + ": no pick refers to a valid sample of the recording");
      return kExitBadInput;
    }
    // Along the board (its two large extents) by 0.25 m; across a flat set
    // of picks (the board's normal) only by 0.08 m, which still holds the
    // uncalibrated ghosts (a few cm) but not a wall 0.16 m behind.
    Eigen::Vector3d grow = Eigen::Vector3d::Constant(0.25);
    int thin;
    const Eigen::Vector3d extent = region.sizes();
    if (extent.minCoeff(&thin) < 0.1) grow[thin] = 0.08;
    region.min() -= grow;
    region.max() += grow;
    const TargetSightings sightings = CollectTargetSightings(store, in.geometry, {}, region);
    const std::vector<PassWindow>& windows = sightings.windows;
    if (args.Flag("refine")) {
      if (windows.size() < 2) {
        PrintError("the target region around the picks was seen in " +
                   std::to_string(windows.size()) + " pass(es), need 2");
        return kExitBadInput;
      }
      s = SolveRefinedCorners(sightings.passes[0], sightings.passes[1], in.geometry, {},
                              CalibrationOptions(), &summary);
      // The paper's baseline on the same picks, reported beside the result.
      std::vector<ObservationPair> pairs;
      CalibrationSummary raw;
      raw.method = "pairs";
      if (ResolvePairs(picks, store, windows, in.geometry, {}, &pairs).ok() &&
          SolvePairs(pairs, in.geometry, {}, CalibrationOptions(), &raw).ok()) {
        baseline = std::make_unique<CalibrationSummary>(raw);
      }
    } else {
      std::vector<ObservationPair> pairs;
      s = ResolvePairs(picks, store, windows, in.geometry, {}, &pairs);
      if (!s.ok()) {
        PrintError(args.Get("pairs") + ": " + s.message());
        return kExitBadInput;
      }
      summary.method = "pairs";
      s = SolvePairs(pairs, in.geometry, {}, CalibrationOptions(), &summary);
    }
  }
  if (!s.ok()) {
    PrintError("calibration failed: " + s.message());
    return kExitFailure;
  }
  if (args.Has("out")) {
    const Status w = SaveCalibrationFile(args.Get("out"), summary.angles, &summary);
    if (!w.ok()) {
      PrintError(w.message());
      return kExitFailure;
    }
  }
  nlohmann::json report;
  report["input"] = in.name;
  report["pose_source"] = args.Get("pose-source", "ekf");
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
  if (args.Has("out")) report["out"] = args.Get("out");
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
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
  if (args.Has("out")) std::printf("  written:          %s\n", args.Get("out").c_str());
  return kExitOk;
}

const char* kEvaluateUsage =
    "usage: sweepscan-cli evaluate CLOUD.ply|CLOUD.pcd|SESSION|--scenario FILE\n"
    "                              [--calibration CALIB.json] [--pose-source S] [--json]\n"
    "\n"
    "Evaluates a cloud (Miao et al. 2022, section 5): statistical outlier removal,\n"
    "RANSAC planes (floor, ceiling, walls) with normal and RMS, signed deviation\n"
    "histograms (Fig. 9), room dimensions from parallel planes (Table 3) and the\n"
    "mean nearest-neighbour distance (Eq. 18-19). With a SESSION or --scenario\n"
    "and --calibration, the cloud is rebuilt from the raw samples twice, without\n"
    "and with the calibration, and both are reported (before / after).\n";

nlohmann::json EvaluationJson(const CloudEvaluation& e) {
  nlohmann::json planes = nlohmann::json::array();
  for (const auto& p : e.planes) {
    planes.push_back({{"kind", p.kind},
                      {"normal", {p.plane.normal.x(), p.plane.normal.y(), p.plane.normal.z()}},
                      {"d_m", p.plane.d},
                      {"rms_m", p.plane.rms},
                      {"points", p.plane.count},
                      {"tilt_deg", p.tilt_deg},
                      {"histogram",
                       {{"bin_m", p.deviations.bin_m},
                        {"min_m", p.deviations.min_m},
                        {"mean_m", p.deviations.mean_m},
                        {"stddev_m", p.deviations.stddev_m},
                        {"counts", p.deviations.counts}}}});
  }
  nlohmann::json dims = nlohmann::json::array();
  for (const auto& d : e.dimensions) {
    dims.push_back({{"planes", {d.plane_a, d.plane_b}},
                    {"axis", d.axis},
                    {"distance_m", d.distance_m},
                    {"angle_deg", d.angle_deg}});
  }
  return {{"points", e.points_in},
          {"points_after_outlier_removal", e.points_after_outliers},
          {"planes", planes},
          {"dimensions", dims},
          {"mean_nn_distance_m", e.mean_nn_distance_m},
          {"density_queries", e.density_queries}};
}

void PrintEvaluation(const std::string& title, const CloudEvaluation& e) {
  std::printf("%s: %zu points, %zu after outlier removal, mean nearest-neighbour distance %.2f mm\n",
              title.c_str(), e.points_in, e.points_after_outliers, 1e3 * e.mean_nn_distance_m);
  for (size_t i = 0; i < e.planes.size(); ++i) {
    const auto& p = e.planes[i];
    std::printf("  plane %zu %-7s n (%+.4f %+.4f %+.4f) d %+.3f m, %zu points, RMS %.1f mm, tilt %.3f deg\n",
                i, p.kind.c_str(), p.plane.normal.x(), p.plane.normal.y(), p.plane.normal.z(), p.plane.d,
                p.plane.count, 1e3 * p.plane.rms, p.tilt_deg);
  }
  for (const auto& d : e.dimensions) {
    std::printf("  %s dimension %.3f m (planes %d and %d, %.2f deg apart)\n", d.axis.c_str(), d.distance_m,
                d.plane_a, d.plane_b, d.angle_deg);
  }
}

int Evaluate(int argc, char** argv) {
  Args args({"json", "help"}, {"scenario", "calibration", "pose-source", "seed"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(error + " (see sweepscan-cli help evaluate)");
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kEvaluateUsage;
    return kExitOk;
  }
  MountingError calibration;
  if (args.Has("calibration")) {
    const Status s = LoadCalibrationFile(args.Get("calibration"), &calibration);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  const auto is_cloud = [](const std::string& p) {
    return p.size() > 4 && (p.substr(p.size() - 4) == ".ply" || p.substr(p.size() - 4) == ".pcd");
  };
  const EvaluationOptions options;
  std::vector<std::pair<std::string, CloudEvaluation>> results;
  if (!args.Has("scenario") && args.positional().size() == 1 && is_cloud(args.positional()[0])) {
    if (args.Has("calibration")) {
      PrintError("--calibration needs a SESSION or --scenario input: a cloud file holds placed points, "
                 "not the raw samples a calibration re-projects");
      return kExitBadInput;
    }
    std::vector<Eigen::Vector3f> pts;
    const Status s = LoadCloudPositions(args.positional()[0], &pts);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    CloudEvaluation e;
    const Status es = EvaluateCloud(pts, options, &e);
    if (!es.ok()) {
      PrintError(es.message());
      return kExitFailure;
    }
    results.emplace_back("cloud", e);
  } else {
    RecordingInput in;
    int code = LoadRecording(args, &in);
    if (code != kExitOk) return code;
    std::vector<std::pair<std::string, MountingError>> runs = {{"uncalibrated", MountingError{}}};
    if (args.Has("calibration")) runs.emplace_back("calibrated", calibration);
    for (const auto& [title, c] : runs) {
      ReconstructionResult r;
      code = RecordingPoses(args, in, c, &r);
      if (code != kExitOk) return code;
      std::vector<Eigen::Vector3f> pts;
      pts.reserve(r.points.size());
      for (const auto& p : r.points) pts.emplace_back(p.x, p.y, p.z);
      CloudEvaluation e;
      const Status es = EvaluateCloud(pts, options, &e);
      if (!es.ok()) {
        PrintError(es.message());
        return kExitFailure;
      }
      results.emplace_back(title, e);
    }
  }
  if (args.Flag("json")) {
    nlohmann::json report;
    for (const auto& [title, e] : results) report[title] = EvaluationJson(e);
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  for (const auto& [title, e] : results) PrintEvaluation(title, e);
  return kExitOk;
}

}  // namespace

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kUsage;
    return kExitBadInput;
  }
  const std::string command = argv[1];
  if (command == "help" || command == "--help" || command == "-h") {
    const std::string topic = argc > 2 ? argv[2] : "";
    if (topic == "simulate") {
      std::cout << kSimulateUsage;
    } else if (topic == "calibrate") {
      std::cout << kCalibrateUsage;
    } else if (topic == "evaluate") {
      std::cout << kEvaluateUsage;
    } else if (topic == "info") {
      std::cout << kInfoUsage;
    } else if (topic == "reconstruct") {
      std::cout << kReconstructUsage;
    } else if (topic == "export") {
      std::cout << kExportUsage;
    } else {
      std::cout << kUsage;
    }
    return kExitOk;
  }
  if (command == "simulate") return Simulate(argc, argv);
  if (command == "info") return RunInfo(argc, argv);
  if (command == "reconstruct") return RunReconstruct(argc, argv);
  if (command == "export") return RunExport(argc, argv);
  if (command == "calibrate") return Calibrate(argc, argv);
  if (command == "evaluate") return Evaluate(argc, argv);
  PrintError("unknown command '" + command + "'\n" + kUsage);
  return kExitBadInput;
}

}  // namespace sweepscan::app

int main(int argc, char** argv) { return sweepscan::app::Main(argc, argv); }
