#include "hardware/emulation/sim_devices.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <sstream>

#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/x4_codec.h"

namespace sweepscan {
namespace hardware {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToDeg = 180.0 / kPi;
constexpr int kDeviceCount = 3;

int DeviceIndex(LinkDevice device) { return static_cast<int>(device) - 1; }
bool KnownDevice(LinkDevice device) {
  const int i = DeviceIndex(device);
  return i >= 0 && i < kDeviceCount;
}

// The X4 decoder's own rounding (llround of ns), so that its time-stamp rule
// inverts ours exactly.
Duration Ns(double seconds) { return Duration(static_cast<int64_t>(std::llround(seconds * 1e9))); }

Duration TransmissionTime(size_t bytes, double baud) {
  return baud > 0 ? Ns(static_cast<double>(bytes) * 10.0 / baud) : Duration(0);
}

// One frame waiting to be read: available (last byte arrived) at `time`;
// `sent` bytes of it were already returned (chunked output).
struct QueuedFrame {
  Time time;
  std::vector<uint8_t> bytes;
  size_t sent = 0;
};

}  // namespace

bool SimDevicesOptions::IsValid(std::string* error) const {
  if (!std::isfinite(lidar_baud) || !std::isfinite(imu_baud) || !std::isfinite(motor_baud)) {
    *error = "baud rates must be finite";
    return false;
  }
  if (lidar_samples_per_packet < 1 || lidar_samples_per_packet > kX4MaxSamplesPerPacket) {
    *error = "lidar_samples_per_packet must be within 1..255";
    return false;
  }
  if (!(motor_time_constant_s >= 0) || !std::isfinite(motor_time_constant_s) ||
      !(motor_control_period_s >= 1e-4) || !std::isfinite(motor_control_period_s)) {
    *error = "motor_time_constant_s must be >= 0 and motor_control_period_s >= 0.1 ms";
    return false;
  }
  if (!std::isfinite(battery_start_v) || !std::isfinite(battery_drop_v_per_hour) ||
      !std::isfinite(imu_pressure_pa)) {
    *error = "battery and pressure values must be finite";
    return false;
  }
  return true;
}

std::string SimDevicesStats::ToString() const {
  std::ostringstream s;
  s << "lidar: " << lidar_packets << " packets, " << lidar_samples_sent << " samples sent, "
    << lidar_samples_dropped << " dropped, " << lidar_responses << " responses, " << lidar_commands
    << " commands, " << lidar_unknown_commands << " unknown, " << lidar_garbage_bytes
    << " garbage bytes; imu: " << imu_frames << " frames, " << imu_bytes_ignored
    << " input bytes ignored; motor: " << motor_frames << " frames, " << motor_commands
    << " commands (" << motor_commands_ignored << " ignored), input "
    << motor_command_decoder.ToString() << "; bytes out " << bytes_out[0] << "/" << bytes_out[1]
    << "/" << bytes_out[2] << ", in " << bytes_in[0] << "/" << bytes_in[1] << "/" << bytes_in[2]
    << "; late writes " << late_writes;
  return s.str();
}

class SimDevices::Impl : public sim::SensorSink {
 public:
  Impl(const sim::SimConfig& config, Mode mode, const SimDevicesOptions& options)
      : options_(options),
        mode_(mode),
        world_(config, mode == Mode::kCommanded ? sim::SimWorld::DriveMode::kCommanded
                                                : sim::SimWorld::DriveMode::kPath),
        start_(TimeFromSeconds(sim::SimWorld::kStartTimeS)),
        control_period_(Ns(options.motor_control_period_s)),
        next_control_(start_) {
    for (Time& t : last_out_) t = Time::min();
    if (options_.lidar_start_scanning) StartScan(start_);
  }

  // ---- Driving the world -------------------------------------------------

  // Runs the world to t. In kCommanded mode the board's control ticks up to
  // t are applied first, each just before the world produces records at its
  // time, so that records never depend on where the caller split time.
  void RunWorldTo(Time t) {
    if (t <= world_.produced_until()) return;
    if (mode_ == Mode::kCommanded) {
      while (next_control_ <= t) {
        world_.RunUntil(next_control_ - Duration(1), this);
        ControlTick(next_control_);
        next_control_ += control_period_;
      }
    }
    world_.RunUntil(t, this);
  }

