// One registration step of a project (issue 29), shared by
// `sweepscan-cli project align` and the desktop app's Project panel: a
// session's cloud (the source) against a placed session's cloud (the
// target), both in their own frames, coarse then fine
// (core/registration/registration.h):
//
//   coarse  AlignByPairs on the operator's picked pairs when given, else
//           AlignByPlanes (a corridor's free direction refused: there is
//           no position along it to start from);
//   fine    RefineIcp from the coarse pose (unless icp is off); with
//           hold_free a direction the clouds leave free (a corridor
//           aligned from picked pairs) is kept at the coarse pose and
//           reported instead of refused.
//
// The caller places the session: project_from_S = project_from_R * R_from_S
// with R_from_S = attempt.fine.target_from_source.
//
// Pure functions, no Qt; any thread (the app runs them on a worker).
#ifndef SWEEPSCAN_HARDWARE_STATION_PROJECT_ALIGN_H_
#define SWEEPSCAN_HARDWARE_STATION_PROJECT_ALIGN_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/project/project.h"
#include "core/registration/registration.h"

namespace sweepscan::hardware {

struct SessionRegistrationOptions {
  std::vector<PointPair> pairs;  // non-empty: coarse by these picks, not by planes
  // Coarse by `pairs` even when empty (then refused): picks given as none
  // are a mistake, not a request for planes.
  bool by_pairs = false;
  bool hold_free = false;        // ICP: hold a free direction at the coarse pose instead of refusing
  bool icp = true;               // refine by ICP after the coarse step
};

struct RegistrationAttempt {
  std::string reference;  // the target session's id
  Status status;          // ok: placed; else why not (the stage's refusal)
  RegistrationResult coarse, fine;  // fine == coarse without ICP or after a coarse refusal
  std::string method;               // "planes", "pairs", "planes+icp", "pairs+icp"
};

// Coarse then fine registration of `source` against `target` (the
// reference `reference`). `control` reports the whole call's progress as
// 0..0.5 for the coarse stage and 0.5..1 for ICP, and cancels either.
RegistrationAttempt RegisterSession(const std::vector<Eigen::Vector3f>& source,
                                    const std::vector<Eigen::Vector3f>& target,
                                    const std::string& reference,
                                    const SessionRegistrationOptions& options,
                                    const RegistrationControl& control = {});

// The evidence a project keeps for a successful attempt (time stamped now).
RegistrationEvidence EvidenceOf(const RegistrationAttempt& attempt,
                                const std::vector<PointPair>& pairs);

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_PROJECT_ALIGN_H_
