// The simulated world: a differential-drive robot following a path of
// (v, w, duration) segments through a Scene, with an X4-like lidar, a
// HI219-like IMU and wheel encoders, all seeded and with ground truth kept.
//
// Ground truth is exact: the path is piecewise constant (v, w), so the true
// pose at any time is the closed-form arc (IntegrateExact), and each lidar
// sample is cast from the true lidar pose at that sample's own time.
//
// Error models (defaults follow the seed paper's Table 2 and the X4 data sheet):
//  * wheel encoders: per-wheel scale error (the paper: 1 % per metre),
//    white speed noise, and slip events in which one wheel's encoder reads
//    (1 + extra) times what the wheel actually rolled;
//  * IMU: white gyro noise plus a constant bias; roll and pitch white noise
//    (0.3 deg); yaw white noise (0.5 deg) in a heading reference rotated by
//    a fixed offset from the world's;
//  * lidar: Gaussian range noise sigma = sqrt(a^2 + (b rho)^2), quantised to
//    the X4's 1 mm, returns lost at random, more at grazing incidence
//    and on dark surfaces, and none outside 0.12-10 m; optionally a range
//    offset and scale error and mixed returns at depth edges (off by
//    default).
//
// Not thread-safe; one world per thread.
#ifndef SWEEPSCAN_CORE_SIM_WORLD_H_
#define SWEEPSCAN_CORE_SIM_WORLD_H_

#include <random>
#include <string>
#include <vector>

#include "core/pose/odometry.h"
#include "core/pose/pose_buffer.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "core/sim/scene.h"

namespace sweepscan::sim {

struct LidarSpec {
  double scan_rate_hz = 7.0;
  double sample_rate_hz = 5000.0;
  double min_range_m = 0.12;
  double max_range_m = 10.0;
  double range_noise_m = 0.002;        // a
  double range_noise_fraction = 0.002;  // b
  double range_quantum_m = 0.001;      // X4 distance unit: Si >> 2 is whole millimetres
  // Systematic errors (docs/scenario-format.md; the calibration's
  // robustness sweep draws them): a constant added to every range (the
  // X4's zero offset), and a clock offset: the sample stamped t is measured
  // at t + time_offset_s (a late or early time stamp of the lidar against
  // the IMU and the wheels).
  double range_offset_m = 0.0;
  double time_offset_s = 0.0;
  // Range scale error: every range reads (1 + range_scale_error) times the
  // truth, before the offset and the noise (a triangulation lidar's baseline
  // or focal length off by that fraction). Within +-0.01 (the X4 data
  // sheet's relative accuracy: 1 % beyond 2 m).
  double range_scale_error = 0.0;
  // Mixed returns at depth edges. A triangulation lidar's spot has a width;
  // where it straddles a depth edge the sensor sees light from both
  // surfaces and reports a blend of their ranges, or the other surface's
  // range at this beam's angle. A beam is an edge beam when its laser at
  // encoder angles +-mixed_footprint_rad / 2 about its own (the spot's
  // extent, swept by the head during the sample; default one beam step,
  // 0.504 deg at 5 kHz / 7 Hz, so about one beam per edge crossing; with
  // model_angle_correction the laser's line, 21.6 mm off the centre, else
  // the centre's ray) hits a surface more than mixed_min_jump_m off the
  // beam's own surface
  // (its plane: a floor at grazing incidence is no edge) and differ in
  // range by more than that. A share `mixed_return_share` of the edge beams report
  // a mixed range: of those, `mixed_blend_share` a blend r + w (r_other - r)
  // with w ~ U(0, 1), the rest r_other. 0 (the default): no mixed returns,
  // and no random numbers drawn for them.
  double mixed_return_share = 0.0;
  double mixed_blend_share = 0.5;
  double mixed_footprint_rad = 0.0088;
  double mixed_min_jump_m = 0.03;
  double dropout_probability = 0.01;
  double grazing_dropout_start_deg = 70.0;  // incidence beyond which returns fade out
  double grazing_dropout_end_deg = 88.0;    // all lost beyond this
  LidarAngleConvention angle_convention;
  // Model the X4's triangulation geometry (device-protocols.md, "second-level
  // correction"): the head's encoder angle advances linearly in time, and a
  // return at distance d really comes from encoder angle + atan(21.8 (155.3 -
  // d) / (155.3 d)). The simulator casts along that corrected direction, so
  // the bytes it emits decode to the same angles a real X4's would.
  bool model_angle_correction = true;
};

struct ImuSpec {
  double rate_hz = 100.0;
  double gyro_noise_rad_s = 0.003;
  double gyro_bias_rad_s = 0.0005;
  double tilt_noise_rad = 0.0052;   // 0.3 deg
  double yaw_noise_rad = 0.0087;    // 0.5 deg
  double yaw_reference_offset_rad = 0.7;  // IMU heading of the world's +x axis
};

struct OdometrySpec {
  double rate_hz = 50.0;
  double scale_error_left = 0.005;
  double scale_error_right = -0.005;
  double speed_noise_mps = 0.002;
};

struct SlipEvent {
  double start_s = 0.0;
  double duration_s = 0.0;
  bool left = true;       // which wheel's encoder over-reads
  double extra = 0.0;     // encoder reads (1 + extra) x the true wheel speed
};

struct DriveSegment {
  double v = 0.0;         // m/s
  double w = 0.0;         // rad/s
  double duration_s = 0.0;
};

struct SimConfig {
  std::string name;
  uint64_t seed = 1;
  Scene scene;
  RobotGeometry geometry;
  MountingError mounting_error;  // the true one, which the calibration should recover
  LidarSpec lidar;
  ImuSpec imu;
  OdometrySpec odometry;
  std::vector<SlipEvent> slips;
  Pose2d start;
  std::vector<DriveSegment> path;

