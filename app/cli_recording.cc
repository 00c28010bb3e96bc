// The input `calibrate` and `evaluate` share (cli_recording.h).
#include "app/cli_recording.h"

#include <cstdlib>
#include <iostream>
#include <string>

#include "app/cli_common.h"
#include "core/calibration/calibration_file.h"
#include "core/calibration/workflow.h"
#include "core/scenario/scenario.h"

namespace sweepscan::app {

FramesLoadOptions SessionFramesOptions(const Args& args) {
  FramesLoadOptions options = hardware::DefaultSessionFramesOptions();
  if (args.Flag("strict")) options.skip_corrupt_records = false;
  return options;
}

void WarnAboutDamage(const std::string& session_dir, const FramesLoadReport& frames) {
  if (!frames.damaged()) return;
  std::cerr << "sweepscan-cli: warning: " << session_dir << "/" << kSessionFramesFile << ": "
            << frames.DamageSummary() << "; the rest was used (--strict refuses a damaged "
            << "session; `sweepscan-cli repair " << session_dir << " --out NEW` writes a clean copy)\n";
}

int DecodeOrFail(const Args& args, const std::string& dir, Decoded* d, bool quiet) {
  const Status s = hardware::DecodeSession(dir, SessionFramesOptions(args), &d->log, &d->info);
  if (!s.ok()) {
    PrintSessionError(args, dir, s);
    return kExitBadInput;
  }
  if (!quiet) WarnAboutDamage(dir, d->info.frames);
  return kExitOk;
}

void PrintSessionError(const Args& args, const std::string& session_dir, const Status& status) {
  std::string message = status.message();
  if (args.Flag("strict") && message.find(": record ") != std::string::npos) {
    message += " (run without --strict to skip the damaged records, or `sweepscan-cli repair " +
               session_dir + " --out NEW` to write a clean copy)";
  }
  PrintError(message);
}

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
  if (const int code = has_scenario
                           ? RefuseOptions(args, {"strict"}, "--scenario (it is for sessions)")
                           : RefuseOptions(args, {"seed"}, "a session (it is for --scenario)");
      code != kExitOk) {
    return code;
  }
  if (has_scenario) {
    sim::SimConfig scenario;
    Status s = LoadScenario(args.Get("scenario"), &scenario);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    if (args.Has("seed")) {
      const std::string v = args.Get("seed");
      uint64_t seed = 0;
      if (!ParseSeed(v, &seed)) {
        PrintError("--seed expects an integer from 0 to 2^64 - 1, got '" + v + "'");
        return kExitBadInput;
      }
      scenario.seed = seed;
    }
    hardware::SimulateRecording(scenario, in);
    return kExitOk;
  }
  const std::string& dir = args.positional().front();
  const Status s = hardware::OpenRecording(dir, SessionFramesOptions(args), in);
  if (!s.ok()) {
    PrintSessionError(args, dir, s);
    return kExitBadInput;
  }
  WarnAboutDamage(dir, in->decode.frames);
  return kExitOk;
}

// Poses for the recording: EKF (default), odometry, or the simulation's truth.
int RecordingPoses(const Args& args, const RecordingInput& in, const MountingError& calibration,
                   bool smooth, ReconstructionResult* result) {
  ReconstructionOptions options;
  options.pose.smooth = smooth;
  // A calibration's smoothed poses take the IMU's tilt noise as measured on
  // the recording, if above the data sheet's (workflow.h).
  if (smooth) UseMeasuredTiltNoise(in.log, &options.pose.ekf);
  if (args.Has("pose-source") && (!ParsePoseSource(args.Get("pose-source"), &options.pose.source) ||
                                  options.pose.source == PoseSource::kSfm)) {
    PrintError("--pose-source must be ekf, odometry or truth, got '" + args.Get("pose-source") + "'");
    return kExitBadInput;
  }
  if (options.pose.source == PoseSource::kTruth && !in.has_truth) {
    PrintError("--pose-source truth needs a simulated input (--scenario)");
    return kExitBadInput;
  }
  options.calibration = calibration;
  const Status s = hardware::ReconstructRecording(in, options, result);
  if (!s.ok()) {  // no poses from the records (no odometry): an unusable input
    PrintError(in.session_dir.empty() ? s.message() : in.session_dir + ": " + s.message());
    return kExitBadInput;
  }
  // Holes in the sensor data (a link outage the robot's buffer did not
  // cover): no motion was invented across them; say how the pose resumed.
  for (const PoseGap& gap : result->gaps) {
    std::cerr << "sweepscan-cli: " << FormatPoseGap(gap, in.decode.first_robot_time) << "\n";
  }
  return kExitOk;
}

int SessionReconstructionOptions(const Args& args, const SessionMeta& meta, ReconstructionOptions* options) {
  options->calibration = meta.calibration;
  options->pose.initial_pose = SessionStartPose(meta);
  if (args.Has("calibration")) {
    const Status s = LoadCalibrationFile(args.Get("calibration"), &options->calibration);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  return kExitOk;
}

int OpenSessionStream(const Args& args, const std::string& dir, bool session_calibration,
                      ReconstructionOptions* options, hardware::SessionCloudStream* stream,
                      TerminalProgress* progress) {
  SessionMeta meta;
  Status s = ReadSessionMeta(dir + "/" + kSessionMetaFile, &meta);
  if (!s.ok()) {
    PrintSessionError(args, dir, s);
    return kExitBadInput;
  }
  if (session_calibration) {
    const int code = SessionReconstructionOptions(args, meta, options);
    if (code != kExitOk) return code;
  } else {
    options->pose.initial_pose = SessionStartPose(meta);
  }
  s = stream->EstimatePoses(
      dir, SessionFramesOptions(args), *options, nullptr,
      progress != nullptr ? progress->Stage("estimating the poses") : nullptr);
  if (progress != nullptr) progress->Clear();  // what follows on lines of its own
  if (!s.ok() && !stream->decoded()) {
    PrintSessionError(args, dir, s);
    return kExitBadInput;
  }
  if (!s.ok()) {  // the session read, but no poses from it (no odometry, say):
    PrintError(dir + ": " + s.message());  // an input that cannot be used
    return kExitBadInput;
  }
  WarnAboutDamage(dir, stream->decode().frames);
  for (const PoseGap& gap : stream->result().gaps) {
    std::cerr << "sweepscan-cli: " << FormatPoseGap(gap, stream->decode().first_robot_time) << "\n";
  }
  return kExitOk;
}

int StreamPositions(const Args& args, const std::string& dir, ReconstructionOptions options,
                    std::vector<Eigen::Vector3f>* points, TerminalProgress* progress) {
  hardware::SessionCloudStream stream;
  const int code =
      OpenSessionStream(args, dir, /*session_calibration=*/false, &options, &stream, progress);
  if (code != kExitOk) return code;
  points->clear();
  points->reserve(stream.PointBound());
  const Status s = stream.PlacePoints(
      [points](const CloudPoint* p, size_t n) {
        for (size_t i = 0; i < n; ++i) points->emplace_back(p[i].x, p[i].y, p[i].z);
        return Status::Ok();
      },
      progress != nullptr ? progress->Stage("placing the points") : nullptr);
  if (progress != nullptr) progress->Clear();
  if (!s.ok()) {
    PrintError(dir + ": " + s.message());
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace sweepscan::app
