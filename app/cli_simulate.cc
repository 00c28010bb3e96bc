// sweepscan-cli simulate: a scenario's world behind the byte-exact device
// emulations, recorded as a session, reconstructed from its bytes and
// measured against the ground truth. The cloud is streamed from the
// session, written and measured piece by piece, so a 12-hour drive needs
// what a minute's does but for its poses (docs/performance.md).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_outputs.h"
#include "app/terminal_progress.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/reconstruct.h"
#include "core/common/checked_file.h"
#include "core/common/file_suffix.h"
#include "core/common/json_reader.h"
#include "core/scenario/scenario.h"
#include "core/sim/truth_eval.h"
#include "core/sim/world.h"
#include "hardware/emulation/simulate_session.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/session_stream.h"

namespace sweepscan::app {

const char* const kSimulateUsage =
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
    "  --json                 print the report as JSON\n"
    "\n"
    "The cloud is streamed from the recorded session, written and measured as it is\n"
    "placed: memory does not grow with the drive but for its poses (a 12-hour drive:\n"
    "0.6 GB). On a terminal (and without --json) the progress is shown on stderr.\n";

namespace {

nlohmann::json StatsJson(const sim::SurfaceErrorStats& s) {
  return {{"count", s.count}, {"mean_m", s.mean}, {"rms_m", s.rms}, {"p95_m", s.p95}, {"max_m", s.max}};
}

// What the command line asks for.
struct SimulateRequest {
  std::string out;
  sim::SimConfig config;
  ReconstructionOptions options;
};

// Returns an exit code; kExitOk with `request` filled to go on, kExitOk
// with request->out empty after --help.
int ParseSimulateArgs(const Args& args, SimulateRequest* request) {
  if (args.Flag("help")) {
    std::cout << kSimulateUsage;
    return kExitOk;
  }
  if (!args.positional().empty()) {
    PrintError("unexpected argument '" + args.positional().front() + "'");
    return kExitBadInput;
  }
  if (!args.Has("scenario") || !args.Has("out")) {
    PrintError(SeeHelp("simulate needs --scenario FILE and --out CLOUD.ply", "simulate"));
    return kExitBadInput;
  }
  const std::string out = args.Get("out");
  if (!HasFileSuffix(out, ".ply") && !HasFileSuffix(out, ".pcd")) {
    PrintError("--out must end in .ply or .pcd, got '" + out + "'");
    return kExitBadInput;
  }
  sim::SimConfig& config = request->config;
  Status status = LoadScenario(args.Get("scenario"), &config);
  if (!status.ok()) {
    PrintError(status.message());
    return kExitBadInput;
  }
  if (args.Has("seed")) {
    const std::string s = args.Get("seed");
    uint64_t seed = 0;
    if (!ParseSeed(s, &seed)) {
      PrintError("--seed expects an integer from 0 to 2^64 - 1, got '" + s + "'");
      return kExitBadInput;
    }
    config.seed = seed;
  }
  ReconstructionOptions& options = request->options;
  if (args.Has("pose-source") && (!ParsePoseSource(args.Get("pose-source"), &options.pose.source) ||
                                  options.pose.source == PoseSource::kSfm)) {
    PrintError("--pose-source must be ekf, odometry or truth, got '" + args.Get("pose-source") + "'");
    return kExitBadInput;
  }
  if (args.Flag("no-ekf")) options.pose.source = PoseSource::kOdometry;
  options.assembly.deskew = !args.Flag("no-deskew");
  options.pose.initial_pose = config.start;  // the cloud is expressed in the scenario's world frame
  options.assembly.min_range_m = config.lidar.min_range_m;
  options.assembly.max_range_m = config.lidar.max_range_m;
  request->out = out;
  return kExitOk;
}

// What the report measures of the cloud, fed each piece as it is written
// (core/sim/truth_eval.h): the cloud is never held.
class CloudMeasures {
 public:
  explicit CloudMeasures(const sim::Scene& scene) : surface_(scene) {
    for (const char* room : {"room", "stairwell"}) {
      if (scene.Find(room) >= 0) rooms_.emplace_back(room, sim::RoomAccumulator(scene, room));
    }
    if (scene.Find("target") >= 0) target_.emplace(scene, "target");
  }
  void Add(const CloudPoint* p, size_t n) {
    surface_.Add(p, n);
    for (auto& room : rooms_) room.second.Add(p, n);
    if (target_) target_->Add(p, n);
  }
  const sim::SurfaceErrorAccumulator& surface() const { return surface_; }
  const std::vector<std::pair<std::string, sim::RoomAccumulator>>& rooms() const { return rooms_; }
  const sim::TargetPassAccumulator* target() const { return target_ ? &*target_ : nullptr; }

