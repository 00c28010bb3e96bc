#include "hardware/station/recording.h"

namespace sweepscan::hardware {

Status OpenRecording(const std::string& session_dir, Recording* recording) {
  return OpenRecording(session_dir, recording, nullptr);
}

Status OpenRecording(const std::string& session_dir, Recording* recording,
                     const DecodeProgress& progress) {
  return OpenRecording(session_dir, DefaultSessionFramesOptions(), recording, progress);
}

Status OpenRecording(const std::string& session_dir, const FramesLoadOptions& frames_options,
                     Recording* recording, const DecodeProgress& progress) {
  *recording = Recording();
  const Status s =
      DecodeSession(session_dir, frames_options, &recording->log, &recording->decode, progress);
  if (!s.ok()) return s;
  recording->session_dir = session_dir;
  recording->geometry = recording->decode.meta.geometry;
  recording->start = SessionStartPose(recording->decode.meta);
  recording->name = "session " + session_dir;
  return Status::Ok();
}

void SimulateRecording(const sim::SimConfig& scenario, Recording* recording) {
  *recording = Recording();
  recording->scenario = scenario;
  sim::SimWorld world(scenario);
  recording->log = world.RunAll();
  recording->truth_poses = world.TruthPoses(1000.0);
  recording->has_truth = true;
  recording->geometry = scenario.geometry;
  recording->start = scenario.start;
  recording->name = "scenario " + scenario.name;
}

Status ReconstructRecording(const Recording& recording, ReconstructionOptions options,
                            ReconstructionResult* result) {
  if (options.pose.source == PoseSource::kSfm) {
    return Status::Error("pose source 'sfm' is computed by core/sfm (sfm::WheeledSfmFromLog), not here");
  }
  if (options.pose.source == PoseSource::kTruth && !recording.has_truth) {
    return Status::Error("pose source 'truth' needs a simulated recording (a scenario)");
  }
  options.pose.initial_pose = recording.start;
  return Reconstruct(recording.log, recording.geometry, options, &recording.truth_poses, result);
}

}  // namespace sweepscan::hardware