  // The board's speed loop: a first-order lag towards the target, held as a
  // piecewise-constant twist for one period.
  void ControlTick(Time t) {
    const double tau = options_.motor_time_constant_s;
    const double alpha = tau > 0 ? 1.0 - std::exp(-options_.motor_control_period_s / tau) : 1.0;
    Twist2d next{current_.v + alpha * (target_.v - current_.v),
                 current_.w + alpha * (target_.w - current_.w)};
    // Snap when closer than the board's own resolution (1 mm/s, 1 mrad/s),
    // so a settled board stops issuing new segments.
    if (std::abs(next.v - target_.v) < 1e-4 && std::abs(next.w - target_.w) < 1e-4) next = target_;
    if (next.v != 0.0 && Blocked(t, next.v)) next.v = 0.0;
    if (next.v != current_.v || next.w != current_.w) {
      current_ = next;
      world_.CommandTwist(t, current_);
    }
  }

  // True when driving at v for the next control period would bring the
  // footprint nearer than its radius to a surface ahead (v > 0) or behind
  // (v < 0): rays at bumper height (10 cm, below every table top and above
  // the floor) across +-75 deg of the direction of travel (a wall beside
  // the robot does not stop it sliding along). A robot already touching may
  // still back away or turn.
  bool Blocked(Time t, double v) const {
    const double radius = options_.body_radius_m;
    if (radius <= 0.0) return false;
    const Pose2d pose = world_.trajectory().PoseAt(PathSeconds(t));
    const double reach = radius + std::abs(v) * options_.motor_control_period_s + 0.005;
    const double heading = pose.yaw + (v < 0.0 ? M_PI : 0.0);
    const Eigen::Vector3d origin(pose.x, pose.y, 0.10);
    for (int k = -5; k <= 5; ++k) {
      const double a = heading + k * (M_PI / 12.0);  // 15 deg apart.
      sim::RayHit hit;
      // Along a ray at angle d off the direction of travel the circle's edge
      // advances by cos(d) of the step: a wall at that angle stops the robot
      // when its range is under the radius plus that advance.
      const double advance = (reach - radius) * std::cos(k * (M_PI / 12.0));
      if (world_.config().scene.Cast(origin, Eigen::Vector3d(std::cos(a), std::sin(a), 0.0), 0.0,
                                     radius + advance, &hit)) {
        return true;
      }
    }
    return false;
  }

  // ---- SensorSink: measurements become device frames ---------------------

  void OnWheels(const WheelSpeedMeasurement& m) override {
    // The board reports the twist its encoders measured (Eq. 2-3), so scale
    // errors, noise and slip show up exactly as on a real board.
    const Twist2d measured =
        TwistFromWheels(m.left_mps, m.right_mps, world_.config().geometry.wheel_distance_m);
    MotorFeedback f;
    f.stop_flag = 0;
    f.vx_mps = measured.v;
    f.wz_radps = measured.w;
    // The board's MPU6050: gravity plus the centripetal term, and the yaw rate.
    const Twist2d truth = world_.trajectory().TwistAt(PathSeconds(m.time));
    f.acc_mps2 = {0.0, truth.v * truth.w, kStandardGravity};
    f.gyro_radps = {0.0, 0.0, measured.w};
    const double hours = std::max(0.0, PathSeconds(m.time)) / 3600.0;
    f.voltage_v = options_.battery_start_v - options_.battery_drop_v_per_hour * hours;
    std::vector<uint8_t> bytes = EncodeMotorFeedback(f);
    const Time available = m.time + TransmissionTime(bytes.size(), options_.motor_baud);
    Append(LinkDevice::kMotorBoard, available, std::move(bytes));
    ++stats_.motor_frames;
  }