 private:
  sim::SurfaceErrorAccumulator surface_;
  std::vector<std::pair<std::string, sim::RoomAccumulator>> rooms_;
  std::optional<sim::TargetPassAccumulator> target_;  // none without a target
};

// The session folder, recorded through the device and link bytes.
int RecordSession(const Args& args, const SimulateRequest& request, TerminalProgress* progress,
                  std::string* session_dir) {
  const std::string& out = request.out;
  *session_dir = args.Get("session", out.substr(0, out.size() - 4) + ".sweepscan");
  hardware::SimulateSessionOptions sim_options;
  sim_options.overwrite = args.Flag("overwrite");
  sim_options.notes = "sweepscan-cli simulate --scenario " + args.Get("scenario");
  if (progress->on()) {
    sim_options.progress = [progress](double f) { progress->Show("recording the drive", f); };
  }
  hardware::SimulateSessionReport sim_report;
  // Not followed through a link (a dangling one is not ours to remove), and
  // an unanswerable question (a name too long) counts as there.
  std::error_code looked;
  const auto status_before = std::filesystem::symlink_status(*session_dir, looked);
  const bool existed = looked ? looked != std::errc::no_such_file_or_directory
                              : std::filesystem::exists(status_before);
  Status status = hardware::SimulateSession(request.config, *session_dir, sim_options, &sim_report);
  if (!status.ok()) {
    progress->Clear();  // the error on a line of its own
    // A drive cut short by a full disk is no recording of the scenario (as a
    // robot's would be): what was written goes, and the folder made for it.
    std::error_code ignored;
    if (!existed) std::filesystem::remove_all(*session_dir, ignored);
    // --overwrite only helps when the session folder already holds a session.
    const bool exists = status.message().find("not empty") != std::string::npos;
    // The writer's "(ask for overwrite explicitly)" becomes this command's option.
    std::string message = status.message();
    const std::string generic = " (ask for overwrite explicitly)";
    if (exists && !args.Flag("overwrite") && message.size() >= generic.size() &&
        message.compare(message.size() - generic.size(), generic.size(), generic) == 0) {
      message.replace(message.size() - generic.size(), generic.size(),
                      " (use --overwrite to replace it)");
    }
    PrintError(message);
    return kExitFailure;
  }
  return kExitOk;
}

// --direct's records of the whole drive, made a simulated second at a time
// when the terminal shows how far it is (the same records as RunAll:
// WorldTest.RunUntilInPiecesEqualsRunAll).
SensorLog RunShowing(sim::SimWorld* world, TerminalProgress* progress) {
  if (!progress->on()) return world->RunAll();
  sim::SensorLogCollector collector;
  for (double t = 1.0; !world->finished(); t += 1.0) {
    world->RunUntil(TimeFromSeconds(sim::SimWorld::kStartTimeS + t), &collector);
    progress->Show("simulating the drive", std::min(1.0, t / world->duration_s()));
  }
  return std::move(*collector.log());
}

// The cloud, written to request.out and measured as it is placed; `result`
// gets everything but the points. Through the bytes the session streams
// (hardware/station/session_stream.h: the same points as DecodeSession +
// Reconstruct, in memory that does not grow with the drive); --direct
// reconstructs the simulator's records whole.
Status PlaceAndWrite(bool direct, const SimulateRequest& request, sim::SimWorld* world,
                     const std::string& session_dir, TerminalProgress* progress,
                     CloudMeasures* measures, ReconstructionResult* result, size_t* scans) {
  const ReconstructionOptions& options = request.options;
  // The truth at 1 kHz only when asked for: 65 bytes a pose, 2.8 GB for
  // 12 hours.
  PoseBuffer truth;
  if (options.pose.source == PoseSource::kTruth) truth = world->TruthPoses(1000.0);
  CloudFileWriter writer;
  Status s = writer.Open(request.out);
  if (!s.ok()) return s;
  const auto sink = [&](const CloudPoint* p, size_t n) {
    measures->Add(p, n);
    return writer.Append(p, n);
  };
  if (direct) {
    const SensorLog log = RunShowing(world, progress);
    progress->Show("reconstructing the cloud", 0.0);  // one step, without a fraction of its own
    s = Reconstruct(log, request.config.geometry, options, &truth, result);
    if (!s.ok()) return s;
    *scans = log.scans.size();
    constexpr size_t kPiece = 65536;
    const size_t total = result->points.size();
    for (size_t i = 0; i < total && s.ok(); i += kPiece) {
      s = sink(result->points.data() + i, std::min(kPiece, total - i));
      progress->Show("writing the points",
                     static_cast<double>(std::min(i + kPiece, total)) / total);
    }
    std::vector<CloudPoint>().swap(result->points);
  } else {
    hardware::SessionCloudStream stream;
    s = stream.EstimatePoses(session_dir, hardware::DefaultSessionFramesOptions(), options, &truth,
                             progress->Stage("estimating the poses"));
    if (s.ok()) s = stream.PlacePoints(sink, progress->Stage("placing the points"));
    if (!s.ok()) return s;
    PoseBuffer poses = stream.TakePoses();  // moved, not copied with the rest
    *result = stream.result();
    result->poses = std::move(poses);
    *scans = stream.scans();
  }
  return s.ok() ? writer.Finish() : s;
}

// The accuracy report: counts, distance to the true surfaces, final pose
// error, the room's size and the target's pass-to-pass disagreement.
nlohmann::json AccuracyReport(const Args& args, const SimulateRequest& request,
                              const sim::SimWorld& world, size_t scans,
                              const std::string& session_dir, const ReconstructionResult& result,
                              const CloudMeasures& measures, sim::SurfaceErrorStats* surface_out) {
  const sim::SimConfig& config = request.config;
  const ReconstructionOptions& options = request.options;
  const std::string& out = request.out;
  nlohmann::json report;
  report["scenario"] = config.name;
  report["session"] = session_dir;
  report["through_bytes"] = !args.Flag("direct");
  report["seed"] = config.seed;
  report["duration_s"] = world.duration_s();
  report["pose_source"] = PoseSourceName(options.pose.source);
  report["deskew"] = options.assembly.deskew;
  report["scans"] = scans;
  report["samples"] = result.stats.samples_in;
  report["points"] = result.stats.points_out;
  report["invalid_samples"] = result.stats.invalid_range;
  report["samples_without_pose"] = result.stats.no_pose;
  report["ekf_updates"] = result.ekf_counters.updates;
  report["ekf_rejected"] = result.ekf_counters.rejected;
  report["out"] = out;
  const sim::SurfaceErrorStats surface = measures.surface().Stats();
  *surface_out = surface;
  report["surface_error"] = StatsJson(surface);
  // Final pose error (position and heading) of the estimate against truth.
  if (!result.poses.empty()) {
    const Rigid3d est = result.poses.pose(result.poses.size() - 1);
    const Rigid3d tru = world.TrueWorldFromBody(result.poses.latest());
    report["final_position_error_m"] = (est.translation() - tru.translation()).head<2>().norm();
    report["final_heading_error_rad"] =
        std::abs(WrapAngle(YawFromQuaternion(est.rotation()) - YawFromQuaternion(tru.rotation())));
  }
  for (const auto& [room, accumulator] : measures.rooms()) {
    const sim::RoomMeasurement m = accumulator.Result();
    if (m.ok) {
      report["room"] = {{"label", room},
                        {"true_m", {m.true_size.x(), m.true_size.y(), m.true_size.z()}},
                        {"measured_m", {m.measured.x(), m.measured.y(), m.measured.z()}},
                        {"relative_error", {m.relative_error.x(), m.relative_error.y(), m.relative_error.z()}}};
    } else {
      report["room"] = {{"label", room}, {"error", m.error}};
    }
  }
  if (measures.target() != nullptr) {
    const sim::PassDisagreement d = measures.target()->Result();
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
  return report;
}

// --truth FILE: the scenario, the true trajectory (50 Hz) and the report.
int WriteTruth(const std::string& path, const sim::SimConfig& config, const sim::SimWorld& world,
               const nlohmann::json& report) {
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
  const Status status = WriteFileAtomically(path, truth_json.dump(1) + "\n");
  if (!status.ok()) {
    PrintError(status.message());
    return kExitFailure;
  }
  return kExitOk;
}

void PrintSimulateReport(const SimulateRequest& request, const sim::SimWorld& world, size_t scans,
                         const std::string& session_dir, const ReconstructionResult& result,
                         const sim::SurfaceErrorStats& surface, const nlohmann::json& report) {
  const sim::SimConfig& config = request.config;
  const ReconstructionOptions& options = request.options;
  const std::string& out = request.out;
  if (!session_dir.empty()) std::printf("recorded session %s (through the device and link bytes)\n", session_dir.c_str());
  std::printf("simulated %.1f s of '%s' (seed %llu): %zu scans, %zu samples -> %zu points in %s\n",
              world.duration_s(), config.name.c_str(), static_cast<unsigned long long>(config.seed),
              scans, result.stats.samples_in, result.stats.points_out, out.c_str());
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
}

}  // namespace

int RunSimulate(int argc, char** argv) {
  Args args({"json", "no-ekf", "no-deskew", "help", "direct", "overwrite"},
            {"scenario", "out", "truth", "pose-source", "seed", "session"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "simulate"));
    return kExitBadInput;
  }
  if (args.Flag("direct")) {
    // --overwrite stays harmless: scripts repeat a command with it.
    const int refused = RefuseOptions(args, {"session"}, "--direct (it records no session)");
    if (refused != kExitOk) return refused;
  }
  SimulateRequest request;
  int code = ParseSimulateArgs(args, &request);
  if (code != kExitOk || request.out.empty()) return code;
  const sim::SimConfig& config = request.config;
  if ((code = RefuseOutputOverInput({{"--out", request.out}, {"--truth", args.Get("truth")}},
                                    {{"the --scenario file", args.Get("scenario")}})) != kExitOk) {
    return code;
  }

