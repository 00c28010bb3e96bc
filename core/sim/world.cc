#include "core/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sweepscan::sim {
namespace {

bool Finite(std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// YDLIDAR's second-level (triangulation) correction, degrees, for d in mm
// (device-protocols.md): atan(21.8 (155.3 - d) / (155.3 d)).
double X4AngleCorrectionDeg(double d_mm) {
  if (d_mm <= 0.0) return 0.0;
  return std::atan(21.8 * (155.3 - d_mm) / (155.3 * d_mm)) * 180.0 / M_PI;
}

double TimeS(Time t) { return ToSeconds(t) - SimWorld::kStartTimeS; }
Time RobotTime(double path_s) { return TimeFromSeconds(path_s + SimWorld::kStartTimeS); }

}  // namespace

bool SimConfig::IsValid(std::string* error) const {
  if (!scene.IsValid(error)) return false;
  if (scene.boxes().empty()) {
    *error = "scene has no boxes";
    return false;
  }
  if (!geometry.IsValid(error)) return false;
  if (!Finite({mounting_error.alpha, mounting_error.beta, mounting_error.gamma})) {
    *error = "mounting error angles must be finite";
    return false;
  }
  const LidarSpec& l = lidar;
  if (!Finite({l.scan_rate_hz, l.sample_rate_hz, l.min_range_m, l.max_range_m, l.range_noise_m,
               l.range_noise_fraction, l.range_quantum_m, l.dropout_probability,
               l.grazing_dropout_start_deg, l.grazing_dropout_end_deg, l.range_offset_m,
               l.time_offset_s, l.range_scale_error, l.mixed_return_share, l.mixed_blend_share,
               l.mixed_footprint_rad, l.mixed_min_jump_m}) ||
      std::abs(l.range_offset_m) > 0.1 || std::abs(l.time_offset_s) > 0.1 ||
      std::abs(l.range_scale_error) > 0.05 || l.mixed_return_share < 0 ||
      l.mixed_return_share > 1 || l.mixed_blend_share < 0 || l.mixed_blend_share > 1 ||
      l.mixed_footprint_rad < 0 || l.mixed_footprint_rad > 0.1 || l.mixed_min_jump_m <= 0 ||
      l.scan_rate_hz <= 0 || l.sample_rate_hz <= 0 || l.sample_rate_hz < 10 * l.scan_rate_hz ||
      l.min_range_m < 0 || l.max_range_m <= l.min_range_m || l.range_noise_m < 0 ||
      l.range_noise_fraction < 0 || l.range_quantum_m < 0 || l.dropout_probability < 0 ||
      l.dropout_probability > 1 || l.grazing_dropout_end_deg <= l.grazing_dropout_start_deg) {
    *error =
        "lidar: rates must be positive (at least 10 samples per scan), 0 <= min_range < "
        "max_range, noise >= 0, dropout within [0, 1], grazing start < end, |range offset| and "
        "|time offset| <= 0.1, |range scale error| <= 0.05, mixed shares within [0, 1], "
        "footprint within [0, 0.1] rad, mixed jump > 0";
    return false;
  }
  if (!Finite({imu.rate_hz, imu.gyro_noise_rad_s, imu.gyro_bias_rad_s, imu.tilt_noise_rad,
               imu.yaw_noise_rad, imu.yaw_reference_offset_rad}) ||
      imu.rate_hz <= 0 || imu.gyro_noise_rad_s < 0 || imu.tilt_noise_rad < 0 ||
      imu.yaw_noise_rad < 0) {
    *error = "imu: rate must be positive and noise non-negative";
    return false;
  }
  if (!Finite({odometry.rate_hz, odometry.scale_error_left, odometry.scale_error_right,
               odometry.speed_noise_mps}) ||
      odometry.rate_hz <= 0 || odometry.speed_noise_mps < 0 || odometry.scale_error_left <= -1 ||
      odometry.scale_error_right <= -1) {
    *error = "odometry: rate must be positive, noise non-negative, scale errors > -1";
    return false;
  }
  for (size_t i = 0; i < slips.size(); ++i) {
    const SlipEvent& s = slips[i];
    if (!Finite({s.start_s, s.duration_s, s.extra}) || s.start_s < 0 || s.duration_s < 0 ||
        s.extra <= -1) {
      *error = "slip " + std::to_string(i) + ": start and duration must be >= 0, extra > -1";
      return false;
    }
  }
  if (!Finite({start.x, start.y, start.yaw})) {
    *error = "start pose must be finite";
    return false;
  }
  if (path.empty()) {
    *error = "path has no segments";
    return false;
  }
  for (size_t i = 0; i < path.size(); ++i) {
    const DriveSegment& s = path[i];
    if (!Finite({s.v, s.w, s.duration_s}) || s.duration_s <= 0) {
      *error = "path segment " + std::to_string(i) + ": v and w must be finite, duration > 0";
      return false;
    }
  }
  return true;
}

double SimConfig::DurationSeconds() const {
  double d = 0.0;
  for (const auto& s : path) d += s.duration_s;
  return d;
}

Trajectory::Trajectory(const Pose2d& start, const std::vector<DriveSegment>& segments)
    : segments_(segments) {
  Pose2d p = start;
  double t = 0.0;
  for (const DriveSegment& s : segments_) {
    starts_s_.push_back(t);
    start_poses_.push_back(p);
    p = IntegrateExact(p, {s.v, s.w}, s.duration_s);
    t += s.duration_s;
  }
  end_pose_ = p;
  end_s_ = t;
  if (segments_.empty()) end_pose_ = start;
}

size_t Trajectory::SegmentAt(double t_s) const {
  const auto it = std::upper_bound(starts_s_.begin(), starts_s_.end(), t_s);
  return it == starts_s_.begin() ? 0 : static_cast<size_t>(it - starts_s_.begin()) - 1;
}

Pose2d Trajectory::PoseAt(double t_s) const {
  if (segments_.empty()) return end_pose_;
  if (!open_ && t_s >= end_s_) return end_pose_;
  if (t_s <= 0.0) return start_poses_.front();
  const size_t i = SegmentAt(t_s);
  return IntegrateExact(start_poses_[i], {segments_[i].v, segments_[i].w}, t_s - starts_s_[i]);
}

Twist2d Trajectory::TwistAt(double t_s) const {
  if (segments_.empty() || t_s < 0.0 || (!open_ && t_s >= end_s_)) return {};
  const DriveSegment& s = segments_[SegmentAt(t_s)];
  return {s.v, s.w};
}

void Trajectory::CommandTwist(double t_s, const Twist2d& twist) {
  constexpr double kOpen = std::numeric_limits<double>::infinity();
  t_s = std::max(t_s, 0.0);
  if (!open_ && t_s >= end_s_) {
    // Past (or without) a fixed path: stand at its end until t_s.
    if (t_s > end_s_ || segments_.empty()) {
      starts_s_.push_back(end_s_);
      start_poses_.push_back(end_pose_);
      segments_.push_back({0.0, 0.0, t_s - end_s_});
    }
  } else {
    const size_t i = SegmentAt(t_s);
    segments_.resize(i + 1);
    starts_s_.resize(i + 1);
    start_poses_.resize(i + 1);
    segments_[i].duration_s = t_s - starts_s_[i];
  }
  // A zero-length segment at t_s is replaced rather than kept, so
  // SegmentAt() never lands on one.
  if (!segments_.empty() && segments_.back().duration_s <= 0.0) {
    segments_.pop_back();
    starts_s_.pop_back();
    start_poses_.pop_back();
  }
  const Pose2d p = segments_.empty() ? end_pose_ : PoseAtClosed(segments_.size() - 1, t_s);
  starts_s_.push_back(t_s);
  start_poses_.push_back(p);
  segments_.push_back({twist.v, twist.w, kOpen});
  end_pose_ = p;  // Unused while open; keeps a sane value.
  end_s_ = kOpen;
  open_ = true;
}

Pose2d Trajectory::PoseAtClosed(size_t i, double t_s) const {
  return IntegrateExact(start_poses_[i], {segments_[i].v, segments_[i].w}, t_s - starts_s_[i]);
}

SimWorld::SimWorld(const SimConfig& config, DriveMode mode)
    : config_(config),
      drive_mode_(mode),
      trajectory_(config.start,
                  mode == DriveMode::kPath ? config.path : std::vector<DriveSegment>()),
      produced_until_(RobotTime(0.0) - Duration(1)),
      body_from_lidar_true_(BodyFromLidar(config.geometry, config.mounting_error)),
      lidar_rng_(config.seed * 3 + 1),
      imu_rng_(config.seed * 3 + 2),
      wheel_rng_(config.seed * 3 + 3) {
  if (mode == DriveMode::kCommanded) trajectory_.CommandTwist(0.0, Twist2d());
}

Time SimWorld::end_time() const {
  return drive_mode_ == DriveMode::kCommanded ? Time::max() : RobotTime(duration_s());
}

bool SimWorld::CommandTwist(Time t, const Twist2d& twist) {
  if (drive_mode_ != DriveMode::kCommanded) return false;
  t = std::max(t, produced_until_ + Duration(1));
  trajectory_.CommandTwist(TimeS(t), twist);
  return true;
}

double SimWorld::LidarPhase(const LidarSpec& spec, int64_t sample_index) {
  const double t_s = static_cast<double>(sample_index) / spec.sample_rate_hz;
  return std::fmod(spec.scan_rate_hz * t_s, 1.0);
}

bool SimWorld::IsLidarRingStart(const LidarSpec& spec, int64_t sample_index) {
  return sample_index == 0 || LidarPhase(spec, sample_index) < LidarPhase(spec, sample_index - 1);
}

Rigid3d SimWorld::TrueWorldFromBody(Time t) const {
  const Pose2d p = trajectory_.PoseAt(TimeS(t));
  return Rigid3d::FromPose(p.x, p.y, 0.0, 0.0, 0.0, p.yaw);
}

Rigid3d SimWorld::TrueWorldFromLidar(Time t) const {
  return TrueWorldFromBody(t) * body_from_lidar_true_;
}

void SimWorld::RunUntil(Time t, SensorSink* sink) {
  const Time until = std::min(t, end_time());
  EmitWheels(until, sink);
  EmitImu(until, sink);
  EmitLidar(until, sink);
  produced_until_ = std::max(produced_until_, until);
  if (t >= end_time()) finished_ = true;
}

SensorLog SimWorld::RunAll() {
  SensorLogCollector collector;
  RunUntil(drive_mode_ == DriveMode::kCommanded ? produced_until_ : end_time(), &collector);
  return std::move(*collector.log());
}

void SimWorld::EmitLidar(Time until, SensorSink* sink) {
  const LidarSpec& spec = config_.lidar;
  const double until_s = TimeS(until);
  const double cos_start = std::cos(spec.grazing_dropout_start_deg * M_PI / 180.0);
  const double start_rad = spec.grazing_dropout_start_deg * M_PI / 180.0;
  const double span_rad = (spec.grazing_dropout_end_deg - spec.grazing_dropout_start_deg) * M_PI / 180.0;
  for (;;) {
    const double t_s = static_cast<double>(next_lidar_sample_) / spec.sample_rate_hz;
    if (t_s > until_s) break;
    // The head turns at scan_rate_hz; phase in [0, 1) of a revolution.
    const double phase = LidarPhase(spec, next_lidar_sample_);
    const bool ring_start = next_lidar_sample_ == 0 || phase < last_phase_;
    if (ring_start && next_lidar_sample_ > 0) ++scan_index_;
    if (ring_start) beam_ = 0;
    last_phase_ = phase;
    ++next_lidar_sample_;

    const Time time = RobotTime(t_s);
    const double encoder_deg = phase * 360.0;
    const LidarAngleConvention& convention = spec.angle_convention;
    // Measured at t + time_offset_s, stamped t.
    const Rigid3d world_from_lidar =
        spec.time_offset_s == 0.0 ? TrueWorldFromLidar(time)
                                  : TrueWorldFromLidar(RobotTime(t_s + spec.time_offset_s));
    RayHit hit;
    SampleTruth truth;
    double range = 0.0;
    double theta = convention.ThetaFromX4Degrees(encoder_deg);
    Eigen::Vector3d dir = world_from_lidar.rotation() * LidarPoint(1.0, theta);
    bool found = false;
    // The laser line's first surface (angle correction only), whether the
    // centre sees it or not.
    RayHit laser;
    Eigen::Vector3d laser_point;
    bool laser_found = false;
    if (!spec.model_angle_correction) {
      found = config_.scene.Cast(world_from_lidar.translation(), dir, 1e-6, spec.max_range_m, &hit);
    } else {
      // The X4 triangulates: its laser leaves the head beside the rotation
      // axis, so at one encoder angle the beam is a fixed line that misses
      // the centre, and a return at distance d lies at encoder + c(d) seen
      // from the centre. The correction is that line: tan c(d) = 21.8/d -
      // 21.8/155.3 (d in mm) is a line 21.6 mm from the centre, to within
      // 0.13 mm between 0.12 and 10 m (0.9 mm from 0.05 m). The device
      // measures the first surface along it, so: cast along the chord of
      // c(d) between those ranges to find that surface, then solve the fixed
      // point d = range(encoder + c(d)) on it (2-3 steps; c changes slowly
      // along a surface). A return whose fixed point leaves that surface is
      // shadowed from the centre's view (a depth edge) and is lost, like
      // the X4's mixed returns at edges. Iterating from the bare encoder
      // angle instead lands at a depth edge on whichever surface the first
      // guess hits: the far one at one end of a board and the near one at
      // the other, which shifted fitted target edges by half a beam step
      // (docs/calibration.md, "Refined corners").
      if (CastLaserLine(encoder_deg, world_from_lidar, &laser, &laser_point)) {
        laser_found = true;
        const Eigen::Vector3d centre = world_from_lidar.translation();
        const double first_range = laser.range;
        double previous = first_range;
        for (int k = 0; k < 5; ++k) {
          theta = convention.ThetaFromX4Degrees(encoder_deg + X4AngleCorrectionDeg(previous * 1e3));
          dir = world_from_lidar.rotation() * LidarPoint(1.0, theta);
          if (!config_.scene.Cast(centre, dir, 1e-6, spec.max_range_m, &hit) ||
              std::abs(hit.range - first_range) > 0.01) {
            break;
          }
          if (std::abs(hit.range - previous) < 1e-4) {
            found = true;
            break;
          }
          previous = hit.range;
        }
      }
    }
    // With mixed returns, a beam whose own return is lost to the centre's
    // shadow may still straddle the edge that casts the shadow (MixedRange,
    // "Shadowed laser returns"): it reports only if drawn as mixed.
    const bool shadowed = !found && laser_found && spec.mixed_return_share > 0.0;
    if (shadowed) {
      hit = laser;
      dir = (laser_point - world_from_lidar.translation()).normalized();
    }
    if (found || shadowed) {
      truth.primitive = hit.primitive;
      truth.face = hit.face;
      truth.true_range = hit.range;
      const double cos_inc = std::abs(hit.normal.dot(dir));
      double p_keep = (1.0 - spec.dropout_probability) *
                      (1.0 - config_.scene.boxes()[hit.primitive].dropout);
      if (cos_inc < cos_start) {
        const double inc = std::acos(std::clamp(cos_inc, 0.0, 1.0));
        p_keep *= std::clamp(1.0 - (inc - start_rad) / span_rad, 0.0, 1.0);
      }
      double measured = hit.range;
      if (spec.mixed_return_share > 0.0) {
        measured = MixedRange(hit, world_from_lidar.translation() + hit.range * dir, encoder_deg,
                              world_from_lidar, &truth);
      }
      if (shadowed && !truth.mixed) {
        // Lost, as without mixed returns; the truth keeps the straddle only.
        truth.primitive = truth.face = -1;
        truth.true_range = 0.0;
      } else {
        const double sigma = std::hypot(spec.range_noise_m, spec.range_noise_fraction * measured);
        const double noisy = measured * (1.0 + spec.range_scale_error) + spec.range_offset_m +
                             sigma * lidar_gauss_(lidar_rng_);
        const bool kept = lidar_uniform_(lidar_rng_) < p_keep;
        if (kept && noisy >= spec.min_range_m && noisy <= spec.max_range_m) {
          range = spec.range_quantum_m > 0.0
                      ? std::round(noisy / spec.range_quantum_m) * spec.range_quantum_m
                      : noisy;
        }
      }
    }
    if (keep_truth_) sample_truth_.push_back(truth);
    // The device reports the encoder angle and the measured distance; the
    // direction a decoder computes from them uses the measured (noisy,
    // quantised) distance, so report exactly that.
    if (spec.model_angle_correction) {
      theta = convention.ThetaFromX4Degrees(encoder_deg + (range > 0.0 ? X4AngleCorrectionDeg(range * 1e3) : 0.0));
    }
    LidarSample s;
    s.time = time;
    s.range_m = static_cast<float>(range);
    s.theta = static_cast<float>(theta);
    s.beam = beam_++;
    sink->OnLidarSample(scan_index_, ring_start, s);
  }
}

bool SimWorld::CastLaserLine(double encoder_deg, const Rigid3d& world_from_lidar, RayHit* hit,
                             Eigen::Vector3d* point) const {
  const LidarSpec& spec = config_.lidar;
  const auto at = [&](double d_m) {
    return world_from_lidar *
           LidarPoint(d_m, spec.angle_convention.ThetaFromX4Degrees(
                               encoder_deg + X4AngleCorrectionDeg(d_m * 1e3)));
  };
  const Eigen::Vector3d near = at(std::max(spec.min_range_m, 0.05));
  const Eigen::Vector3d chord = at(spec.max_range_m) - near;
  const Eigen::Vector3d u = chord.normalized();
  if (!config_.scene.Cast(near, u, 1e-6, chord.norm(), hit)) return false;
  *point = near + hit->range * u;
  hit->range = (*point - world_from_lidar.translation()).norm();
  return true;
}

// The spot, and what the device reports for the part of it on the other
// surface (issue 32).
//
// Geometry. At encoder angle phi the X4's laser is the line
//   L(phi) = { the point at distance d from the centre o, at angle phi + c(d) },
//   tan c(d) = 21.8/d - 21.8/155.3 (mm),
// 21.6 mm beside o (EmitLidar). The camera turns with the laser and images
// the spot; the device turns the image's position into the distance d of
// the point of L(phi) it would come from, and a decoder puts a return of
// range d at phi + c(d) seen from o: the point of L(phi) at distance d.
//
// The spot's sides. The footprint f (mixed_footprint_rad, by default one
// beam step, 0.504 deg) is what the head turns during one sample: over the
// exposure the laser sweeps L(phi - f/2) .. L(phi + f/2), the line turned
// about o; turned about its own emitter instead, 21.6 mm from o, the lines
// differ by at most 21.6 mm * f/2 = 0.1 mm. So the sides are the laser's
// lines L(phi +- f/2), cast like the beam itself (CastLaserLine). Until
// 2026-11-27 they were rays from o at +-f/2 about the centre's ray through
// the beam's hit. At a depth edge that ray is the wrong line: from the wall
// 16 cm behind the lab's board at 0.7 m, o's ray crosses the board's plane
// where the laser of encoder phi + c(d_wall) - c(d_board) does, and
// c(d_board) - c(d_wall) ~ 21.8 mm (1/d_board - 1/d_wall) = 5.8 mrad, about
// 2/3 of f: the straddle window sat off the spot by that, and on the near
// pass of the lab's diamond (p = 1, one turn) half the lines' ends had no
// straddling beam and a fifth or less were long
// (EdgeEffectsSimTest.OtherSurfaceReturnsStraddleBothEndsOfALine).
//
// The range reported. While the laser is at L(phi + a) (|a| <= f/2) the
// camera, turning with it, sees the spot on that line and ranges it
// exactly: a part q of the spot on the other surface reads d_q = |q - o|.
// (A spot part beside the laser's line with the camera held still would
// instead read about d (1 + delta / b), delta its lateral offset, b ~ 22 mm
// the baseline: 10 cm at 0.7 m for delta = d f/2. That is a spot's width
// from the laser's divergence, which this model does not draw.) The decoder
// puts d_q on L(phi): at q' = q turned about o by -a (the same distance
// from o, on the line turned back), so
//   |q' - q| = 2 d_q sin(|a| / 2) ~ d_q |a|, along t, the tangent of the
//   scan plane at q (perpendicular to o's ray),
//   off the other surface's plane (normal n) by  d_q |a| |n . t|.
// The simulator reports the side's range (|a| = f/2): on the lab diamond the
// board and the scan plane are vertical and n is horizontal, so
// |n . t| = sin(e) |n . h| (e the ray's elevation, h its horizontal heading),
// and a long return lies d_q f/2 sin(e) |n . h| off the board's plane.
// Measured (noise-free, the test above): 4.2-5.6 mm near and 4.4-5.8 mm far
// on the upper edges, as modelled to 0.1 mm (d f/2 is 4-7 mm near, 11-12 mm
// far; sin(e) is larger near); 2.5-7.2 mm on the lower edges, whose sides
// can hit the board's 5 mm edge face. Within the board fit's band (2.5 sigma:
// ~5.5 mm near, ~13 mm far) the far ones all; the near ones lie at its edge,
// so with the range noise some fall out of their line. The same holds for a
// short return off the background's plane. (An earlier try along the laser's
// line, not kept, put its long returns 3-9 mm off near, which is this plus
// the range noise, but up to 33 mm off far, which nothing here explains.)
//
// Shadowed laser returns. The camera sees from o (EmitLidar's fixed point):
// a beam whose laser passes just beyond a board's edge can hit a background
// that the board hides from o (within c(d_board) - c(d_wall), 2/3 of a
// step, beyond one end of each near line), and EmitLidar loses it. Its spot's
// side on the board is in view, so with mixed returns on such a beam is an
// edge beam like any other, reporting only if drawn as mixed. Without this,
// the near pass's upper ends had 7 long lines of 46 instead of 30, the far
// pass's lower ends 20 of 45 instead of 25 (the test above). Whether o
// sees a side's other surface is not asked, so that the shares
// mixed_return_share and mixed_blend_share hold at both ends of a line alike;
// a camera that cannot see the background part beyond one edge would make
// the short returns at that end rarer. Likewise a shadowed beam drawn as a
// blend blends the hidden range in.
double SimWorld::MixedRange(const RayHit& hit, const Eigen::Vector3d& p, double encoder_deg,
                            const Rigid3d& world_from_lidar, SampleTruth* truth) {
  const LidarSpec& spec = config_.lidar;
  const double range = hit.range;
  // A side is across a depth edge when its hit lies off the beam's surface
  // by more than mixed_min_jump_m: a floor seen at grazing incidence changes
  // range fast with angle but stays on its plane, and a room's concave
  // corner is off it by millimetres; and its range differs by more than that
  // too (a board's convex corner, front face beside edge face, is continuous
  // in range). Without the angle correction the laser passes through o, and
  // its lines are o's rays.
  const Eigen::Vector3d o = world_from_lidar.translation();
  const double half_deg = 0.5 * spec.mixed_footprint_rad * 180.0 / M_PI;
  double other = range, jump = spec.mixed_min_jump_m;
  for (double side : {-1.0, 1.0}) {
    RayHit h;
    Eigen::Vector3d q;
    if (spec.model_angle_correction) {
      if (!CastLaserLine(encoder_deg + side * half_deg, world_from_lidar, &h, &q)) continue;
    } else {
      const Eigen::Vector3d d =
          world_from_lidar.rotation() *
          LidarPoint(1.0, spec.angle_convention.ThetaFromX4Degrees(encoder_deg + side * half_deg));
      if (!config_.scene.Cast(o, d, 1e-6, spec.max_range_m, &h)) continue;
      q = o + h.range * d;
    }
    const double off = std::abs(hit.normal.dot(q - p));
    if (off > jump && std::abs(h.range - range) > spec.mixed_min_jump_m) jump = off, other = h.range;
  }
  if (other == range) return range;
  truth->edge = true;
  truth->other_range = other;
  if (!(lidar_uniform_(lidar_rng_) < spec.mixed_return_share)) return range;
  truth->mixed = true;
  if (lidar_uniform_(lidar_rng_) < spec.mixed_blend_share) {
    return range + lidar_uniform_(lidar_rng_) * (other - range);
  }
  return other;
}

void SimWorld::TrueWheelSpeeds(double t0_s, double t1_s, double* left, double* right) const {
  const double d = config_.geometry.wheel_distance_m;
  if (t1_s <= t0_s) {
    const Twist2d tw = trajectory_.TwistAt(t0_s);
    WheelsFromTwist(tw, d, left, right);
    return;
  }
  // Exact mean of a piecewise-constant twist: integrate segment by segment.
  double dl = 0.0, dr = 0.0, t = 0.0;
  for (const DriveSegment& s : trajectory_.segments()) {
    const double a = std::max(t0_s, t), b = std::min(t1_s, t + s.duration_s);
    if (b > a) {
      dl += (s.v - s.w * d) * (b - a);
      dr += (s.v + s.w * d) * (b - a);
    }
    t += s.duration_s;
    if (t >= t1_s) break;
  }
  *left = dl / (t1_s - t0_s);
  *right = dr / (t1_s - t0_s);
}

void SimWorld::EmitWheels(Time until, SensorSink* sink) {
  const OdometrySpec& spec = config_.odometry;
  const double until_s = TimeS(until);
  for (;;) {
    const double t1 = static_cast<double>(next_wheel_tick_) / spec.rate_hz;
    if (t1 > until_s) break;
    // Tick 0 (time 0) reports the instantaneous speeds; it only starts the odometry.
    const double t0 = next_wheel_tick_ == 0 ? t1 : t1 - 1.0 / spec.rate_hz;
    ++next_wheel_tick_;
    double left, right;
    TrueWheelSpeeds(t0, t1, &left, &right);
    double slip_left = 0.0, slip_right = 0.0;
    const double mid = 0.5 * (t0 + t1);
    for (const SlipEvent& s : config_.slips) {
      if (mid >= s.start_s && mid < s.start_s + s.duration_s) (s.left ? slip_left : slip_right) += s.extra;
    }
    WheelSpeedMeasurement m;
    m.time = RobotTime(t1);
    // A wheel at rest turns its encoder by no tick: it reads exactly 0. The
    // noise is drawn either way, so a standstill leaves the random stream
    // (and every later record) as it was.
    const double noise_left = spec.speed_noise_mps * wheel_gauss_(wheel_rng_);
    const double noise_right = spec.speed_noise_mps * wheel_gauss_(wheel_rng_);
    m.left_mps = left == 0.0 ? 0.0
                             : left * (1.0 + spec.scale_error_left) * (1.0 + slip_left) + noise_left;
    m.right_mps = right == 0.0
                      ? 0.0
                      : right * (1.0 + spec.scale_error_right) * (1.0 + slip_right) + noise_right;
    sink->OnWheels(m);
  }
}

void SimWorld::EmitImu(Time until, SensorSink* sink) {
  const ImuSpec& spec = config_.imu;
  const double until_s = TimeS(until);
  for (;;) {
    const double t = static_cast<double>(next_imu_tick_) / spec.rate_hz;
    if (t > until_s) break;
    ++next_imu_tick_;
    const Pose2d p = trajectory_.PoseAt(t);
    ImuMeasurement m;
    m.time = RobotTime(t);
    m.gyro_z = trajectory_.TwistAt(t).w + spec.gyro_bias_rad_s + spec.gyro_noise_rad_s * imu_gauss_(imu_rng_);
    m.roll = spec.tilt_noise_rad * imu_gauss_(imu_rng_);
    m.pitch = spec.tilt_noise_rad * imu_gauss_(imu_rng_);
    m.yaw = WrapAngle(p.yaw + spec.yaw_reference_offset_rad + spec.yaw_noise_rad * imu_gauss_(imu_rng_));
    sink->OnImu(m);
  }
}

PoseBuffer SimWorld::TruthPoses(double rate_hz) const {
  PoseBuffer buffer;
  const double duration =
      drive_mode_ == DriveMode::kCommanded ? std::max(0.0, TimeS(produced_until_)) : duration_s();
  const int64_t n = static_cast<int64_t>(std::ceil(duration * rate_hz));
  for (int64_t i = 0; i <= n; ++i) {
    const double t = std::min(static_cast<double>(i) / rate_hz, duration);
    buffer.Add(RobotTime(t), TrueWorldFromBody(RobotTime(t)));
  }
  return buffer;
}

void SensorLogCollector::OnLidarSample(uint32_t scan_index, bool ring_start, const LidarSample& s) {
  if (ring_start || log_.scans.empty()) {
    log_.scans.emplace_back();
    log_.scans.back().index = scan_index;
  }
  log_.scans.back().samples.push_back(s);
}

}  // namespace sweepscan::sim