  void OnImu(const ImuMeasurement& m) override {
    ImuSample s;
    s.fields = kImuAcc | kImuGyro | kImuEuler | kImuQuat | kImuPressure | kImuSystemTime |
               kImuTemperature | kImuMainStatus;
    s.main_status = 0;
    s.temperature_c = options_.imu_temperature_c;
    s.pressure_pa = options_.imu_pressure_pa;
    s.system_time_ms = static_cast<uint32_t>(ToNanoseconds(m.time) / 1000000);
    // Specific force in the body frame for a level-driving robot tilted by
    // (roll, pitch): R^T (0, 0, g) with R = Rz Ry Rx, plus the centripetal
    // acceleration v * w along y; in g.
    const Twist2d truth = world_.trajectory().TwistAt(PathSeconds(m.time));
    const double cr = std::cos(m.roll), sr = std::sin(m.roll);
    const double cp = std::cos(m.pitch), sp = std::sin(m.pitch);
    s.acc_g = {static_cast<float>(-sp),
               static_cast<float>(cp * sr + truth.v * truth.w / kStandardGravity),
               static_cast<float>(cp * cr)};
    s.gyro_dps = {0.0f, 0.0f, static_cast<float>(m.gyro_z * kRadToDeg)};
    s.roll_deg = static_cast<float>(m.roll * kRadToDeg);
    s.pitch_deg = static_cast<float>(m.pitch * kRadToDeg);
    s.yaw_deg = static_cast<float>(m.yaw * kRadToDeg);
    // q = Rz(yaw) Ry(pitch) Rx(roll), the same attitude as the Euler angles.
    const double hr = 0.5 * m.roll, hp = 0.5 * m.pitch, hy = 0.5 * m.yaw;
    const double c1 = std::cos(hy), s1 = std::sin(hy), c2 = std::cos(hp), s2 = std::sin(hp),
                 c3 = std::cos(hr), s3 = std::sin(hr);
    s.quat_wxyz = {static_cast<float>(c1 * c2 * c3 + s1 * s2 * s3),
                   static_cast<float>(c1 * c2 * s3 - s1 * s2 * c3),
                   static_cast<float>(c1 * s2 * c3 + s1 * c2 * s3),
                   static_cast<float>(s1 * c2 * c3 - c1 * s2 * s3)};
    std::vector<uint8_t> bytes = EncodeHi219Packet91Frame(s);
    const Time available = m.time + TransmissionTime(bytes.size(), options_.imu_baud);
    Append(LinkDevice::kImu, available, std::move(bytes));
    ++stats_.imu_frames;
  }

  void OnLidarSample(uint32_t /*scan_index*/, bool ring_start, const LidarSample& s) override {
    const int64_t n = lidar_sample_index_++;
    if (!scanning_ || !lidar_motor_on_) {
      ++stats_.lidar_samples_dropped;
      pending_.clear();
      plan_.clear();
      plan_pos_ = 0;
      return;
    }
    if (ring_start) {
      // The revolution's first sample goes alone, flagged, with the scan
      // frequency; then the rest of the revolution is planned.
      pending_.clear();
      pending_.push_back(s);
      SendPacket(true);
      plan_ = PlanPackets(SamplesUntilRingStart(n + 1));
      plan_pos_ = 0;
      return;
    }
    if (plan_pos_ >= plan_.size()) {
      // Streaming started mid-revolution.
      plan_ = PlanPackets(SamplesUntilRingStart(n));
      plan_pos_ = 0;
    }
    pending_.push_back(s);
    if (pending_.size() >= plan_[plan_pos_]) {
      SendPacket(false);
      ++plan_pos_;
    }
  }

  // ---- Host writes --------------------------------------------------------

  void WriteLidar(const uint8_t* data, size_t n, Time now) {
    x4_in_.insert(x4_in_.end(), data, data + n);
    size_t i = 0;
    while (i < x4_in_.size()) {
      if (x4_in_[i] != kX4CommandSync) {
        ++stats_.lidar_garbage_bytes;
        ++i;
        continue;
      }
      if (i + 2 > x4_in_.size()) break;
      const uint8_t cmd = x4_in_[i + 1];
      if (cmd == kX4CommandSync) {  // A5 A5: the first one was noise.
        ++stats_.lidar_garbage_bytes;
        ++i;
        continue;
      }
      if (IsPlainX4Command(cmd) || (cmd & 0x80) == 0) {
        HandleX4Command(cmd, now);
        i += 2;
        continue;
      }
      // `A5 (cmd|0x80) size payload xor`: the X4 has no such command we
      // emulate (frequency and motor settings are for other models), but
      // skip a well-formed one as a whole.
      if (i + 3 > x4_in_.size()) break;
      const size_t total = 3 + static_cast<size_t>(x4_in_[i + 2]) + 1;
      if (i + total > x4_in_.size()) break;
      uint8_t x = 0;
      for (size_t k = 0; k + 1 < total; ++k) x ^= x4_in_[i + k];
      if (x == x4_in_[i + total - 1]) {
        ++stats_.lidar_unknown_commands;
        i += total;
      } else {
        ++stats_.lidar_garbage_bytes;
        ++i;
      }
    }
    x4_in_.erase(x4_in_.begin(), x4_in_.begin() + static_cast<std::ptrdiff_t>(i));
    // A sender that never completes a command cannot grow the buffer.
    if (x4_in_.size() > 512) {
      stats_.lidar_garbage_bytes += x4_in_.size();
      x4_in_.clear();
    }
  }

