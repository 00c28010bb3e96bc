// A recording ready for processing: the decoded sensor records of a session
// folder (or of a scenario simulated in-process), the robot's geometry and
// start pose, and, for simulations, the ground truth. The one way the CLI's
// commands and the desktop app open their input, so both process the same
// records the same way.
//
// Pure functions, no Qt; may run on any thread (the app opens recordings on
// a worker thread).
#ifndef SWEEPSCAN_HARDWARE_STATION_RECORDING_H_
#define SWEEPSCAN_HARDWARE_STATION_RECORDING_H_

#include <string>

#include "core/cloud/reconstruct.h"
#include "core/common/status.h"
#include "core/pose/pose_buffer.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "core/session/session.h"
#include "core/sim/world.h"
#include "hardware/link/telemetry_decoder.h"

namespace sweepscan::hardware {

struct Recording {
  std::string name;         // "session DIR" or "scenario NAME", for messages
  std::string session_dir;  // empty for an in-process simulation
  SensorLog log;
  RobotGeometry geometry;
  Pose2d start;              // the robot's pose at the first record (world frame)
  SessionDecodeInfo decode;  // sessions only: meta.json, frame and decoder counters
  bool has_truth = false;    // simulations only:
  sim::SimConfig scenario;   //   the world and its true mounting error
  PoseBuffer truth_poses;    //   the true trajectory (1 kHz)
};

// Decodes a session folder (docs/session-format.md). A corrupt meta.json is
// refused with the file, the place and the reason; damaged stretches of
// frames.bin are skipped and described in decode.frames.damage (show
// decode.frames.DamageSummary() to the operator); frames that are not valid
// link frames are counted in decode.frames_refused and skipped.
Status OpenRecording(const std::string& session_dir, Recording* recording);
// The same with progress and cancel (DecodeProgress: fraction 0..1; return
// false to cancel, which fails with "cancelled").
Status OpenRecording(const std::string& session_dir, Recording* recording,
                     const DecodeProgress& progress);
// With explicit frames.bin options (skip_corrupt_records = false refuses a
// damaged session: the CLI's --strict).
Status OpenRecording(const std::string& session_dir, const FramesLoadOptions& frames_options,
                     Recording* recording, const DecodeProgress& progress = nullptr);

// Runs a scenario's world in-process (no bytes: the simulator's records
// directly) and keeps its ground truth.
void SimulateRecording(const sim::SimConfig& scenario, Recording* recording);

// Poses and cloud of a recording: options.pose.initial_pose is set from the
// recording's start; kTruth needs a simulated recording.
Status ReconstructRecording(const Recording& recording, ReconstructionOptions options,
                            ReconstructionResult* result);

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_RECORDING_H_