  bool IsValid(std::string* error) const;
  double DurationSeconds() const;
};

// Piecewise-constant (v, w) path with its exact pose. Either a fixed path
// (the scenario's segments; the robot stands at the end pose afterwards) or,
// after CommandTwist, open-ended: the last segment lasts until the next
// command, so live commands keep the pose exact (closed-form arcs).
class Trajectory {
 public:
  Trajectory(const Pose2d& start, const std::vector<DriveSegment>& segments);
  // Infinite once open-ended.
  double duration_s() const { return starts_s_.empty() ? 0.0 : end_s_; }
  Pose2d PoseAt(double t_s) const;
  Twist2d TwistAt(double t_s) const;

  // From t_s on (path time, clamped to >= 0) the robot drives `twist` until
  // the next call: the segment holding t_s ends there, later ones are
  // dropped, and the trajectory becomes open-ended. Past the end of a fixed
  // path the robot stands still until t_s.
  void CommandTwist(double t_s, const Twist2d& twist);
  bool open_ended() const { return open_; }
  // The segments and their start times (an open-ended last segment has an
  // infinite duration).
  const std::vector<DriveSegment>& segments() const { return segments_; }
  const std::vector<double>& segment_starts_s() const { return starts_s_; }

 private:
  size_t SegmentAt(double t_s) const;
  Pose2d PoseAtClosed(size_t i, double t_s) const;  // Within segment i, whatever its length.
  std::vector<DriveSegment> segments_;
  std::vector<double> starts_s_;
  std::vector<Pose2d> start_poses_;
  Pose2d end_pose_;
  double end_s_ = 0.0;
  bool open_ = false;
};

// Receives simulated records as the world produces them. Within each stream
// records arrive in time order.
class SensorSink {
 public:
  virtual ~SensorSink() = default;
  virtual void OnWheels(const WheelSpeedMeasurement& m) = 0;
  virtual void OnImu(const ImuMeasurement& m) = 0;
  // `ring_start` is true for the first sample of a new revolution.
  virtual void OnLidarSample(uint32_t scan_index, bool ring_start, const LidarSample& s) = 0;
};

// Ground truth of one lidar sample (for tests): what it hit.
struct SampleTruth {
  int primitive = -1;
  int face = -1;
  double true_range = 0.0;
  // Mixed returns (LidarSpec::mixed_return_share > 0 only): whether the
  // beam straddles a depth edge, the other surface's range there, and
  // whether this sample reports a mixed range. A beam whose laser return
  // the centre cannot see (lost, primitive -1) may still straddle; if it
  // reports a mixed range, primitive and true_range are its laser's hit.
  bool edge = false;
  bool mixed = false;
  double other_range = 0.0;
};

class SimWorld {
 public:
  // kPath: the robot follows config.path and the world finishes at its end.
  // kCommanded: config.path is ignored; the robot stands at config.start
  // until CommandTwist moves it, and the world never finishes (the device
  // simulator's motor board drives it).
  enum class DriveMode { kPath, kCommanded };
  explicit SimWorld(const SimConfig& config, DriveMode mode = DriveMode::kPath);
  DriveMode drive_mode() const { return drive_mode_; }

  const SimConfig& config() const { return config_; }
  const Trajectory& trajectory() const { return trajectory_; }
  double duration_s() const { return trajectory_.duration_s(); }
  // Robot time of the path's start; the simulated robot clock starts at 1 s
  // so that no record carries time zero.
  static constexpr double kStartTimeS = 1.0;