  void WriteMotor(const uint8_t* data, size_t n, Time now) {
    motor_decoder_.Feed(data, n, now);
    for (const MotorCommand& c : motor_decoder_.TakeRecords()) {
      ++stats_.motor_commands;
      if (mode_ != Mode::kCommanded) {
        ++stats_.motor_commands_ignored;
        continue;
      }
      target_ = {c.vx_mps, c.wz_radps};
    }
    stats_.motor_command_decoder = motor_decoder_.stats();
  }

  void SetLidarMotor(bool on) {
    lidar_motor_on_ = on;
    if (!on) {
      pending_.clear();
      plan_.clear();
      plan_pos_ = 0;
    }
  }

  // ---- Output ---------------------------------------------------------------

  // Moves every chunk available by `now` to *out, merged across devices in
  // time order (ties: lowest device id first).
  void Emit(Time now, std::vector<TimedBytes>* out) {
    for (;;) {
      int best = -1;
      Time best_time = Time::max();
      size_t best_end = 0;
      for (int d = 0; d < kDeviceCount; ++d) {
        if (queues_[d].empty()) continue;
        size_t end;
        const Time t = NextChunk(d, &end);
        if (t <= now && t < best_time) {
          best = d;
          best_time = t;
          best_end = end;
        }
      }
      if (best < 0) return;
      QueuedFrame& f = queues_[best].front();
      TimedBytes tb;
      tb.device = static_cast<LinkDevice>(best + 1);
      tb.time = best_time;
      tb.bytes.assign(f.bytes.begin() + static_cast<std::ptrdiff_t>(f.sent),
                      f.bytes.begin() + static_cast<std::ptrdiff_t>(best_end));
      stats_.bytes_out[best] += tb.bytes.size();
      last_out_[best] = best_time;
      f.sent = best_end;
      if (f.sent == f.bytes.size()) queues_[best].pop_front();
      out->push_back(std::move(tb));
    }
  }

  bool QueuesEmpty() const {
    for (const auto& q : queues_) {
      if (!q.empty()) return false;
    }
    return true;
  }

  SimDevicesOptions options_;
  Mode mode_;
  sim::SimWorld world_;
  SimDevicesStats stats_;
  Twist2d current_;

 private:
  double PathSeconds(Time t) const { return ToSeconds(t) - sim::SimWorld::kStartTimeS; }

  double Baud(int device) const {
    return device == 0 ? options_.lidar_baud
                       : (device == 1 ? options_.imu_baud : options_.motor_baud);
  }

  // The next chunk of device d's front frame: its end offset and the time its
  // last byte arrived, never before the device's previous chunk.
  Time NextChunk(int d, size_t* end) const {
    const QueuedFrame& f = queues_[d].front();
    const size_t size = f.bytes.size();
    *end = options_.max_chunk_bytes == 0 ? size : std::min(size, f.sent + options_.max_chunk_bytes);
    const Time t = f.time - TransmissionTime(size - *end, Baud(d));
    return std::max(t, last_out_[d]);
  }

  // Appends a frame to a device's queue (measurement frames arrive in time
  // order per device).
  void Append(LinkDevice device, Time available, std::vector<uint8_t> bytes) {
    auto& q = queues_[DeviceIndex(device)];
    if (!q.empty() && available < q.back().time) available = q.back().time;
    q.push_back({available, std::move(bytes), 0});
  }

