#include "hardware/station/project_align.h"

#include "core/session/session.h"

namespace sweepscan::hardware {
namespace {

// The control of one stage, its progress mapped into [lo, hi] of the call.
RegistrationControl Stage(const RegistrationControl& control, double lo, double hi) {
  RegistrationControl stage;
  stage.cancel = control.cancel;
  if (control.progress) {
    stage.progress = [progress = control.progress, lo, hi](const RegistrationProgress& p) {
      RegistrationProgress mapped = p;
      mapped.fraction = lo + (hi - lo) * p.fraction;
      return progress(mapped);
    };
  }
  return stage;
}

}  // namespace

RegistrationAttempt RegisterSession(const std::vector<Eigen::Vector3f>& source,
                                    const std::vector<Eigen::Vector3f>& target,
                                    const std::string& reference,
                                    const SessionRegistrationOptions& options,
                                    const RegistrationControl& control) {
  RegistrationAttempt a;
  a.reference = reference;
  const double coarse_end = options.icp ? 0.5 : 1.0;
  if (options.by_pairs || !options.pairs.empty()) {
    a.status = AlignByPairs(options.pairs, &a.coarse);
    a.method = "pairs";
  } else {
    a.status = AlignByPlanes(source, target, PlaneAlignOptions(), &a.coarse,
                             Stage(control, 0.0, coarse_end));
    a.method = "planes";
    // A corridor stays refused here, hold_free or not: the planes fix the
    // rest but give no position along it (nor, often, which way round the
    // corridor runs), so there is no coarse pose to hold. Picked pairs
    // across it give one, and ICP then holds that direction.
  }
  if (!a.status.ok() || !options.icp) {
    a.fine = a.coarse;
    return a;
  }
  IcpOptions icp;
  icp.degeneracy = options.hold_free ? DegeneracyPolicy::kHold : DegeneracyPolicy::kRefuse;
  icp.pairs = options.pairs;  // the picks stay as a prior (registration.h)
  a.status = RefineIcp(source, target, a.coarse.target_from_source, icp,
                       Stage(control, coarse_end, 1.0), &a.fine);
  a.method += "+icp";
  return a;
}

RegistrationEvidence EvidenceOf(const RegistrationAttempt& a, const std::vector<PointPair>& pairs) {
  RegistrationEvidence e;
  e.method = a.method;
  e.reference = a.reference;
  const RegistrationResult& r = a.fine;
  e.rms_m = r.rms_m;
  e.overlap = r.overlap;
  e.correspondences = r.correspondences;
  e.iterations = r.iterations;
  for (int i = 0; i < 36; ++i) e.covariance[i] = r.covariance(i / 6, i % 6);
  if (r.degenerate && !r.free_is_rotation) e.free_direction = r.free_direction;
  for (const PointPair& p : pairs) e.pairs.push_back({p.source, p.target});
  e.time_utc = UtcNowIso8601();
  return e;
}

}  // namespace sweepscan::hardware
