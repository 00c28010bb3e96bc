// Loop closure inside one session (issue 29): a drive that comes back to
// where it was (re-enters the room it started in) sees the same walls
// again; registering what it saw the second time to what it saw the first
// measures the drift accumulated in between, and spreading that correction
// over the loop removes it from the poses, and so from the cloud.
//
//   1. The loop: the drive ends in the room it started in (the operator
//      asks for the closure, knowing where the robot was driven). The
//      windows are the run of poses from the first that stays within
//      revisit_radius_m of the first pose, and the run to the last that
//      stays within it of the last pose (turns in place there: the room seen
//      whole). The two must be at least min_gap_s apart and the robot at
//      least min_away_m from its start in between, or there is no loop. The
//      end's position is not compared with the start's: the drift being
//      removed may be metres (the wheels alone); the registration decides
//      whether the two windows see the same room.
//   2. Measure: the late window's points (source) against the early
//      window's (target), both in the session's frame: planes, then ICP
//      (ICP alone from the identity if the planes refuse and the drift is
//      small). C = target_from_source maps where the drifted poses put the
//      room the second time onto where they put it the first.
//   3. Correct (first order in the drift): a pose at time t becomes
//      Interp(I, C, s(t)) * pose(t) with s = 0 up to the early window's end,
//      s = 1 from the late window's start, and linear in time between (drift
//      grows with the time driven; the EKF's heading drift is a gyro bias
//      integrated over time). The end of the loop is then exact to the
//      registration; in between the error falls from its drift to what the
//      linear spread does not model.
//
// Pure functions; any thread.
#ifndef SWEEPSCAN_CORE_REGISTRATION_LOOP_CLOSURE_H_
#define SWEEPSCAN_CORE_REGISTRATION_LOOP_CLOSURE_H_

#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/common/status.h"
#include "core/pose/pose_buffer.h"
#include "core/registration/registration.h"

namespace sweepscan {

struct LoopClosureOptions {
  double revisit_radius_m = 0.5;
  double min_gap_s = 60.0;
  double min_away_m = 3.0;
  // The correction's translation may be at most this share of the distance
  // driven between the windows: a drive that does not end in its start's
  // room can still register to a look-alike room (the office floor's room B
  // onto room A, 5.1 m away), which no plausible drift explains. The EKF
  // drifts by well under 1 % of the distance (the default allows 5 %); the
  // wheels alone by tens of per cent (give 0.5 for them).
  double max_drift_fraction = 0.05;
  PlaneAlignOptions planes;
  IcpOptions icp;
  bool IsValid(std::string* error) const;
};

struct LoopClosure {
  bool found = false;          // the drive left and came back (else nothing to close; not an error)
  std::string method;          // "planes+icp" or "icp"
  Time early_begin, early_end, late_begin, late_end;
  size_t early_points = 0, late_points = 0;
  Rigid3d correction;          // C, world_from_drifted at the loop's end
  RegistrationResult registration;
};

// Measures the loop. OK with found = false when the drive never left its
// start; an error when the registration of the two windows refuses (they
// do not see the same room, or too little of it: the Status says why) or
// they hold too few points.
Status FindLoop(const std::vector<CloudPoint>& points, const PoseBuffer& poses,
                const LoopClosureOptions& options, LoopClosure* loop);

// The poses with the loop's correction spread over it (step 3 above).
PoseBuffer CorrectPoses(const PoseBuffer& poses, const LoopClosure& loop);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_REGISTRATION_LOOP_CLOSURE_H_
