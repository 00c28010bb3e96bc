#include "core/sfm/wheeled.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/sim/rig.h"

namespace sweepscan::sfm {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

double Yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// The scan deskewed to its middle time `mid` with the prior: the Assembler
// places every sample by the prior's pose at the sample's time relative to
// the pose at `mid` (P_mid^-1 P(t_i)), i.e. in the body frame at `mid`;
// the points are then expressed in the scan-plane frame `body_from_plane`
// (x, y in the plane, z across it: the motion during the revolution).
// Returns false when the prior does not cover the scan.
bool DeskewScan(const LidarScan& scan, const PoseBuffer& prior, Time mid, const Rigid3d& body_from_lidar,
                const Rigid3d& body_from_plane, const AssemblyOptions& assembly, Scan* out) {
  Rigid3d world_from_mid;
  if (!prior.Lookup(mid, &world_from_mid)) return false;
  size_t hint = 0, first = 0, last = 0;
  double frac;
  if (!prior.FindInterval(scan.start_time(), &hint, &first, &frac)) return false;
  if (!prior.FindInterval(scan.end_time(), &hint, &last, &frac)) return false;
  const Rigid3d mid_from_world = world_from_mid.inverse();
  PoseBuffer relative;
  for (size_t i = first; i <= std::min(last + 1, prior.size() - 1); ++i) {
    relative.Add(prior.time(i), mid_from_world * prior.pose(i));
  }
  AssemblyOptions local = assembly;
  local.snap_to_grid = false;  // Points for scan matching, not the cloud.
  Assembler assembler(local, body_from_lidar, PoseSource::kSfm);
  PointChunks chunks(1024);
  assembler.AddScan(scan, relative, &chunks);
  chunks.Seal();
  // CloudPoint::beam is the sample's beam; map it back to the scan order.
  std::vector<int> sample_of_beam;
  for (size_t j = 0; j < scan.samples.size(); ++j) {
    const uint16_t b = scan.samples[j].beam;
    if (b >= sample_of_beam.size()) sample_of_beam.resize(b + 1, -1);
    sample_of_beam[b] = static_cast<int>(j);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out->points.assign(scan.samples.size(), Eigen::Vector2d(nan, nan));
  out->deskewed.assign(scan.samples.size(), Eigen::Vector3d(nan, nan, nan));
  const Rigid3d plane_from_body = body_from_plane.inverse();
  for (const CloudPoint& p : chunks.Flatten()) {
    if (p.beam >= sample_of_beam.size() || sample_of_beam[p.beam] < 0) continue;
    const Eigen::Vector3d q = plane_from_body * Eigen::Vector3d(p.x, p.y, p.z);
    out->points[sample_of_beam[p.beam]] = q.head<2>();
    out->deskewed[sample_of_beam[p.beam]] = q;
  }
  out->time_s = ToSeconds(mid);
  out->lidar = 0;
  return true;
}

}  // namespace

MotionPrior WheeledMotionPrior(PoseSource prior_source) {
  MotionPrior m;
  m.abs_tilt_sigma_rad = 0.005;
  m.abs_yaw_sigma_rad = prior_source == PoseSource::kOdometry ? 0.0 : 0.01;
  return m;
}

SequenceOptions WheeledSequenceOptions() {
  SequenceOptions o;
  o.new_plane_parallel_separation_m = 0.3;
  return o;
}

Status RunWheeledSfm(const std::vector<LidarScan>& scans, const Rigid3d& body_from_lidar, const PoseBuffer& prior,
                     const SequenceInit& init, const WheeledSfmOptions& options, WheeledSfmResult* result) {
  *result = WheeledSfmResult();
  if (prior.empty()) return Status::Error("no prior poses (the recording has no wheel records?)");
  std::string error;
  if (!options.assembly.IsValid(&error)) return Status::Error(error);
  // The scan plane is the lidar frame's y-z plane (Eq. 1); the sequence's
  // lidar frame has it as x-y (sim::X4LidarFromScanPlane).
  const Rigid3d body_from_plane = body_from_lidar * sim::X4LidarFromScanPlane();
  Rig rig;
  rig.rig_from_lidar = {body_from_plane};
  std::vector<Scan> frames;
  MotionPrior motion = options.motion;
  motion.world_from_rig.clear();
  double last_time = -1e300;
  for (const LidarScan& scan : scans) {
    if (scan.samples.size() < 2) continue;
    const Time mid = scan.start_time() + (scan.end_time() - scan.start_time()) / 2;
    if (ToSeconds(mid) - last_time <= 1e-6) continue;  // not after the previous frame
    Scan s;
    if (!DeskewScan(scan, prior, mid, body_from_lidar, body_from_plane, options.assembly, &s)) continue;
    int valid = 0;
    for (const Eigen::Vector2d& p : s.points) valid += p.allFinite() ? 1 : 0;
    if (valid < options.min_scan_samples) continue;
    Rigid3d world_from_body;
    prior.Lookup(mid, &world_from_body);
    motion.world_from_rig.push_back(world_from_body);
    result->scans.push_back(scan.index);
    last_time = s.time_s;
    frames.push_back(std::move(s));
  }
  if (frames.size() < 2) {
    return Status::Error("fewer than two lidar scans within the prior's time span (" + std::to_string(frames.size()) +
                         " of " + std::to_string(scans.size()) + ")");
  }
  result->prior = motion.world_from_rig;
  Status s = RunSequence(frames, rig, init, options.sequence, &motion, &result->sequence);
  if (!s.ok()) return s;
  const SequenceResult& seq = result->sequence;
  if (seq.planes.empty()) return Status::Error("no planes found in the scans (no lines of at least 0.5 m?)");

  // The corrected buffer: C(t) P(t), C interpolated between the frames.
  const std::vector<double>& ft = seq.frame_times_s;
  std::vector<Rigid3d> correction(ft.size());
  for (size_t k = 0; k < ft.size(); ++k) correction[k] = seq.poses[k] * result->prior[k].inverse();
  size_t k = 0;
  for (size_t i = 0; i < prior.size(); ++i) {
    const double t = ToSeconds(prior.time(i));
    while (k + 1 < ft.size() && ft[k + 1] <= t) ++k;
    Rigid3d c;
    if (t <= ft.front()) {
      c = correction.front();
    } else if (k + 1 >= ft.size()) {
      c = correction.back();
    } else {
      c = PoseBuffer::InterpolateNlerp(correction[k], correction[k + 1], (t - ft[k]) / (ft[k + 1] - ft[k]));
    }
    result->poses.Add(prior.time(i), c * prior.pose(i));
  }
  return Status::Ok();
}

Status WheeledSfmFromLog(const SensorLog& log, const RobotGeometry& geometry, const MountingError& calibration,
                         const Pose2d& start, PoseSource prior_source, const SequenceInit& init,
                         const WheeledSfmOptions& options, WheeledSfmResult* result) {
  if (prior_source != PoseSource::kEkf && prior_source != PoseSource::kOdometry) {
    return Status::Error("the SfM prior must be ekf or odometry");
  }
  std::string error;
  if (!geometry.IsValid(&error)) return Status::Error(error);
  if (log.wheels.empty()) return Status::Error("the recording has no wheel odometry records");
  if (log.scans.empty()) return Status::Error("the recording has no lidar scans");
  PoseEstimatorOptions po;
  po.source = prior_source;
  po.initial_pose = start;
  PoseEstimator estimator = EstimatePoses(log, po, geometry);
  return RunWheeledSfm(log.scans, BodyFromLidar(geometry, calibration), estimator.poses(), init, options, result);
}

Status WheeledInitFromTruth(const std::vector<LidarScan>& scans, const PoseBuffer& truth,
                            const Rigid3d& body_from_lidar, const sim::Scene& scene, int min_samples,
                            SequenceInit* init, std::vector<std::string>* chosen) {
  const std::vector<sim::TruthPlane> faces = sim::ScenePlanes(scene);
  for (const LidarScan& scan : scans) {
    std::vector<std::vector<size_t>> on(faces.size());
    int valid = 0;
    size_t hint = 0;
    for (size_t j = 0; j < scan.samples.size(); ++j) {
      const LidarSample& m = scan.samples[j];
      Rigid3d world_from_body;
      if (!(m.range_m > 0.12f) || !truth.LookupWithHint(m.time, &hint, &world_from_body)) continue;
      ++valid;
      const Eigen::Vector3d p =
          world_from_body * (body_from_lidar * Eigen::Vector3d(0.0, m.range_m * std::sin(m.theta),
                                                               m.range_m * std::cos(m.theta)));
      for (size_t f = 0; f < faces.size(); ++f) {
        if (std::abs(faces[f].normal.dot(p) + faces[f].d) < 0.01) on[f].push_back(j);
      }
    }
    if (valid < min_samples) continue;
    std::vector<size_t> order(faces.size());
    for (size_t f = 0; f < faces.size(); ++f) order[f] = f;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return on[a].size() > on[b].size(); });
    // Faces in one plane (a desk's bottom on the floor) count once.
    std::vector<size_t> picked;
    for (size_t f : order) {
      if (picked.size() == 3 || on[f].size() < 30) break;
      bool same = false;
      for (size_t g : picked) {
        const double c = faces[f].normal.dot(faces[g].normal);
        same = same || (std::abs(c) > std::cos(2.0 * M_PI / 180.0) && std::abs(faces[f].d - c * faces[g].d) < 0.01);
      }
      if (!same) picked.push_back(f);
    }
    if (picked.size() < 3) return Status::Error("the first scan does not see three planes of the scene");
    *init = SequenceInit();
    chosen->clear();
    for (int k = 0; k < 3; ++k) {
      const sim::TruthPlane& f = faces[picked[k]];
      const LidarSample& m = scan.samples[on[picked[k]][on[picked[k]].size() / 2]];
      InitPlane& ip = init->planes[k];
      ip.known = true;
      ip.plane.normal = f.normal;
      ip.plane.d = f.d;
      InitLineRef ref;
      ref.near = Eigen::Vector2d(m.range_m * std::cos(m.theta), m.range_m * std::sin(m.theta));
      ip.lines.push_back(ref);
      chosen->push_back(f.label);
    }
    return Status::Ok();
  }
  return Status::Error("no scan with enough samples within the truth's time span");
}

