// `sweepscan-cli p3l`: the minimal problem of lidar-only structure from
// motion (Choi et al. 2017, section 3), and its synthetic protocol
// (section 5.1); `sweepscan-cli sfm`: the sequence pipeline (section 4) on a
// simulated rig. docs/sfm.md describes the formats and the math.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_outputs.h"
#include "app/cli_recording.h"
#include "core/calibration/calibration_file.h"
#include "core/cloud/cloud_io.h"
#include "core/common/checked_file.h"
#include "core/common/json_reader.h"
#include "core/sfm/p3l_json.h"
#include "core/sfm/rig_scenario.h"
#include "core/sfm/sequence.h"
#include "core/sfm/sequence_json.h"
#include "core/sfm/synthetic.h"
#include "core/sfm/wheeled.h"

namespace sweepscan::app {

const char* const kP3lUsage =
    "usage: sweepscan-cli p3l PROBLEM.json\n"
    "       sweepscan-cli p3l --protocol --csv FILE [--trials 1000] [--seed 1]\n"
    "                     [--noise-max 0.1] [--steps 10] [--points 2]\n"
    "\n"
    "The 6-DoF pose of a 2D-lidar rig from three scan lines on three known planes\n"
    "(Choi et al. 2017, section 3). PROBLEM.json:\n"
    "  {\"planes\": [{\"normal\": [nx, ny, nz], \"d\": d}, x3],\n"
    "   \"lines\": [[[x, y, z], [x, y, z]], x3]}\n"
    "world planes n.x + d = 0 (unit n pointing to the plane's back side) and, for\n"
    "plane i, two points of its scan line in the sensor frame. More plane/line pairs\n"
    "rank the candidates; \"previous\": {\"R\": ..., \"t\": ...} ranks by a previous pose.\n"
    "Prints {\"solutions\": [{\"R\": [[...], [...], [...]], \"t\": [tx, ty, tz]}, ...]},\n"
    "every candidate in front of all three planes (n.t + d < 0), best first, with\n"
    "x_world = R x_sensor + t. Degenerate problems exit 2 with one line saying why.\n"
    "\n"
    "--protocol runs the paper's synthetic protocol (section 5.1): --trials random\n"
    "problems per noise level (uniform noise of width 0 .. --noise-max m in --steps\n"
    "steps), writes mean and standard deviation of the rotation and translation\n"
    "errors as CSV to --csv and a table to stdout.\n";

namespace {

int RunProtocol(const Args& args) {
  std::string error;
  // Counts within what runs in minutes (the paper's protocol: 1 000 trials,
  // 10 steps, 2 points a line), noise within a metre: an unbounded count
  // ran for days, and a cast of 1e20 to int crashed.
  int64_t trials = 1000, seed = 1, steps = 10, points = 2;
  double noise_max = 0.1;
  if (!args.GetInteger("trials", 1, 1'000'000, &trials, &error) ||
      !args.GetInteger("seed", 0, 1'000'000'000, &seed, &error) ||
      !args.GetDouble("noise-max", &noise_max, &error) ||
      !args.GetInteger("steps", 1, 1000, &steps, &error) ||
      !args.GetInteger("points", 2, 10'000, &points, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (!args.Has("csv")) {
    PrintError("p3l --protocol needs --csv FILE");
    return kExitBadInput;
  }
  if (noise_max < 0 || noise_max > 1.0) {
    PrintError("p3l --protocol: --noise-max is a width in metres, from 0 to 1");
    return kExitBadInput;
  }
  std::ostringstream csv;
  csv << "noise_width_m,trials,solved,truth_found_1e-6,mean_candidates,rot_mean_deg,rot_std_deg,"
         "trans_mean_m,trans_std_m,ranked_rot_mean_deg,ranked_rot_std_deg,ranked_trans_mean_m,"
         "ranked_trans_std_m,rot_median_deg,trans_median_m\n";
  std::printf("%9s %6s %6s | nearest candidate: %8s %8s %8s %8s | ranked by a 4th line: %8s %8s\n",
              "noise_m", "solved", "truth", "rot_deg", "+-", "trans_m", "+-", "rot_deg", "trans_m");
  for (int k = 0; k <= static_cast<int>(steps); ++k) {
    sfm::SyntheticOptions o;
    o.noise_width_m = noise_max * k / static_cast<double>(steps);
    o.points_per_line = static_cast<int>(points);
    const sfm::ProtocolRow r =
        sfm::RunProtocol(o, static_cast<int>(trials), static_cast<uint64_t>(seed) * 1000 + k);
    char line[512];
    std::snprintf(line, sizeof(line), "%.6g,%d,%d,%d,%.4f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n",
                  r.noise_width_m, r.trials, r.solved, r.truth_found_1e6, r.mean_candidates, r.rot_mean_deg,
                  r.rot_std_deg, r.trans_mean_m, r.trans_std_m, r.ranked_rot_mean_deg, r.ranked_rot_std_deg,
                  r.ranked_trans_mean_m, r.ranked_trans_std_m, r.rot_median_deg, r.trans_median_m);
    csv << line;
    std::printf("%9.4f %6d %6d |                    %8.4f %8.4f %8.4f %8.4f |                      %8.4f %8.4f\n",
                r.noise_width_m, r.solved, r.truth_found_1e6, r.rot_mean_deg, r.rot_std_deg, r.trans_mean_m,
                r.trans_std_m, r.ranked_rot_mean_deg, r.ranked_trans_mean_m);
  }
  const Status s = WriteFileAtomically(args.Get("csv"), csv.str());
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace

int RunP3l(int argc, char** argv) {
  // --json is taken as every command takes it: p3l prints JSON anyway.
  Args args({"protocol", "help", "json"},
            {"csv", "trials", "seed", "noise-max", "steps", "points"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "p3l"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kP3lUsage;
    return kExitOk;
  }
  if (args.Flag("protocol")) return RunProtocol(args);
  if (args.positional().size() != 1) {
    PrintError(SeeHelp("p3l needs one PROBLEM.json", "p3l"));
    return kExitBadInput;
  }
  const std::string path = args.positional()[0];
  nlohmann::json doc;
  Status s = ReadJsonFile(path, &doc);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  sfm::P3lProblem problem;
  s = sfm::ParseP3lProblem(doc, &problem);
  if (!s.ok()) {
    PrintError(path + ": " + s.message());
    return kExitBadInput;
  }
  std::vector<sfm::PoseCandidate> candidates;
  s = sfm::SolveP3l(problem.planes, problem.lines, {}, problem.disambiguation, &candidates);
  if (!s.ok()) {
    PrintError(path + ": " + s.message());
    return kExitBadInput;
  }
  std::cout << sfm::P3lSolutionsToJson(candidates).dump() << "\n";
  return kExitOk;
}

const char* const kSfmUsage =
    "usage: sweepscan-cli sfm SESSION|--scenario FILE [--seed N] --out CLOUD.ply|CLOUD.pcd\n"
    "                     [--motion-prior ekf|odometry|none|truth] [--init INIT.json]\n"
    "                     [--calibration FILE] [--poses POSES.csv] [--planes PLANES.json]\n"
    "                     [--no-refine] [--strict] [--json]\n"
    "       sweepscan-cli sfm --rig-scenario room|stairwell [--frames N] [--seed 1]\n"
    "                     [--init INIT.json] [--write-init INIT.json] [--out CLOUD.ply]\n"
    "                     [--poses POSES.csv] [--planes PLANES.json] [--no-refine] [--json]\n"
    "\n"
    "The wheeled scanner (SESSION, or --scenario FILE simulated in-process, with\n"
    "its ground truth): every X4 scan, deskewed, is placed by the planes its lines\n"
    "lie on (floor, ceiling, walls, found on the way), with the wheel + IMU EKF\n"
    "(--motion-prior ekf, the default) or the wheels alone (odometry) as the motion\n"
    "prior for what the planes do not fix: a vertical scan sees two normal\n"
    "directions, so the position along the walls comes from the prior.\n"
    "--motion-prior truth (--scenario only): the simulation's true poses as the prior.\n"
    "--motion-prior none: the paper's lidar-only tracking (constant velocity), which\n"
    "needs --init (three known planes; with --scenario, by default the truth's: the\n"
    "three distinct planes most samples of the first scan lie on).\n"
    "--init INIT.json: three known planes (world frame) with lines of the first scan\n"
    "(lidar 0; \"near\": [r cos theta, r sin theta] of a sample). Writes the cloud\n"
    "placed by the corrected poses (deskewed per sample), --poses a CSV (scan, time,\n"
    "pose, the prior's pose, the truth's with --scenario), --planes the planes, and\n"
    "prints the planes found and the poses against the prior (and the truth).\n"
    "Calibration: meta.json's for a session, none for --scenario, or --calibration.\n"
    "\n"
    "--rig-scenario: lidar-only structure from motion (Choi et al. 2017, section 4)\n"
    "on a simulated hand-held rig of two 2D lidars (core/sim/rig.h): the room walk\n"
    "(650 frames, 1300 scans) or the stairwell walk (1750 frames, 3500 scans). Initialisation\n"
    "from three planes and their lines in the first frame: --init INIT.json, or\n"
    "by default the truth's (the faces the first frame's lines hit; --write-init\n"
    "saves it). Writes the refined cloud (PLY), the poses (CSV: frame, time, x, y,\n"
    "z, qw, qx, qy, qz and the errors against the truth), the planes (JSON) and\n"
    "prints the errors, planes found and times.\n";

namespace {

Status WritePosesCsv(const std::string& path, const sfm::SequenceResult& r, const sim::RigRun& run) {
  std::ostringstream csv;
  csv << "frame,time_s,x,y,z,qw,qx,qy,qz,rot_err_deg,trans_err_m\n";
  const Rigid3d align = r.gauge_first_pose ? run.world_from_rig[0] * r.poses[0].inverse() : Rigid3d::Identity();
  for (size_t k = 0; k < r.poses.size(); ++k) {
    const Rigid3d& p = r.poses[k];
    const Rigid3d est = align * p;
    const Rigid3d& truth = run.world_from_rig[k];
    const double rot = sfm::RotationAngle(est.rotation().toRotationMatrix(), truth.rotation().toRotationMatrix()) *
                       180.0 / M_PI;
    char line[256];
    std::snprintf(line, sizeof(line), "%zu,%.6f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%.5f,%.6f\n", k,
                  r.frame_times_s[k], p.translation().x(), p.translation().y(), p.translation().z(), p.rotation().w(),
                  p.rotation().x(), p.rotation().y(), p.rotation().z(), rot,
                  (est.translation() - truth.translation()).norm());
    csv << line;
  }
  return WriteFileAtomically(path, csv.str());
}

nlohmann::json PlanesJson(const std::vector<sfm::FoundPlane>& found) {
  nlohmann::json planes = nlohmann::json::array();
  for (const sfm::FoundPlane& fp : found) {
    planes.push_back({{"normal", {fp.plane.normal.x(), fp.plane.normal.y(), fp.plane.normal.z()}},
                      {"d", fp.plane.d},
                      {"initial", fp.initial},
                      {"first_frame", fp.first_frame},
                      {"lines", fp.observations},
                      {"frames", fp.frames}});
  }
  return planes;
}

nlohmann::json WheeledErrorsJson(const sfm::WheeledErrors& e) {
  return {{"frames", e.frames},
          {"along_mean_m", e.along_mean_m},
          {"along_max_m", e.along_max_m},
          {"along_final_m", e.along_final_m},
          {"lateral_mean_m", e.lateral_mean_m},
          {"lateral_max_m", e.lateral_max_m},
          {"lateral_final_m", e.lateral_final_m},
          {"height_mean_m", e.height_mean_m},
          {"height_max_m", e.height_max_m},
          {"heading_mean_deg", e.heading_mean_deg},
          {"heading_max_deg", e.heading_max_deg},
          {"heading_final_deg", e.heading_final_deg},
          {"tilt_mean_deg", e.tilt_mean_deg},
          {"tilt_max_deg", e.tilt_max_deg},
          {"trans_mean_m", e.trans_mean_m},
          {"trans_max_m", e.trans_max_m}};
}

void PrintWheeledErrors(const char* name, const sfm::WheeledErrors& e) {
  std::printf("%-16s along %.3f / %.3f m, lateral %.4f / %.4f m, height %.4f / %.4f m, heading %.3f / %.3f deg, "
              "tilt %.3f / %.3f deg (mean / max); final: along %.3f m, lateral %.4f m, heading %.3f deg\n",
              name, e.along_mean_m, e.along_max_m, e.lateral_mean_m, e.lateral_max_m, e.height_mean_m,
              e.height_max_m, e.heading_mean_deg, e.heading_max_deg, e.tilt_mean_deg, e.tilt_max_deg,
              e.along_final_m, e.lateral_final_m, e.heading_final_deg);
}

double YawDeg(const Rigid3d& p) {
  const Eigen::Matrix3d R = p.rotation().toRotationMatrix();
  return std::atan2(R(1, 0), R(0, 0)) * 180.0 / M_PI;
}

Status WriteWheeledPosesCsv(const std::string& path, const sfm::WheeledSfmResult& r, const PoseBuffer* truth) {
  std::ostringstream csv;
  csv << "scan,time_s,x,y,z,qw,qx,qy,qz,yaw_deg,prior_x,prior_y,prior_z,prior_yaw_deg";
  if (truth != nullptr) csv << ",truth_x,truth_y,truth_z,truth_yaw_deg";
  csv << "\n";
  const sfm::SequenceResult& seq = r.sequence;
  for (size_t k = 0; k < seq.poses.size(); ++k) {
    const Rigid3d& p = seq.poses[k];
    const Rigid3d& q = r.prior[k];
    char line[512];
    std::snprintf(line, sizeof(line), "%u,%.6f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%.5f,%.6f,%.6f,%.6f,%.5f",
                  r.scans[k], seq.frame_times_s[k], p.translation().x(), p.translation().y(), p.translation().z(),
                  p.rotation().w(), p.rotation().x(), p.rotation().y(), p.rotation().z(), YawDeg(p),
                  q.translation().x(), q.translation().y(), q.translation().z(), YawDeg(q));
    csv << line;
    Rigid3d t;
    if (truth != nullptr) {
      if (truth->Lookup(TimeFromSeconds(seq.frame_times_s[k]), &t)) {
        std::snprintf(line, sizeof(line), ",%.6f,%.6f,%.6f,%.5f", t.translation().x(), t.translation().y(),
                      t.translation().z(), YawDeg(t));
        csv << line;
      } else {
        csv << ",,,,";
      }
    }
    csv << "\n";
  }
  return WriteFileAtomically(path, csv.str());
}

// `sfm SESSION` / `sfm --scenario FILE`: the wheeled scanner (wheeled.h).
int RunSfmWheeled(const Args& args) {
  const int refused = RefuseOptions(args, {"frames", "write-init"},
                                    "the wheeled scanner (it is for --rig-scenario)");
  if (refused != kExitOk) return refused;
  if (!args.Has("out")) {
    PrintError(SeeHelp("sfm needs --out CLOUD.ply", "sfm"));
    return kExitBadInput;
  }
  if (!IsCloudFile(args.Get("out"))) {
    PrintError("--out " + args.Get("out") + ": not a cloud file (.las, .ply or .pcd)");
    return kExitBadInput;
  }
  const std::string prior_name = args.Get("motion-prior", "ekf");
  if (prior_name != "ekf" && prior_name != "odometry" && prior_name != "none" && prior_name != "truth") {
    PrintError("--motion-prior must be ekf, odometry, none or truth, got '" + prior_name + "'");
    return kExitBadInput;
  }
  sfm::SequenceInit init;
  Status s;
  if (args.Has("init")) {
    nlohmann::json doc;
    s = ReadJsonFile(args.Get("init"), &doc);
    if (s.ok()) s = sfm::ParseSequenceInit(doc, &init);
    if (s.ok() && !init.planes[0].known) {
      s = Status::Error("the wheeled scanner's initialisation needs the three planes given (normal, d): one "
                        "vertical scan has one line per plane");
    }
    if (!s.ok()) {
      PrintError(args.Get("init") + ": " + s.message());
      return kExitBadInput;
    }
  }
  MountingError calibration;
  if (args.Has("calibration")) {
    s = LoadCalibrationFile(args.Get("calibration"), &calibration);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  RecordingInput in;
  const int code = LoadRecording(args, &in);
  if (code != kExitOk) return code;
  if (!args.Has("calibration") && !in.session_dir.empty()) calibration = in.decode.meta.calibration;
  if (prior_name == "truth" && !in.has_truth) {
    PrintError("--motion-prior truth needs a simulated input (--scenario)");
    return kExitBadInput;
  }
  const Rigid3d body_from_lidar = BodyFromLidar(in.geometry, calibration);
  sfm::WheeledSfmOptions options;
  if (args.Flag("no-refine")) options.sequence.refine_passes = 0;
  if (prior_name == "none") {
    // The paper's tracking: constant velocity, no prior terms; the prior
    // (the EKF) only gives the first pose.
    options.motion.predict = false;
    options.motion.constrain = false;
    if (!args.Has("init")) {
      std::vector<std::string> chosen;
      s = in.has_truth ? sfm::WheeledInitFromTruth(in.log.scans, in.truth_poses, body_from_lidar, in.scenario.scene,
                                                   options.min_scan_samples, &init, &chosen)
                       : Status::Error("--motion-prior none needs --init INIT.json (three known planes) for a session");
      if (!s.ok()) {
        PrintError(s.message());
        return kExitBadInput;
      }
    }
  }
  const PoseSource prior_source = prior_name == "odometry" ? PoseSource::kOdometry : PoseSource::kEkf;
  const sfm::MotionPrior weights = sfm::WheeledMotionPrior(prior_source);
  options.motion.abs_tilt_sigma_rad = weights.abs_tilt_sigma_rad;
  options.motion.abs_yaw_sigma_rad = weights.abs_yaw_sigma_rad;
  sfm::WheeledSfmResult result;
  // truth: what the planes do with a perfect prior (a check of the pipeline).
  s = prior_name == "truth"
          ? sfm::RunWheeledSfm(in.log.scans, body_from_lidar, in.truth_poses, init, options, &result)
          : sfm::WheeledSfmFromLog(in.log, in.geometry, calibration, in.start, prior_source, init, options, &result);
  if (!s.ok()) {
    PrintError(in.name + ": " + s.message());
    return args.Has("init") && s.message().rfind("init:", 0) == 0 ? kExitBadInput : kExitFailure;
  }
  const sfm::SequenceResult& seq = result.sequence;
  // The cloud: every sample deskewed with the corrected poses.
  ReconstructionOptions ro;
  ro.pose.source = PoseSource::kSfm;
  ro.pose.initial_pose = in.start;
  ro.calibration = calibration;
  if (in.has_truth) {
    ro.assembly.min_range_m = in.scenario.lidar.min_range_m;
    ro.assembly.max_range_m = in.scenario.lidar.max_range_m;
  }
  ReconstructionResult cloud;
  s = Reconstruct(in.log, in.geometry, ro, &result.poses, &cloud);
  if (s.ok()) s = SaveCloud(args.Get("out"), cloud.points);
  if (s.ok() && args.Has("poses")) {
    s = WriteWheeledPosesCsv(args.Get("poses"), result, in.has_truth ? &in.truth_poses : nullptr);
  }
  const nlohmann::json planes = PlanesJson(seq.planes);
  if (s.ok() && args.Has("planes")) {
    s = WriteFileAtomically(args.Get("planes"), nlohmann::json({{"planes", planes}}).dump(2) + "\n");
  }
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  // The prior as a buffer, to compare the SfM poses with.
  PoseBuffer prior_buffer;
  for (size_t k = 0; k < result.prior.size(); ++k) {
    prior_buffer.Add(TimeFromSeconds(seq.frame_times_s[k]), result.prior[k]);
  }
  const sfm::WheeledErrors vs_prior = sfm::EvaluateWheeled(seq.frame_times_s, seq.poses, prior_buffer);
  sfm::WheeledErrors prior_vs_truth, tracked_vs_truth, sfm_vs_truth;
  if (in.has_truth) {
    prior_vs_truth = sfm::EvaluateWheeled(seq.frame_times_s, result.prior, in.truth_poses);
    tracked_vs_truth = sfm::EvaluateWheeled(seq.frame_times_s, seq.tracked, in.truth_poses);
    sfm_vs_truth = sfm::EvaluateWheeled(seq.frame_times_s, seq.poses, in.truth_poses);
  }
  const char* prior_label = prior_name == "none" ? "ekf" : prior_name.c_str();
  if (args.Flag("json")) {
    nlohmann::json out = {{"input", in.name},
                          {"out", args.Get("out")},
                          {"motion_prior", prior_name},
                          {"scans", seq.poses.size()},
                          {"lines", seq.lines_total},
                          {"lines_assigned", seq.lines_assigned},
                          {"planes", planes},
                          {"weak_frames", seq.frames_weak},
                          {"points", cloud.stats.points_out},
                          {"tracking_s", seq.tracking_seconds},
                          {"refinement_s", seq.refine.seconds},
                          {"sfm_vs_prior", WheeledErrorsJson(vs_prior)}};
    if (in.has_truth) {
      out["prior_vs_truth"] = WheeledErrorsJson(prior_vs_truth);
      out["tracked_vs_truth"] = WheeledErrorsJson(tracked_vs_truth);
      out["sfm_vs_truth"] = WheeledErrorsJson(sfm_vs_truth);
    }
    std::cout << out.dump() << "\n";
    return kExitOk;
  }
  std::printf("%s: %zu scans, %d lines (%d on planes), %zu planes; %zu points in %s (motion prior %s)\n",
              in.name.c_str(), seq.poses.size(), seq.lines_total, seq.lines_assigned, seq.planes.size(),
              cloud.stats.points_out, args.Get("out").c_str(), prior_name.c_str());
  std::printf("time: tracking %.2f s, refinement %.2f s (%d passes, %d iterations, cost %.4g -> %.4g)\n",
              seq.tracking_seconds, seq.refine.seconds, seq.refine.passes, seq.refine.iterations,
              seq.refine.initial_cost, seq.refine.final_cost);
  if (prior_name != "truth") PrintWheeledErrors((std::string("sfm vs ") + prior_label + ":").c_str(), vs_prior);
  if (in.has_truth) {
    if (prior_name != "truth") PrintWheeledErrors((std::string(prior_label) + " vs truth:").c_str(), prior_vs_truth);
    PrintWheeledErrors("tracked vs truth:", tracked_vs_truth);
    PrintWheeledErrors("sfm vs truth:", sfm_vs_truth);
  }
  return kExitOk;
}

}  // namespace

int RunSfm(int argc, char** argv) {
  Args args({"help", "json", "no-refine", "strict"},
            {"rig-scenario", "frames", "seed", "init", "write-init", "out", "poses", "planes", "scenario",
             "motion-prior", "calibration"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "sfm"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kSfmUsage;
    return kExitOk;
  }
  // Every output over no input nor another, and writable, before the
  // minutes of work (a --poses that could not be written was said after
  // the cloud was written).
  std::vector<CommandInput> inputs = {{"the --scenario file", args.Get("scenario")},
                                      {"the --calibration file", args.Get("calibration")},
                                      {"the --init file", args.Get("init")}};
  for (const std::string& session : args.positional()) {
    inputs.push_back(
        {"the session folder " + session + ", which holds the recording", session, true});
  }
  const std::vector<CommandOutput> outputs = {{"--out", args.Get("out")},
                                              {"--poses", args.Get("poses")},
                                              {"--planes", args.Get("planes")},
                                              {"--write-init", args.Get("write-init")}};
  if (const int refused = RefuseOutputOverInput(outputs, inputs); refused != kExitOk)
    return refused;
  for (const CommandOutput& out : outputs) {
    if (out.path.empty()) continue;
    if (const Status w = CheckCanWrite(out.path); !w.ok()) {
      PrintError(w.message());
      return kExitFailure;
    }
  }
  if (!args.positional().empty() || args.Has("scenario")) {
    if (args.Has("rig-scenario")) {
      PrintError("sfm: give SESSION, --scenario FILE or --rig-scenario NAME, one of them");
      return kExitBadInput;
    }
    return RunSfmWheeled(args);
  }
  if (!args.Has("rig-scenario")) {
    PrintError(
        SeeHelp("sfm needs SESSION, --scenario FILE or --rig-scenario (room, stairwell)", "sfm"));
    return kExitBadInput;
  }
  const int refused =
      RefuseOptions(args, {"motion-prior", "calibration", "strict"},
                    "--rig-scenario (it is for the wheeled scanner: SESSION or --scenario)");
  if (refused != kExitOk) return refused;
  sim::RigSimConfig config;
  Status s = sfm::RigScenarioByName(args.Get("rig-scenario"), &config);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  int64_t frames = config.frames, seed = 1;
  if (!args.GetInteger("frames", 2, 1'000'000, &frames, &error) ||
      !args.GetInteger("seed", 0, 1'000'000'000, &seed, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (args.Get("rig-scenario") == "room") {
    config = sim::SmallRoomRigScenario(static_cast<int>(frames), static_cast<uint64_t>(seed));
  } else {
    config = sim::StairwellRigScenario(static_cast<int>(frames), static_cast<uint64_t>(seed));
  }
  const sim::RigRun run = sim::SimulateRig(config);
  sfm::SequenceOptions options;
  if (args.Flag("no-refine")) options.refine_passes = 0;
  sfm::SequenceInit init;
  std::vector<std::string> chosen;
  if (args.Has("init")) {
    nlohmann::json doc;
    s = ReadJsonFile(args.Get("init"), &doc);
    if (s.ok()) s = sfm::ParseSequenceInit(doc, &init);
    if (!s.ok()) {
      PrintError(args.Get("init") + ": " + s.message());
      return kExitBadInput;
    }
  } else {
    s = sfm::InitFromTruth(run, config.scene, true, options.lines, &init, &chosen);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  if (args.Has("write-init")) {
    s = WriteFileAtomically(args.Get("write-init"), sfm::SequenceInitToJson(init).dump(2) + "\n");
    if (!s.ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  sfm::SequenceResult result;
  const std::vector<sfm::Scan> scans = sfm::ScansFromRigRun(run);
  const sfm::Rig rig = sfm::RigFromRigRun(run);
  s = sfm::RunSequence(scans, rig, init, options, &result);
  if (!s.ok()) {
    PrintError(s.message());
    return args.Has("init") ? kExitBadInput : kExitFailure;
  }
  const sfm::SequenceErrors tracked =
      sfm::EvaluateSequence(result.tracked, result.planes, result.gauge_first_pose, run, config.scene);
  const sfm::SequenceErrors refined =
      sfm::EvaluateSequence(result.poses, result.planes, result.gauge_first_pose, run, config.scene);
  if (args.Has("out")) {
    std::vector<CloudPoint> cloud;
    for (size_t f = 0; f < result.frame_scans.size(); ++f) {
      for (int si : result.frame_scans[f]) {
        const sfm::Scan& scan = scans[si];
        const Rigid3d T = result.poses[f] * rig.rig_from_lidar[scan.lidar];
        for (size_t b = 0; b < scan.points.size(); ++b) {
          const Eigen::Vector2d& p2 = scan.points[b];
          if (!p2.allFinite()) continue;
          const Eigen::Vector3d p = T * Eigen::Vector3d(p2.x(), p2.y(), 0.0);
          CloudPoint c;
          c.x = static_cast<float>(p.x());
          c.y = static_cast<float>(p.y());
          c.z = static_cast<float>(p.z());
          c.range_m = static_cast<float>(p2.norm());
          c.time_ns = static_cast<int64_t>(std::llround(scan.time_s * 1e9));
          c.scan = static_cast<uint32_t>(si);
          c.beam = static_cast<uint16_t>(b);
          c.pose_source = static_cast<uint8_t>(PoseSource::kSfm);  // placed by the SfM
          cloud.push_back(c);
        }
      }
    }
    s = SaveCloud(args.Get("out"), cloud);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  if (args.Has("poses")) {
    s = WritePosesCsv(args.Get("poses"), result, run);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  const nlohmann::json planes = PlanesJson(result.planes);
  if (args.Has("planes")) {
    s = WriteFileAtomically(args.Get("planes"), nlohmann::json({{"planes", planes}}).dump(2) + "\n");
    if (!s.ok()) {
      PrintError(s.message());
      return kExitFailure;
    }
  }
  auto errors = [](const sfm::SequenceErrors& e) {
    return nlohmann::json{{"rot_mean_deg", e.rot_mean_deg},
                          {"rot_max_deg", e.rot_max_deg},
                          {"trans_mean_m", e.trans_mean_m},
                          {"trans_max_m", e.trans_max_m}};
  };
  if (args.Flag("json")) {
    nlohmann::json out = {{"scenario", config.name},
                          {"frames", result.poses.size()},
                          {"scans", scans.size()},
                          {"lines", result.lines_total},
                          {"lines_assigned", result.lines_assigned},
                          {"planes", planes},
                          {"planes_true", refined.planes_matched},
                          {"true_planes_found", refined.truth_planes_found},
                          {"tracked", errors(tracked)},
                          {"refined", errors(refined)},
                          {"tracking_s", result.tracking_seconds},
                          {"refinement_s", result.refine.seconds},
                          {"weak_frames", result.frames_weak},
                          {"p3l_frames", result.frames_p3l}};
    std::cout << out.dump() << "\n";
    return kExitOk;
  }
  std::printf("%s: %zu frames, %zu scans, %d lines (%d on planes)\n", config.name.c_str(), result.poses.size(),
              scans.size(), result.lines_total, result.lines_assigned);
  std::printf("planes: %zu found, %d match a true face (%d distinct):", result.planes.size(), refined.planes_matched,
              refined.truth_planes_found);
  for (const std::string& l : refined.matched_labels) std::printf(" %s", l.c_str());
  std::printf("\n");
  std::printf("tracked: rotation %.3f deg mean, %.3f max; translation %.4f m mean, %.4f max\n", tracked.rot_mean_deg,
              tracked.rot_max_deg, tracked.trans_mean_m, tracked.trans_max_m);
  std::printf("refined: rotation %.3f deg mean, %.3f max; translation %.4f m mean, %.4f max\n", refined.rot_mean_deg,
              refined.rot_max_deg, refined.trans_mean_m, refined.trans_max_m);
  std::printf("time: tracking %.2f s, refinement %.2f s (%d passes, %d iterations); weak frames %d, p3l frames %d\n",
              result.tracking_seconds, result.refine.seconds, result.refine.passes, result.refine.iterations,
              result.frames_weak, result.frames_p3l);
  return kExitOk;
}

}  // namespace sweepscan::app
