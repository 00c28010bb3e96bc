// sweepscan-cli: the headless front end. Thin: parses arguments, calls core,
// prints text or JSON. Exit codes: 0 success, 1 failure while working
// (e.g. cannot write the output), 2 bad input (usage, invalid files).
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "app/cli_args.h"
#include "core/cloud_io.h"
#include "core/json_reader.h"
#include "core/reconstruct.h"
#include "core/scenario.h"
#include "core/sim/truth_eval.h"
#include "core/sim/world.h"

namespace sweepscan::app {
namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

const char* kUsage =
    "usage: sweepscan-cli <command> [options]\n"
    "\n"
    "Commands:\n"
    "  simulate   run a simulated scan (scenario file) and reconstruct its cloud\n"
    "  help       show this text, or `help <command>` for one command\n"
    "\n"
    "Every command accepts --json (machine-readable output on stdout) and --help.\n"
    "Exit codes: 0 ok, 1 failed while working, 2 bad input.\n";

const char* kSimulateUsage =
    "usage: sweepscan-cli simulate --scenario FILE --out CLOUD.ply|CLOUD.pcd [options]\n"
    "\n"
    "Runs the scenario's simulated world faster than real time, reconstructs the\n"
    "cloud from the simulated wheel, IMU and lidar records, writes it, and reports\n"
    "its accuracy against the world's ground truth.\n"
    "\n"
    "Options:\n"
    "  --scenario FILE        scenario JSON (docs/scenario-format.md)\n"
    "  --out FILE             cloud to write (.ply binary or .pcd binary, all attributes)\n"
    "  --truth FILE           also write ground truth JSON (scenario, trajectory, metrics)\n"
    "  --pose-source S        ekf (default), odometry (wheels only) or truth\n"
    "  --no-ekf               same as --pose-source odometry\n"
    "  --no-deskew            place each whole scan at its first sample's pose\n"
    "  --seed N               override the scenario's seed\n"
    "  --json                 print the report as JSON\n";

void PrintError(const std::string& message) { std::cerr << "sweepscan-cli: error: " << message << "\n"; }

nlohmann::json StatsJson(const sim::SurfaceErrorStats& s) {
  return {{"count", s.count}, {"mean_m", s.mean}, {"rms_m", s.rms}, {"p95_m", s.p95}, {"max_m", s.max}};
}

int Simulate(int argc, char** argv) {
  Args args({"json", "no-ekf", "no-deskew", "help"}, {"scenario", "out", "truth", "pose-source", "seed"});
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
  const SensorLog log = world.RunAll();
  const PoseBuffer truth = world.TruthPoses(1000.0);
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

}  // namespace

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kUsage;
    return kExitBadInput;
  }
  const std::string command = argv[1];
  if (command == "help" || command == "--help" || command == "-h") {
    if (argc > 2 && std::string(argv[2]) == "simulate") {
      std::cout << kSimulateUsage;
    } else {
      std::cout << kUsage;
    }
    return kExitOk;
  }
  if (command == "simulate") return Simulate(argc, argv);
  PrintError("unknown command '" + command + "'\n" + kUsage);
  return kExitBadInput;
}

}  // namespace sweepscan::app

int main(int argc, char** argv) { return sweepscan::app::Main(argc, argv); }
