// sweepscan-cli evaluate: planes, deviation histograms, room dimensions and
// density of a cloud, or of a recording before and after a calibration.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_recording.h"
#include "app/terminal_progress.h"
#include "core/calibration/calibration_file.h"
#include "core/cloud/cloud_io.h"
#include "core/common/file_suffix.h"
#include "core/evaluation/cloud_arrays.h"
#include "core/evaluation/evaluation.h"
#include "core/evaluation/report.h"

namespace sweepscan::app {

const char* const kEvaluateUsage =
    "usage: sweepscan-cli evaluate CLOUD.ply|CLOUD.pcd|SESSION|--scenario FILE\n"
    "                              [--calibration CALIB.json] [--pose-source S] [--json]\n"
    "                              [--seed N] [--threads N] [--timing]\n"
    "\n"
    "Evaluates a cloud (Miao et al. 2022, section 5): statistical outlier removal,\n"
    "RANSAC planes (floor, ceiling, walls) with normal and RMS, signed deviation\n"
    "histograms (Fig. 9), room dimensions from parallel planes (Table 3) and the\n"
    "mean nearest-neighbour distance (Eq. 18-19). With a SESSION or --scenario\n"
    "and --calibration, the cloud is rebuilt from the raw samples twice, without\n"
    "and with the calibration, and both are reported (before / after).\n"
    "\n"
    "  --seed N      the --scenario's noise seed (default: the scenario's own)\n"
    "  --threads N   worker threads (default: every core; the result does not depend on it)\n"
    "  --timing      print the wall time of each stage on stderr\n"
    "  --strict      refuse a SESSION with damaged records (default: skip them, with a warning)\n"
    "  --neighbours batched|kdtree|grid|flann   the shared neighbour structure (for measurements;\n"
    "                the same result with each): batched Morton kd-tree (default), nanoflann,\n"
    "                voxel hash grid, PCL KdTreeFLANN\n"
    "On a terminal (and without --json) the progress is shown on stderr.\n"
    "Memory: a SESSION is read record by record and only the cloud's positions are kept\n"
    "(12 B a point); the evaluation adds about 32 B a point while it measures (about 7.7 GB\n"
    "for the 180 M points of a 10-hour drive). A cloud file is read whole.\n";

namespace {

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

// Reads a cloud file's positions straight into the evaluation's array; PCL
// reads what the direct reader does not (ASCII, compressed) and reports the
// errors.
Status LoadPositions(const std::string& path, std::vector<Eigen::Vector3f>* pts) {
  // The header must fit the file before anything is allocated (a forged
  // vertex count must not exhaust memory; trailing junk is refused).
  const Status valid = ValidateCloudFile(path);
  if (!valid.ok()) return valid;
  std::string error;
  if (ReadCloudPositions(path, pts, &error) == CloudReadResult::kOk) return Status::Ok();
  return LoadCloudPositions(path, pts);
}

// The evaluation's stages on a terminal: "evaluate cloud: neighbours  42 %".
EvaluationControl ShowOn(TerminalProgress* progress) {
  EvaluationControl c;
  if (progress->on()) {
    c.progress = [progress](const EvaluationProgress& p) {
      progress->Show(EvaluationStageName(p.stage), p.fraction);
      return true;
    };
  }
  return c;
}

void PrintTiming(const std::string& title, const CloudEvaluation& e) {
  const EvaluationTiming& t = e.timing;
  std::fprintf(stderr,
               "timing %s: %zu points, %d threads: neighbours %.3f s, outliers %.3f s, density %.3f s, "
               "planes %.3f s, total %.3f s\n",
               title.c_str(), e.points_in, t.threads, t.neighbours_s, t.outliers_s, t.density_s,
               t.planes_s, t.total_s);
}

}  // namespace

int RunEvaluate(int argc, char** argv) {
  Args args({"json", "help", "timing", "strict"}, {"scenario", "calibration", "pose-source", "seed", "threads", "neighbours"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "evaluate"));
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
    return p.size() > 4 && (HasFileSuffix(p, ".ply") || HasFileSuffix(p, ".pcd"));
  };
  EvaluationOptions options;
  if (args.Has("threads")) {
    char* end = nullptr;
    const long threads = std::strtol(args.Get("threads").c_str(), &end, 10);
    if (args.Get("threads").empty() || end == nullptr || *end != '\0' || threads < 0 ||
        threads > 1024) {
      PrintError("--threads needs a whole number within 0-1024 (0: every core), got '" +
                 args.Get("threads") + "'");
      return kExitBadInput;
    }
    options.threads = static_cast<int>(threads);
  }
  if (args.Has("neighbours")) {
    const std::string b = args.Get("neighbours");
    if (b == "batched") {
      options.neighbours = NeighbourBackend::kBatched;
    } else if (b == "kdtree") {
      options.neighbours = NeighbourBackend::kKdTree;
    } else if (b == "grid") {
      options.neighbours = NeighbourBackend::kVoxelGrid;
    } else if (b == "flann") {
      options.neighbours = NeighbourBackend::kPclKdTree;
    } else {
      PrintError(
          "--neighbours is batched (the default), kdtree (nanoflann), grid (voxel hash grid) or "
          "flann (PCL)");
      return kExitBadInput;
    }
  }
  const bool show_progress = TerminalProgress::Wanted(args.Flag("json"));
  const auto evaluate = [&](const std::string& title, const std::vector<Eigen::Vector3f>& pts,
                            CloudEvaluation* e) {
    TerminalProgress progress(show_progress, "evaluate " + title);
    const Status s = EvaluateCloud(pts, options, e, ShowOn(&progress));
    progress.Clear();
    if (s.ok() && args.Flag("timing")) PrintTiming(title, *e);
    return s;
  };
  std::vector<std::pair<std::string, CloudEvaluation>> results;
  if (!args.Has("scenario") && args.positional().size() == 1 && is_cloud(args.positional()[0])) {
    if (args.Has("calibration")) {
      PrintError("--calibration needs a SESSION or --scenario input: a cloud file holds placed points, "
                 "not the raw samples a calibration re-projects");
      return kExitBadInput;
    }
    const int refused = RefuseOptions(args, {"pose-source", "strict", "seed"},
                                      "a cloud file (it holds placed points)");
    if (refused != kExitOk) return refused;
    std::vector<Eigen::Vector3f> pts;
    const Status s = LoadPositions(args.positional()[0], &pts);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    // Too few points for a plane is the file's fault, not the evaluation's.
    if (pts.size() < 3) {
      PrintError(args.positional()[0] + ": " + std::to_string(pts.size()) +
                 " finite point(s): nothing to evaluate (a plane needs 3)");
      return kExitBadInput;
    }
    CloudEvaluation e;
    const Status es = evaluate("cloud", pts, &e);
    if (!es.ok()) {
      PrintError(es.message());
      return kExitFailure;
    }
    results.emplace_back("cloud", e);
  } else {
    // Uncalibrated, and with --calibration calibrated: each run's positions
    // from `positions`, then evaluated.
    std::vector<std::pair<std::string, MountingError>> runs = {{"uncalibrated", MountingError{}}};
    if (args.Has("calibration")) runs.emplace_back("calibrated", calibration);
    auto evaluate_runs = [&](auto&& positions) {
      for (const auto& [title, c] : runs) {
        std::vector<Eigen::Vector3f> pts;
        const int code = positions(c, &pts);
        if (code != kExitOk) return code;
        CloudEvaluation e;
        const Status es = evaluate(title, pts, &e);
        if (!es.ok()) {
          PrintError(es.message());
          return kExitFailure;
        }
        results.emplace_back(title, e);
      }
      return kExitOk;
    };
    int code;
    // One input: a SESSION, a cloud file or --scenario (not both, not two).
    if (args.positional().size() + (args.Has("scenario") ? 1 : 0) != 1) {
      PrintError(args.positional().size() > 1
                     ? "evaluate takes one SESSION or cloud file, got " +
                           std::to_string(args.positional().size())
                     : std::string(args.positional().empty()
                                       ? "expected a SESSION, a cloud file or --scenario"
                                       : "give a SESSION or --scenario, not both"));
      return kExitBadInput;
    }
    if (!args.Has("scenario") && !(args.Has("pose-source") && args.Get("pose-source") == "truth")) {
      // A session: streamed (hardware/station/session_stream.h), only the
      // positions kept, so memory is the evaluation's own.
      if ((code = RefuseOptions(args, {"seed"}, "a session (it is for --scenario)")) != kExitOk)
        return code;
      ReconstructionOptions ro;
      if (args.Has("pose-source") && (!ParsePoseSource(args.Get("pose-source"), &ro.pose.source) ||
                                      ro.pose.source == PoseSource::kSfm)) {
        PrintError("--pose-source must be ekf, odometry or truth, got '" + args.Get("pose-source") + "'");
        return kExitBadInput;
      }
      code = evaluate_runs([&](const MountingError& c, std::vector<Eigen::Vector3f>* pts) {
        ro.calibration = c;
        TerminalProgress reading(show_progress, "evaluate " + args.positional()[0]);
        return StreamPositions(args, args.positional()[0], ro, pts, &reading);
      });
    } else {
      // A scenario (simulated in-process, with its truth) or truth poses.
      RecordingInput in;
      if ((code = LoadRecording(args, &in)) != kExitOk) return code;
      code = evaluate_runs([&](const MountingError& c, std::vector<Eigen::Vector3f>* pts) {
        ReconstructionResult r;
        const int rc = RecordingPoses(args, in, c, /*smooth=*/false, &r);  // the cloud `reconstruct` makes
        if (rc != kExitOk) return rc;
        pts->reserve(r.points.size());
        for (const auto& p : r.points) pts->emplace_back(p.x, p.y, p.z);
        return kExitOk;
      });
    }
    if (code != kExitOk) return code;
  }
  if (args.Flag("json")) {
    nlohmann::json report;
    for (const auto& [title, e] : results) report[title] = EvaluationToJson(e);
    std::cout << report.dump(2) << "\n";
    return kExitOk;
  }
  for (const auto& [title, e] : results) PrintEvaluation(title, e);
  return kExitOk;
}

}  // namespace sweepscan::app
