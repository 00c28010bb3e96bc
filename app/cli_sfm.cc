// `sweepscan-cli p3l`: the minimal problem of lidar-only structure from
// motion (Choi et al. 2017, section 3), and its synthetic protocol
// (section 5.1); `sweepscan-cli sfm`: the sequence pipeline (section 4) on a
// simulated rig. docs/sfm.md describes the formats and the math.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "core/common/json_reader.h"
#include "core/cloud/cloud_io.h"
#include "core/sfm/p3l_json.h"
#include "core/sfm/rig_scenario.h"
#include "core/sfm/sequence.h"
#include "core/sfm/sequence_json.h"
#include "core/sfm/synthetic.h"

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
  double trials = 1000, seed = 1, noise_max = 0.1, steps = 10, points = 2;
  if (!args.GetDouble("trials", &trials, &error) || !args.GetDouble("seed", &seed, &error) ||
      !args.GetDouble("noise-max", &noise_max, &error) || !args.GetDouble("steps", &steps, &error) ||
      !args.GetDouble("points", &points, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (!args.Has("csv")) {
    PrintError("p3l --protocol needs --csv FILE");
    return kExitBadInput;
  }
  if (trials < 1 || steps < 1 || noise_max < 0 || points < 2 || seed < 0) {
    PrintError("p3l --protocol: --trials, --steps >= 1, --points >= 2, --noise-max and --seed >= 0");
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
    o.noise_width_m = noise_max * k / steps;
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
  Args args({"protocol", "help"}, {"csv", "trials", "seed", "noise-max", "steps", "points"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kP3lUsage;
    return kExitOk;
  }
  if (args.Flag("protocol")) return RunProtocol(args);
  if (args.positional().size() != 1) {
    PrintError("p3l needs one PROBLEM.json\n" + std::string(kP3lUsage));
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
    "usage: sweepscan-cli sfm --rig-scenario room|stairwell [--frames N] [--seed 1]\n"
    "                     [--init INIT.json] [--write-init INIT.json] [--out CLOUD.ply]\n"
    "                     [--poses POSES.csv] [--planes PLANES.json] [--no-refine] [--json]\n"
    "\n"
    "Lidar-only structure from motion (Choi et al. 2017, section 4) on a simulated\n"
    "hand-held rig of two 2D lidars (core/sim/rig.h): the room walk (650 frames,\n"
    "1300 scans) or the stairwell walk (1750 frames, 3500 scans). Initialisation\n"
    "from three planes and their lines in the first frame: --init INIT.json, or\n"
    "by default the truth's (the faces the first frame's lines hit; --write-init\n"
    "saves it). Writes the refined cloud (PLY), the poses (CSV: frame, time, x, y,\n"
    "z, qw, qx, qy, qz and the errors against the truth), the planes (JSON) and\n"
    "prints the errors, planes found and times. SESSION input: not yet.\n";

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

}  // namespace

int RunSfm(int argc, char** argv) {
  Args args({"help", "json", "no-refine"},
            {"rig-scenario", "frames", "seed", "init", "write-init", "out", "poses", "planes"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kSfmUsage;
    return kExitOk;
  }
  if (!args.positional().empty() || !args.Has("rig-scenario")) {
    PrintError(args.positional().empty()
                   ? "sfm needs --rig-scenario (room, stairwell)\n" + std::string(kSfmUsage)
                   : "sfm: session input is not supported yet; use --rig-scenario\n" + std::string(kSfmUsage));
    return kExitBadInput;
  }
  sim::RigSimConfig config;
  Status s = sfm::RigScenarioByName(args.Get("rig-scenario"), &config);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  double frames = config.frames, seed = 1;
  if (!args.GetDouble("frames", &frames, &error) || !args.GetDouble("seed", &seed, &error)) {
    PrintError(error);
    return kExitBadInput;
  }
  if (frames < 2 || frames > 1e6 || seed < 0) {
    PrintError("sfm: --frames within [2, 1e6], --seed >= 0");
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
  nlohmann::json planes = nlohmann::json::array();
  for (const sfm::FoundPlane& fp : result.planes) {
    planes.push_back({{"normal", {fp.plane.normal.x(), fp.plane.normal.y(), fp.plane.normal.z()}},
                      {"d", fp.plane.d},
                      {"initial", fp.initial},
                      {"first_frame", fp.first_frame},
                      {"lines", fp.observations},
                      {"frames", fp.frames}});
  }
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
