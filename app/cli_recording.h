// Input shared by `calibrate` and `evaluate`: a recorded session folder, or
// a scenario simulated in-process. Both end as a hardware::Recording;
// everything after that is one code path.
#ifndef SWEEPSCAN_APP_CLI_RECORDING_H_
#define SWEEPSCAN_APP_CLI_RECORDING_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "app/cli_args.h"
#include "app/terminal_progress.h"
#include "core/cloud/reconstruct.h"
#include "core/robot/robot_model.h"
#include "hardware/station/recording.h"
#include "hardware/station/session_stream.h"

namespace sweepscan::app {

using RecordingInput = hardware::Recording;

// --strict: refuse a session with damaged records (the default skips them
// with a warning). Accepted by every command that reads sessions.
FramesLoadOptions SessionFramesOptions(const Args& args);
// One warning line on stderr when frames.bin had damaged stretches that were
// skipped (how many records, how many seconds, where); nothing otherwise.
void WarnAboutDamage(const std::string& session_dir, const FramesLoadReport& frames);
// The error line for a session that could not be opened (with --strict, a
// damaged record's error says how to go on).
void PrintSessionError(const Args& args, const std::string& session_dir, const Status& status);

// A session decoded whole (info, export, and the cloud exports that need
// every scan at once: --pose-source sfm, --loop-closure).
struct Decoded {
  SensorLog log;
  hardware::SessionDecodeInfo info;
};
// Decodes SESSION (damaged records skipped unless --strict); warns about
// damage unless `quiet` (info reports it in its own output). Returns an exit code.
int DecodeOrFail(const Args& args, const std::string& dir, Decoded* d, bool quiet = false);

// Pass 1 of a streamed session (hardware/station/session_stream.h): reads
// meta.json, completes *options (the start pose; with session_calibration
// also meta.json's calibration or --calibration FILE's), estimates the
// poses, warns about damage and prints the pose gaps on stderr. Returns an
// exit code; prints one error line otherwise. `progress` (may be null)
// shows pass 1 on a terminal.
int OpenSessionStream(const Args& args, const std::string& dir, bool session_calibration,
                      ReconstructionOptions* options, hardware::SessionCloudStream* stream,
                      TerminalProgress* progress = nullptr);
// The positions of a session's cloud, streamed (evaluate); `progress` as
// above, for both passes.
int StreamPositions(const Args& args, const std::string& dir, ReconstructionOptions options,
                    std::vector<Eigen::Vector3f>* points, TerminalProgress* progress = nullptr);

// `reconstruct SESSION --out CLOUD` and `export SESSION --out CLOUD`
// (cli_reconstruct.cc); `command` titles the progress shown on a terminal.
// IsCloudFile: CLOUD ends in .las, .ply or .pcd.
int ReconstructToFile(const Args& args, const std::string& command);
bool IsCloudFile(const std::string& path);

// What `reconstruct` and `export --format rosbag` make a session's cloud
// with: meta.json's calibration (or --calibration FILE's), its start pose.
// Returns an exit code; prints one error line otherwise.
int SessionReconstructionOptions(const Args& args, const SessionMeta& meta, ReconstructionOptions* options);

// SESSION or --scenario FILE [--seed N]. Returns an exit code (kExitOk on
// success); prints one error line otherwise.
int LoadRecording(const Args& args, RecordingInput* in);

// Poses for the recording (--pose-source: EKF by default, odometry, or the
// simulation's truth) and its cloud under `calibration`; `smooth`: the EKF's
// poses smoothed over the whole recording (pose_estimator.h). Returns an
// exit code.
int RecordingPoses(const Args& args, const RecordingInput& in, const MountingError& calibration,
                   bool smooth, ReconstructionResult* result);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_CLI_RECORDING_H_