  // A command response: inserted at its time among the queued packets, at
  // a frame boundary, after any frame already partly returned.
  void InsertResponse(Time available, std::vector<uint8_t> bytes) {
    auto& q = queues_[0];
    auto it = std::upper_bound(q.begin(), q.end(), available,
                               [](Time t, const QueuedFrame& f) { return t < f.time; });
    if (it == q.begin() && !q.empty() && q.front().sent > 0) ++it;
    q.insert(it, {available, std::move(bytes), 0});
    ++stats_.lidar_responses;
  }

  static bool IsPlainX4Command(uint8_t cmd) {
    return cmd == kX4CmdScan || cmd == kX4CmdForceScan || cmd == kX4CmdStop || cmd == kX4CmdReset ||
           cmd == kX4CmdDeviceInfo || cmd == kX4CmdHealth;
  }

  void HandleX4Command(uint8_t cmd, Time now) {
    switch (cmd) {
      case kX4CmdScan:
      case kX4CmdForceScan:
        ++stats_.lidar_commands;
        StartScan(now);
        return;
      case kX4CmdStop:
      case kX4CmdReset:
        ++stats_.lidar_commands;
        scanning_ = false;
        pending_.clear();
        plan_.clear();
        plan_pos_ = 0;
        return;
      case kX4CmdDeviceInfo: {
        ++stats_.lidar_commands;
        X4DeviceInfo info;
        info.model = kX4ModelCode;
        info.firmware = options_.lidar_firmware;
        info.hardware = options_.lidar_hardware;
        info.serial = options_.lidar_serial;
        std::vector<uint8_t> bytes = EncodeX4DeviceInfo(info);
        const Time t = now + TransmissionTime(bytes.size(), options_.lidar_baud);
        InsertResponse(t, std::move(bytes));
        return;
      }
      case kX4CmdHealth: {
        ++stats_.lidar_commands;
        std::vector<uint8_t> bytes = EncodeX4Health(X4Health());
        const Time t = now + TransmissionTime(bytes.size(), options_.lidar_baud);
        InsertResponse(t, std::move(bytes));
        return;
      }
      default:
        ++stats_.lidar_unknown_commands;
        return;
    }
  }

  void StartScan(Time now) {
    // A second start while streaming repeats the header; the stream goes on.
    std::vector<uint8_t> bytes = EncodeX4ScanStartHeader();
    const Time t = now + TransmissionTime(bytes.size(), options_.lidar_baud);
    InsertResponse(t, std::move(bytes));
    scanning_ = true;
  }

  // Samples from index `first` up to (not including) the next ring start.
  int64_t SamplesUntilRingStart(int64_t first) const {
    const sim::LidarSpec& spec = world_.config().lidar;
    // A revolution has about sample_rate / scan_rate samples (IsValid: >= 10).
    const int64_t limit = static_cast<int64_t>(spec.sample_rate_hz / spec.scan_rate_hz) + 16;
    int64_t m = first;
    while (m - first < limit && !sim::SimWorld::IsLidarRingStart(spec, m)) ++m;
    return std::max<int64_t>(m - first, 1);
  }

  // Packet sizes for `count` samples ending just before a ring-start packet.
  // A packet's bytes are available at its last sample's time plus its own
  // transmission time, so a long packet followed by a short one would be
  // available after it: packets shrink towards the ring start (..., 40, 20,
  // 9, 4, 2 at 5 kHz and 128000 baud) so that the byte stream stays in time
  // order and every packet keeps the exact time the X4 decoder assumes.
  std::vector<size_t> PlanPackets(int64_t count) const {
    const double period = 1.0 / world_.config().lidar.sample_rate_hz;
    const double byte_s = options_.lidar_baud > 0 ? 10.0 / options_.lidar_baud : 0.0;
    const size_t max_size = options_.lidar_samples_per_packet;
    std::vector<size_t> reversed;
    size_t next = 1;  // The ring-start packet.
    while (count > 0) {
      // Packet j (n_j) before packet j+1 (n): n * period + 2 (n - n_j) byte_s >= 0.
      size_t cap = max_size;
      if (byte_s > 0) {
        const double bound = static_cast<double>(next) * (period + 2 * byte_s) / (2 * byte_s);
        cap = std::min(cap, static_cast<size_t>(std::max(1.0, std::floor(bound - 1e-9))));
      }
      const size_t k = std::min(cap, static_cast<size_t>(count));
      reversed.push_back(k);
      count -= static_cast<int64_t>(k);
      next = k;
    }
    return std::vector<size_t>(reversed.rbegin(), reversed.rend());
  }

