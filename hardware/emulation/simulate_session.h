// Records a simulated scan as a session by the real bytes, as fast as the
// machine allows: the scenario's world behind the byte-exact device
// emulations (SimDevices), the robot agent's own logic (AgentCore) turning
// device bytes into link frames, and a workstation-side link decoder that
// appends every frame to a session folder, exactly as RobotConnection does
// over a serial port or TCP. Reprocessing that session (DecodeSession +
// Reconstruct) is then the same code path as for a real robot.
//
// Time is simulated: the loop advances robot time in fixed steps, so a
// 60 s drive takes well under a second and the result is deterministic.
#ifndef SWEEPSCAN_HARDWARE_EMULATION_SIMULATE_SESSION_H_
#define SWEEPSCAN_HARDWARE_EMULATION_SIMULATE_SESSION_H_

#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/session/session.h"
#include "core/sim/world.h"
#include "hardware/link/link_protocol.h"

namespace sweepscan::hardware {

struct SimulateSessionOptions {
  // Simulated time step of the loop (the agent's tick and the device reads).
  Duration step = std::chrono::milliseconds(5);
  // Extra time recorded after the path ends (the last revolution and frames).
  Duration tail = std::chrono::milliseconds(500);
  bool overwrite = false;  // Replace an existing session folder.
  std::string notes;
  // Called once a simulated second with the fraction of the drive recorded
  // (0..1); may be empty.
  std::function<void(double fraction)> progress;
};

struct SimulateSessionReport {
  uint64_t frames_recorded = 0;
  uint64_t bytes_recorded = 0;
  uint64_t telemetry_frames = 0;
  LinkDecoderStats link;  // Workstation side: must show no errors.
  double simulated_s = 0.0;
};

// Writes `session_dir` (must not exist unless options.overwrite). The
// session's meta.json carries the scenario's robot geometry and lidar angle
// convention, zero calibration (the mounting error is what calibration has to
// find), and the scenario itself under settings.scenario.
Status SimulateSession(const sim::SimConfig& config, const std::string& session_dir,
                       const SimulateSessionOptions& options, SimulateSessionReport* report);

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_EMULATION_SIMULATE_SESSION_H_