  Rigid3d TrueWorldFromBody(Time t) const;
  Rigid3d TrueWorldFromLidar(Time t) const;

  // Produces every record with time <= t, in time order per stream.
  void RunUntil(Time t, SensorSink* sink);
  bool finished() const { return finished_; }
  // The path's end; Time::max() in kCommanded mode.
  Time end_time() const;
  // The latest time given to RunUntil (records up to it exist); start time
  // minus 1 ns before the first call.
  Time produced_until() const { return produced_until_; }

  // kCommanded only (returns false otherwise): from robot time t on the
  // robot drives `twist`. Records already produced are never rewritten: a t
  // at or before produced_until() takes effect 1 ns after it.
  bool CommandTwist(Time t, const Twist2d& twist);

  // Sample n's head phase in [0, 1) of a revolution, and whether sample n
  // starts a revolution: the exact rule EmitLidar uses, so a device
  // emulation can know in advance where the next revolution starts.
  static double LidarPhase(const LidarSpec& spec, int64_t sample_index);
  static bool IsLidarRingStart(const LidarSpec& spec, int64_t sample_index);

  // Runs the whole path and collects the records (offline; kPath only, in
  // kCommanded mode it runs to produced_until()).
  SensorLog RunAll();
  // Ground truth of each produced lidar sample when enabled (before running).
  void KeepSampleTruth(bool keep) { keep_truth_ = keep; }
  const std::vector<SampleTruth>& sample_truth() const { return sample_truth_; }

  // The true body poses sampled at `rate_hz`, for reconstruction from truth
  // (kCommanded: up to produced_until()).
  PoseBuffer TruthPoses(double rate_hz) const;

 private:
  void EmitLidar(Time until, SensorSink* sink);
  void EmitWheels(Time until, SensorSink* sink);
  void EmitImu(Time until, SensorSink* sink);
  // The first surface along the X4's laser line at `encoder_deg`
  // (LidarSpec::model_angle_correction): `hit` with its range measured from
  // the lidar's centre, `point` in the world. Whether the centre sees it is
  // not asked (EmitLidar's fixed point does that).
  bool CastLaserLine(double encoder_deg, const Rigid3d& world_from_lidar, RayHit* hit,
                     Eigen::Vector3d* point) const;
  // The range an edge beam reports (LidarSpec's mixed returns): hit.range
  // if the spot of the beam at `encoder_deg` (its laser's surface `hit`, at
  // `point`) does not straddle a depth edge or is not drawn as mixed; fills
  // the truth's edge fields.
  double MixedRange(const RayHit& hit, const Eigen::Vector3d& point, double encoder_deg,
                    const Rigid3d& world_from_lidar, SampleTruth* truth);
  // Mean left/right wheel speeds over [t0, t1] (true, before encoder errors).
  void TrueWheelSpeeds(double t0_s, double t1_s, double* left, double* right) const;

  SimConfig config_;
  DriveMode drive_mode_;
  Trajectory trajectory_;
  Time produced_until_;
  Rigid3d body_from_lidar_true_;
  std::mt19937_64 lidar_rng_, imu_rng_, wheel_rng_;
  // Members, not locals: normal_distribution keeps half of each generated
  // pair, so recreating it per call would make RunUntil's chunking change
  // the noise.
  std::normal_distribution<double> lidar_gauss_, imu_gauss_, wheel_gauss_;
  std::uniform_real_distribution<double> lidar_uniform_;
  int64_t next_lidar_sample_ = 0;
  int64_t next_wheel_tick_ = 0;
  int64_t next_imu_tick_ = 0;
  uint32_t scan_index_ = 0;
  double last_phase_ = -1.0;
  uint16_t beam_ = 0;
  bool finished_ = false;
  bool keep_truth_ = false;
  std::vector<SampleTruth> sample_truth_;
};

// Collects a SensorLog from sink calls, grouping lidar samples into scans.
class SensorLogCollector : public SensorSink {
 public:
  void OnWheels(const WheelSpeedMeasurement& m) override { log_.wheels.push_back(m); }
  void OnImu(const ImuMeasurement& m) override { log_.imu.push_back(m); }
  void OnLidarSample(uint32_t scan_index, bool ring_start, const LidarSample& s) override;
  SensorLog* log() { return &log_; }

 private:
  SensorLog log_;
};

}  // namespace sweepscan::sim

#endif  // SWEEPSCAN_CORE_SIM_WORLD_H_