  void SendPacket(bool ring_start) {
    const LidarAngleConvention& convention = world_.config().lidar.angle_convention;
    X4PacketToEncode p;
    p.ring_start = ring_start;
    p.scan_frequency_hz = ring_start ? world_.config().lidar.scan_rate_hz : 0.0;
    // The corrected angle the decoder should output: the sample's theta
    // (encoder angle plus correction for the measured distance; the raw
    // encoder angle for invalid samples, as the decoder applies none).
    p.first_angle_deg = convention.X4DegreesFromTheta(pending_.front().theta);
    p.last_angle_deg = convention.X4DegreesFromTheta(pending_.back().theta);
    p.distances_mm.reserve(pending_.size());
    for (const LidarSample& s : pending_) {
      p.distances_mm.push_back(std::round(static_cast<double>(s.range_m) * 1000.0));
    }
    std::vector<uint8_t> bytes;
    EncodeX4ScanPacket(p, &bytes);
    const Time available =
        pending_.back().time + TransmissionTime(bytes.size(), options_.lidar_baud);
    Append(LinkDevice::kLidar, available, std::move(bytes));
    ++stats_.lidar_packets;
    stats_.lidar_samples_sent += pending_.size();
    pending_.clear();
  }

  Time start_;
  Duration control_period_;
  Time next_control_;
  Twist2d target_;
  MotorCommandDecoder motor_decoder_;

  std::deque<QueuedFrame> queues_[kDeviceCount];
  Time last_out_[kDeviceCount];

  std::vector<uint8_t> x4_in_;
  bool scanning_ = false;
  bool lidar_motor_on_ = true;
  int64_t lidar_sample_index_ = 0;
  std::vector<LidarSample> pending_;
  std::vector<size_t> plan_;
  size_t plan_pos_ = 0;
};

SimDevices::SimDevices(const sim::SimConfig& config, Mode mode, const SimDevicesOptions& options)
    : mode_(mode),
      options_(options),
      now_(Time::min()),
      impl_(std::make_unique<Impl>(config, mode, options)) {}

SimDevices::~SimDevices() = default;

void SimDevices::WriteToDevice(LinkDevice device, const uint8_t* data, size_t n, Time now) {
  if (!KnownDevice(device) || (data == nullptr && n > 0)) return;
  if (now < now_) {
    ++impl_->stats_.late_writes;
    now = now_;
  }
  impl_->stats_.bytes_in[DeviceIndex(device)] += n;
  // Run the world up to the write, so that what the command changes starts
  // exactly at its time, whatever the caller's AdvanceTo steps were.
  impl_->RunWorldTo(now);
  switch (device) {
    case LinkDevice::kLidar:
      impl_->WriteLidar(data, n, now);
      break;
    case LinkDevice::kImu:
      impl_->stats_.imu_bytes_ignored += n;
      break;
    case LinkDevice::kMotorBoard:
      impl_->WriteMotor(data, n, now);
      break;
  }
}

void SimDevices::SetLidarMotor(bool on, Time now) {
  if (now < now_) {
    ++impl_->stats_.late_writes;
    now = now_;
  }
  impl_->RunWorldTo(now);
  impl_->SetLidarMotor(on);
}

void SimDevices::AdvanceTo(Time now, std::vector<TimedBytes>* out) {
  if (now > now_) now_ = now;
  impl_->RunWorldTo(now_);
  if (out != nullptr) impl_->Emit(now_, out);
}

const sim::SimWorld& SimDevices::world() const { return impl_->world_; }

bool SimDevices::finished() const {
  return mode_ == Mode::kScripted && impl_->world_.finished() && impl_->QueuesEmpty();
}

const SimDevicesStats& SimDevices::stats() const { return impl_->stats_; }

Duration SimDevices::ImuTransmissionTime() const {
  return TransmissionTime(kHi219HeaderSize + kHi219Packet91Size, options_.imu_baud);
}

Duration SimDevices::MotorTransmissionTime() const {
  return TransmissionTime(kMotorFeedbackSize, options_.motor_baud);
}

Twist2d SimDevices::CurrentTwist() const { return impl_->current_; }

}  // namespace hardware
}  // namespace sweepscan