WheeledErrors EvaluateWheeled(const std::vector<double>& times_s, const std::vector<Rigid3d>& poses,
                              const PoseBuffer& truth) {
  WheeledErrors e;
  size_t hint = 0;
  for (size_t k = 0; k < poses.size() && k < times_s.size(); ++k) {
    size_t i;
    double frac;
    if (!truth.FindInterval(TimeFromSeconds(times_s[k]), &hint, &i, &frac)) continue;
    const Rigid3d T = frac == 0.0 ? truth.pose(i) : PoseBuffer::InterpolateNlerp(truth.pose(i), truth.pose(i + 1), frac);
    const Eigen::Matrix3d Rt = T.rotation().toRotationMatrix(), Re = poses[k].rotation().toRotationMatrix();
    const Eigen::Vector3d d = poses[k].translation() - T.translation();
    const double yaw = Yaw(Rt);
    const double along = std::abs(d.x() * std::cos(yaw) + d.y() * std::sin(yaw));
    const double lateral = std::abs(-d.x() * std::sin(yaw) + d.y() * std::cos(yaw));
    const double heading = std::abs(WrapAngle(Yaw(Re) - yaw)) * kRadToDeg;
    const double tilt = std::acos(std::clamp(Rt.col(2).dot(Re.col(2)), -1.0, 1.0)) * kRadToDeg;
    ++e.frames;
    e.along_mean_m += along;
    e.along_max_m = std::max(e.along_max_m, along);
    e.along_final_m = along;
    e.lateral_mean_m += lateral;
    e.lateral_max_m = std::max(e.lateral_max_m, lateral);
    e.lateral_final_m = lateral;
    e.height_mean_m += std::abs(d.z());
    e.height_max_m = std::max(e.height_max_m, std::abs(d.z()));
    e.heading_mean_deg += heading;
    e.heading_max_deg = std::max(e.heading_max_deg, heading);
    e.heading_final_deg = heading;
    e.tilt_mean_deg += tilt;
    e.tilt_max_deg = std::max(e.tilt_max_deg, tilt);
    e.trans_mean_m += d.norm();
    e.trans_max_m = std::max(e.trans_max_m, d.norm());
  }
  if (e.frames > 0) {
    const double n = e.frames;
    e.along_mean_m /= n;
    e.lateral_mean_m /= n;
    e.height_mean_m /= n;
    e.heading_mean_deg /= n;
    e.tilt_mean_deg /= n;
    e.trans_mean_m /= n;
  }
  return e;
}

}  // namespace sweepscan::sfm