  // The cloud's folder is made if missing (the session recorded beside it
  // always made it), and the cloud asked to be writable before the drive is
  // simulated and placed (minutes for a long one).
  std::error_code ignored;  // CheckCanWrite says why it cannot
  std::filesystem::create_directories(std::filesystem::path(request.out).parent_path(), ignored);
  // And the truth file, else a whole drive was simulated before its
  // folder turned out to be a file.
  Status status = CheckCanWrite(request.out);
  if (status.ok() && args.Has("truth")) status = CheckCanWrite(args.Get("truth"));
  if (!status.ok()) {
    PrintError(status.message());
    return kExitFailure;
  }
  sim::SimWorld world(config);
  TerminalProgress progress(TerminalProgress::Wanted(args.Flag("json")), "simulate " + config.name);
  std::string session_dir;
  const bool direct = args.Flag("direct");
  if (!direct) {
    code = RecordSession(args, request, &progress, &session_dir);
    if (code != kExitOk) return code;
  }
  CloudMeasures measures(config.scene);
  ReconstructionResult result;
  size_t scans = 0;
  status =
      PlaceAndWrite(direct, request, &world, session_dir, &progress, &measures, &result, &scans);
  progress.Clear();
  if (!status.ok()) {
    PrintError(status.message());
    return kExitFailure;
  }

  sim::SurfaceErrorStats surface;
  const nlohmann::json report =
      AccuracyReport(args, request, world, scans, session_dir, result, measures, &surface);
  if (args.Has("truth")) {
    code = WriteTruth(args.Get("truth"), config, world, report);
    if (code != kExitOk) return code;
  }
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  PrintSimulateReport(request, world, scans, session_dir, result, surface, report);
  return kExitOk;
}

}  // namespace sweepscan::app
