// SimDevices against the real decoders: every byte the emulated devices send
// is fed to X4Decoder, Hi219Decoder and MotorFeedbackDecoder and compared
// with what SimWorld produces for the same configuration.
#include "hardware/emulation/sim_devices.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "core/cloud/reconstruct.h"
#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/link/telemetry_decoder.h"
#include "tests/testing/worlds.h"

namespace sweepscan::hardware {
namespace {

constexpr double kPi = 3.14159265358979323846;
const Time kStart = TimeFromSeconds(sim::SimWorld::kStartTimeS);

// The lab, shortened: straight, an arc, a turn in place, with a wheel slip.
sim::SimConfig ShortLab() {
  sim::SimConfig c = testing::LabConfig(7);
  c.path = {{0.2, 0.0, 2.0}, {0.2, 0.3, 1.5}, {0.0, 0.5, 1.0}, {0.15, -0.1, 1.5}};
  c.slips = {{2.5, 0.5, true, 0.3}};
  c.mounting_error = {0.004, -0.003, 0.006};
  return c;
}

SimDevicesOptions Streaming() {
  SimDevicesOptions o;
  o.lidar_start_scanning = true;
  return o;
}

// Runs a scripted SimDevices to the end in steps of `step` (plus a tail so
// every frame is out).
std::vector<TimedBytes> RunAll(SimDevices* devices, Duration step) {
  std::vector<TimedBytes> out;
  const Time end = devices->world().end_time() + FromSeconds(0.1);
  for (Time t = kStart; t < end; t += step) devices->AdvanceTo(t, &out);
  devices->AdvanceTo(end, &out);
  return out;
}

double WrapPi(double a) { return std::remainder(a, 2 * kPi); }

TEST(SimDevicesTest, LidarPacketsDecodeToTheSimulatedSamples) {
  const sim::SimConfig config = ShortLab();
  const SensorLog direct = sim::SimWorld(config).RunAll();
  SimDevices devices(config, SimDevices::Mode::kScripted, Streaming());
  const std::vector<TimedBytes> out = RunAll(&devices, FromSeconds(0.01));
  EXPECT_TRUE(devices.finished());

  X4Decoder decoder;
  Time previous = Time::min();
  for (const TimedBytes& b : out) {
    if (b.device != LinkDevice::kLidar) continue;
    EXPECT_GE(b.time, previous) << "lidar bytes out of time order";
    previous = b.time;
    decoder.Feed(b.bytes, b.time);
  }
  EXPECT_EQ(decoder.scan_start_headers(), 1u);
  EXPECT_EQ(decoder.stats().checksum_errors + decoder.stats().length_errors +
                decoder.stats().framing_errors + decoder.stats().bytes_skipped,
            0u)
      << decoder.stats().ToString();

  std::vector<X4Packet> packets = decoder.TakePackets();
  for (const X4Packet& p : packets) {
    if (p.ring_start) {
      EXPECT_EQ(p.samples.size(), 1u);
      EXPECT_DOUBLE_EQ(p.scan_frequency_hz, 7.0);
    } else {
      EXPECT_LE(p.samples.size(), 40u);
      EXPECT_EQ(p.ct, 0);
    }
  }

  // The last revolution never completes (no following ring start).
  const std::vector<X4Scan> scans = decoder.TakeScans();
  ASSERT_EQ(scans.size() + 1, direct.scans.size());
  const LidarAngleConvention& convention = config.lidar.angle_convention;
  double worst_time_us = 0, worst_angle_deg = 0;
  size_t valid = 0, total = 0;
  for (size_t i = 0; i < scans.size(); ++i) {
    const std::vector<LidarSample>& want = direct.scans[i].samples;
    const std::vector<X4Sample>& got = scans[i].samples;
    ASSERT_EQ(got.size(), want.size()) << "scan " << i;
    for (size_t k = 0; k < got.size(); ++k) {
      const double dt_us = std::abs(ToSeconds(got[k].time - want[k].time)) * 1e6;
      worst_time_us = std::max(worst_time_us, dt_us);
      ASSERT_LE(dt_us, 1.0) << "scan " << i << " sample " << k;
      ASSERT_EQ(got[k].distance_mm, std::round(want[k].range_m * 1000.0))
          << "scan " << i << " sample " << k;
      const double d_deg =
          std::abs(WrapPi(convention.ThetaFromX4Degrees(got[k].angle_deg) - want[k].theta)) * 180 /
          kPi;
      worst_angle_deg = std::max(worst_angle_deg, d_deg);
      ASSERT_LE(d_deg, 1.0 / 64.0) << "scan " << i << " sample " << k;
      valid += got[k].valid;
      ++total;
    }
  }
  EXPECT_GT(valid, total / 2);
  // Measured (docs/simulator.md): time 0.000 us worst (ns rounding only),
  // angle about 1/128 deg worst (FSA/LSA rounding).
  RecordProperty("worst_time_us", std::to_string(worst_time_us));
  RecordProperty("worst_angle_deg", std::to_string(worst_angle_deg));
  std::printf(
      "lidar: %zu samples in %zu scans, worst time error %.4f us, worst angle error %.5f deg\n",
      total, scans.size(), worst_time_us, worst_angle_deg);
}

TEST(SimDevicesTest, ImuFramesDecodeToTheSimulatedValues) {
  const sim::SimConfig config = ShortLab();
  const SensorLog direct = sim::SimWorld(config).RunAll();
  SimDevices devices(config, SimDevices::Mode::kScripted);
  const std::vector<TimedBytes> out = RunAll(&devices, FromSeconds(0.013));

  Hi219Decoder decoder;
  for (const TimedBytes& b : out) {
    if (b.device == LinkDevice::kImu) decoder.Feed(b.bytes, b.time);
  }
  const std::vector<ImuSample> samples = decoder.TakeSamples();
  ASSERT_EQ(samples.size(), direct.imu.size());
  EXPECT_EQ(decoder.stats().checksum_errors + decoder.stats().bytes_skipped, 0u);
  for (size_t i = 0; i < samples.size(); ++i) {
    const ImuSample& s = samples[i];
    const ImuMeasurement& m = direct.imu[i];
    ASSERT_EQ(s.receive_time - devices.ImuTransmissionTime(), m.time) << i;
    // Float fields: relative 1e-7, i.e. well under a microradian here.
    EXPECT_NEAR(s.gyro_radps[2], m.gyro_z, 1e-6) << i;
    EXPECT_NEAR(s.roll_rad, m.roll, 1e-6) << i;
    EXPECT_NEAR(s.pitch_rad, m.pitch, 1e-6) << i;
    EXPECT_NEAR(s.yaw_rad, m.yaw, 1e-6) << i;
    // The quaternion is the same attitude as the Euler angles.
    const Eigen::Quaterniond q(s.quat_wxyz[0], s.quat_wxyz[1], s.quat_wxyz[2], s.quat_wxyz[3]);
    const Eigen::Quaterniond e(Eigen::AngleAxisd(m.yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(m.pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(m.roll, Eigen::Vector3d::UnitX()));
    EXPECT_LT(q.angularDistance(e), 1e-5) << i;
    // Gravity with the tilt: 1 g give or take the centripetal v * w.
    const double g = std::hypot(s.acc_g[0], s.acc_g[1], s.acc_g[2]);
    EXPECT_NEAR(g, 1.0, 0.02) << i;
    EXPECT_NEAR(s.acc_g[0], -std::sin(m.pitch), 1e-6) << i;
    EXPECT_EQ(s.system_time_ms, static_cast<uint32_t>(ToNanoseconds(m.time) / 1000000));
    EXPECT_EQ(s.temperature_c, 31);
    EXPECT_FLOAT_EQ(s.pressure_pa, 101325.0f);
  }
}

TEST(SimDevicesTest, MotorFeedbackCarriesTheMeasuredWheelTwist) {
  const sim::SimConfig config = ShortLab();
  const SensorLog direct = sim::SimWorld(config).RunAll();
  SimDevices devices(config, SimDevices::Mode::kScripted);
  const std::vector<TimedBytes> out = RunAll(&devices, FromSeconds(0.007));

  MotorFeedbackDecoder decoder;
  for (const TimedBytes& b : out) {
    if (b.device == LinkDevice::kMotorBoard) decoder.Feed(b.bytes, b.time);
  }
  const std::vector<MotorFeedback> frames = decoder.TakeRecords();
  ASSERT_EQ(frames.size(), direct.wheels.size());
  const double d = config.geometry.wheel_distance_m;
  double worst_v = 0, worst_w = 0;
  bool slip_seen = false;
  for (size_t i = 0; i < frames.size(); ++i) {
    const WheelSpeedMeasurement& m = direct.wheels[i];
    ASSERT_EQ(frames[i].receive_time - devices.MotorTransmissionTime(), m.time) << i;
    const Twist2d want = TwistFromWheels(m.left_mps, m.right_mps, d);
    // Wire quantisation: 1 mm/s and 1 mrad/s, rounded to nearest.
    worst_v = std::max(worst_v, std::abs(frames[i].vx_mps - want.v));
    worst_w = std::max(worst_w, std::abs(frames[i].wz_radps - want.w));
    ASSERT_LE(std::abs(frames[i].vx_mps - want.v), 0.5e-3 + 1e-9) << i;
    ASSERT_LE(std::abs(frames[i].wz_radps - want.w), 0.5e-3 + 1e-9) << i;
    const double t = ToSeconds(m.time) - sim::SimWorld::kStartTimeS;
    // The slip (left encoder over-reads by 30 %) shows up as a yaw rate the
    // path does not have.
    if (t > 2.6 && t < 2.9) {
      const Twist2d truth = devices.world().trajectory().TwistAt(t - 0.01);
      if (std::abs(frames[i].wz_radps - truth.w) > 0.1) slip_seen = true;
    }
    EXPECT_NEAR(frames[i].acc_mps2[2], kStandardGravity, 1e-3);
    EXPECT_LE(frames[i].voltage_v, 12.1 + 1e-9);
    EXPECT_GT(frames[i].voltage_v, 12.0);
  }
  EXPECT_TRUE(slip_seen);
  EXPECT_LT(frames.back().voltage_v, frames.front().voltage_v + 1e-9);
  std::printf("motor: %zu frames, worst |dv| %.6f m/s, worst |dw| %.6f rad/s\n", frames.size(),
              worst_v, worst_w);
}

TEST(SimDevicesTest, X4AnswersCommandsAndStreamsOnlyWhenAsked) {
  const sim::SimConfig config = ShortLab();
  SimDevices devices(config, SimDevices::Mode::kScripted);
  X4Decoder decoder;
  std::vector<TimedBytes> out;
  auto advance = [&](double s) {
    out.clear();
    devices.AdvanceTo(kStart + FromSeconds(s), &out);
    size_t lidar_bytes = 0;
    for (const TimedBytes& b : out) {
      if (b.device != LinkDevice::kLidar) continue;
      decoder.Feed(b.bytes, b.time);
      lidar_bytes += b.bytes.size();
    }
    return lidar_bytes;
  };
  EXPECT_EQ(advance(0.5), 0u) << "the X4 is silent until asked";

  // Device info, split across two writes, with garbage before it.
  const std::vector<uint8_t> garbage = {0x00, 0x17, 0xFF, 0xA5};
  devices.WriteToDevice(LinkDevice::kLidar, garbage, kStart + FromSeconds(0.5));
  devices.WriteToDevice(LinkDevice::kLidar, std::vector<uint8_t>{0xA5}, kStart + FromSeconds(0.5));
  devices.WriteToDevice(LinkDevice::kLidar, std::vector<uint8_t>{0x90}, kStart + FromSeconds(0.5));
  devices.WriteToDevice(LinkDevice::kLidar, EncodeX4Command(kX4CmdHealth),
                        kStart + FromSeconds(0.51));
  advance(0.6);
  const std::vector<X4DeviceInfo> infos = decoder.TakeDeviceInfos();
  ASSERT_EQ(infos.size(), 1u);
  EXPECT_EQ(infos[0].model, kX4ModelCode);
  EXPECT_EQ(infos[0].firmware, 0x0108);
  EXPECT_EQ(infos[0].SerialString(), "2024031500000042");
  const std::vector<X4Health> health = decoder.TakeHealth();
  ASSERT_EQ(health.size(), 1u);
  EXPECT_EQ(health[0].status, 0);
  EXPECT_EQ(devices.stats().lidar_garbage_bytes, 4u);  // 00 17 FF and the lone A5.

  devices.WriteToDevice(LinkDevice::kLidar, EncodeX4Command(kX4CmdScan), kStart + FromSeconds(0.6));
  EXPECT_GT(advance(1.6), 10000u);
  EXPECT_EQ(decoder.scan_start_headers(), 1u);
  EXPECT_GE(decoder.TakeScans().size(), 5u);
  EXPECT_GT(decoder.samples_before_first_ring(), 0u);  // Started mid-revolution.

  // Stop: packets measured before it still arrive, nothing after them.
  const Time stop = kStart + FromSeconds(1.6);
  devices.WriteToDevice(LinkDevice::kLidar, EncodeX4Command(kX4CmdStop), stop);
  advance(1.7);
  for (const X4Packet& p : decoder.TakePackets()) {
    for (const X4Sample& s : p.samples) EXPECT_LE(s.time, stop);
  }
  EXPECT_EQ(advance(2.5), 0u);
  EXPECT_EQ(decoder.stats().checksum_errors + decoder.stats().framing_errors, 0u);
  EXPECT_EQ(devices.stats().lidar_commands, 4u);
}

TEST(SimDevicesTest, OutputDoesNotDependOnAdvanceChunking) {
  const sim::SimConfig config = ShortLab();
  SimDevices a(config, SimDevices::Mode::kScripted, Streaming());
  const std::vector<TimedBytes> steady = RunAll(&a, FromSeconds(0.01));

  SimDevices b(config, SimDevices::Mode::kScripted, Streaming());
  std::vector<TimedBytes> irregular;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int64_t> step_us(1, 60000);
  const Time end = b.world().end_time() + FromSeconds(0.1);
  for (Time t = kStart - FromSeconds(0.2); t < end; t += Duration(step_us(rng) * 1000)) {
    b.AdvanceTo(t, &irregular);
  }
  b.AdvanceTo(end, &irregular);

  SimDevices c(config, SimDevices::Mode::kScripted, Streaming());
  std::vector<TimedBytes> one_step;
  c.AdvanceTo(end, &one_step);

  for (const std::vector<TimedBytes>* other : {&irregular, &one_step}) {
    ASSERT_EQ(other->size(), steady.size());
    for (size_t i = 0; i < steady.size(); ++i) {
      ASSERT_EQ((*other)[i].device, steady[i].device) << i;
      ASSERT_EQ((*other)[i].time, steady[i].time) << i;
      ASSERT_EQ((*other)[i].bytes, steady[i].bytes) << i;
    }
  }
  // Whole output in time order across devices.
  for (size_t i = 1; i < steady.size(); ++i) ASSERT_GE(steady[i].time, steady[i - 1].time);
}

TEST(SimDevicesTest, ChunkedSerialReadsCarryTheSameBytesAndTimes) {
  const sim::SimConfig config = ShortLab();
  SimDevices whole(config, SimDevices::Mode::kScripted, Streaming());
  const std::vector<TimedBytes> frames = RunAll(&whole, FromSeconds(0.01));
  SimDevicesOptions options = Streaming();
  options.max_chunk_bytes = 7;
  SimDevices chunked(config, SimDevices::Mode::kScripted, options);
  const std::vector<TimedBytes> chunks = RunAll(&chunked, FromSeconds(0.01));
  EXPECT_GT(chunks.size(), 5 * frames.size());
  std::vector<uint8_t> bytes_a[3], bytes_b[3];
  for (const TimedBytes& f : frames) {
    auto& v = bytes_a[static_cast<int>(f.device) - 1];
    v.insert(v.end(), f.bytes.begin(), f.bytes.end());
  }
  X4Decoder x4_a, x4_b;
  for (const TimedBytes& f : frames) {
    if (f.device == LinkDevice::kLidar) x4_a.Feed(f.bytes, f.time);
  }
  Time previous[3] = {Time::min(), Time::min(), Time::min()};
  for (const TimedBytes& f : chunks) {
    const int d = static_cast<int>(f.device) - 1;
    EXPECT_LE(f.bytes.size(), 7u);
    EXPECT_GE(f.time, previous[d]);
    previous[d] = f.time;
    bytes_b[d].insert(bytes_b[d].end(), f.bytes.begin(), f.bytes.end());
    if (f.device == LinkDevice::kLidar) x4_b.Feed(f.bytes, f.time);
  }
  for (int d = 0; d < 3; ++d) EXPECT_EQ(bytes_a[d], bytes_b[d]) << d;
  // Only the chunk with a packet's last byte matters for its time stamps.
  const std::vector<X4Packet> pa = x4_a.TakePackets(), pb = x4_b.TakePackets();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    ASSERT_EQ(pa[i].samples.size(), pb[i].samples.size());
    for (size_t k = 0; k < pa[i].samples.size(); ++k) {
      ASSERT_EQ(pa[i].samples[k].time, pb[i].samples[k].time);
    }
  }
}

TEST(SimDevicesTest, CommandedRobotFollowsMotorCommands) {
  const sim::SimConfig config = ShortLab();
  SimDevicesOptions options;
  options.motor_time_constant_s = 0.05;
  SimDevices devices(config, SimDevices::Mode::kCommanded, options);
  std::vector<TimedBytes> out;
  devices.AdvanceTo(kStart + FromSeconds(1.0), &out);
  const sim::Trajectory& traj = devices.world().trajectory();
  // Trajectory times are path time: robot time minus kStart.
  EXPECT_NEAR(traj.PoseAt(1.0).x, config.start.x, 1e-12) << "stands until commanded";

  MotorCommand forward;
  forward.vx_mps = 0.2;
  devices.WriteToDevice(LinkDevice::kMotorBoard, EncodeMotorCommand(forward),
                        kStart + FromSeconds(1.0));
  devices.AdvanceTo(kStart + FromSeconds(3.0), &out);
  EXPECT_NEAR(traj.TwistAt(2.5).v, 0.2, 1e-9);
  EXPECT_NEAR(traj.TwistAt(2.5).w, 0.0, 1e-12);
  EXPECT_NEAR(traj.TwistAt(1.0 - 1e-6).v, 0.0, 1e-12);
  // Lag: 0.2 m/s for 2 s less about tau (50 ms) plus half a control period
  // and the wait for the next tick (10 ms).
  const Pose2d p3 = traj.PoseAt(3.0);
  EXPECT_NEAR(p3.x - config.start.x, 0.2 * (2.0 - 0.055), 0.002);
  EXPECT_NEAR(p3.y, config.start.y, 1e-9);

  MotorCommand turn = forward;
  turn.wz_radps = 0.5;
  devices.WriteToDevice(LinkDevice::kMotorBoard, EncodeMotorCommand(turn),
                        kStart + FromSeconds(3.0));
  devices.AdvanceTo(kStart + FromSeconds(5.0), &out);
  EXPECT_NEAR(traj.TwistAt(3.5).w, 0.5, 1e-9);
  EXPECT_NEAR(traj.TwistAt(3.5).v, 0.2, 1e-9);
  EXPECT_NEAR(WrapPi(traj.PoseAt(5.0).yaw - config.start.yaw), 0.5 * (2.0 - 0.055), 0.003);
  // Still exact arcs: the pose is continuous across every control tick.
  for (double t = 0.9; t < 5.0; t += 0.0005) {
    const Pose2d a = traj.PoseAt(t), b = traj.PoseAt(t + 1e-7);
    ASSERT_LT(std::hypot(a.x - b.x, a.y - b.y), 1e-7) << t;
  }
  EXPECT_FALSE(devices.finished());
  EXPECT_EQ(devices.stats().motor_commands, 2u);

  // The board reports the twist it drives.
  MotorFeedbackDecoder feedback;
  for (const TimedBytes& b : out) {
    if (b.device == LinkDevice::kMotorBoard) feedback.Feed(b.bytes, b.time);
  }
  const std::vector<MotorFeedback> frames = feedback.TakeRecords();
  ASSERT_FALSE(frames.empty());
  EXPECT_NEAR(frames.back().vx_mps, 0.2, 0.015);  // Encoder scale errors and noise.
  EXPECT_NEAR(frames.back().wz_radps, 0.5, 0.05);
}

// Distance from (x, y) to the nearest surface at bumper height (10 cm),
// horizontally: the nearest hit of 360 rays.
double HorizontalClearance(const sim::Scene& scene, double x, double y) {
  double nearest = 1e9;
  for (int i = 0; i < 360; ++i) {
    const double a = i * M_PI / 180.0;
    sim::RayHit hit;
    if (scene.Cast(Eigen::Vector3d(x, y, 0.10), Eigen::Vector3d(std::cos(a), std::sin(a), 0.0), 0.0, 50.0, &hit)) {
      nearest = std::min(nearest, hit.range);
    }
  }
  return nearest;
}

// Driven straight at a wall for long enough to cross the room, the robot
// stops with its footprint touching the wall instead of driving through it
// (the keyboard used to drive it out of the lab), and can still back away.
TEST(SimDevicesTest, TheCommandedRobotStopsAtWallsAndCanBackAway) {
  const sim::SimConfig config = ShortLab();
  for (const double radius : {0.22, 0.0}) {
    SimDevicesOptions options;
    options.body_radius_m = radius;
    SimDevices devices(config, SimDevices::Mode::kCommanded, options);
    std::vector<TimedBytes> out;
    MotorCommand forward;
    forward.vx_mps = 0.5;
    devices.WriteToDevice(LinkDevice::kMotorBoard, EncodeMotorCommand(forward), kStart);
    devices.AdvanceTo(kStart + FromSeconds(40.0), &out);  // 20 m at 0.5 m/s: far beyond the room.
    const sim::Trajectory& traj = devices.world().trajectory();
    const Pose2d p = traj.PoseAt(39.0);
    const double clearance = HorizontalClearance(config.scene, p.x, p.y);
    if (radius == 0.0) {
      // Without a footprint it drives through the wall: 19.5 m from its start.
      EXPECT_NEAR(std::hypot(p.x - config.start.x, p.y - config.start.y), 0.5 * 39.0, 0.1);
      continue;
    }
    EXPECT_GT(std::hypot(p.x - config.start.x, p.y - config.start.y), 1.0) << "it drove";
    // Stopped within a control period's travel (5 mm) of touching.
    EXPECT_GE(clearance, radius - 0.002);
    EXPECT_LE(clearance, radius + 0.012);
    EXPECT_EQ(traj.TwistAt(39.0).v, 0.0);
    EXPECT_EQ(devices.CurrentTwist().v, 0.0);

    MotorCommand back;
    back.vx_mps = -0.2;
    devices.WriteToDevice(LinkDevice::kMotorBoard, EncodeMotorCommand(back), kStart + FromSeconds(40.0));
    devices.AdvanceTo(kStart + FromSeconds(42.0), &out);
    const Pose2d q = traj.PoseAt(41.9);
    EXPECT_GT(HorizontalClearance(config.scene, q.x, q.y), clearance + 0.2)
        << "backing away from the wall is allowed";
  }
}

TEST(SimDevicesTest, GarbageWrittenToDevicesIsIgnoredAndCounted) {
  const sim::SimConfig config = ShortLab();
  SimDevices devices(config, SimDevices::Mode::kCommanded);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<uint8_t> junk(5000);
  for (uint8_t& b : junk) b = static_cast<uint8_t>(byte(rng));
  // Keep random bytes from forming a scan-start command by chance.
  std::replace(junk.begin(), junk.end(), uint8_t{0xA5}, uint8_t{0x00});
  std::replace(junk.begin(), junk.end(), uint8_t{0x7B}, uint8_t{0x00});
  std::vector<TimedBytes> out;
  for (int i = 0; i < 3; ++i) {
    const Time t = kStart + FromSeconds(0.1 * (i + 1));
    devices.WriteToDevice(static_cast<LinkDevice>(i + 1), junk, t);
    devices.WriteToDevice(static_cast<LinkDevice>(42), junk, t);  // Unknown device.
    devices.AdvanceTo(t, &out);
  }
  devices.AdvanceTo(kStart + FromSeconds(1.0), &out);
  for (const TimedBytes& b : out) EXPECT_NE(b.device, LinkDevice::kLidar);
  EXPECT_EQ(devices.stats().lidar_garbage_bytes, junk.size());
  EXPECT_EQ(devices.stats().imu_bytes_ignored, junk.size());
  EXPECT_EQ(devices.stats().motor_command_decoder.bytes_skipped, junk.size());
  EXPECT_EQ(devices.stats().motor_commands, 0u);
  EXPECT_NEAR(devices.world().trajectory().PoseAt(0.9).x, config.start.x, 1e-12);
  // Late writes are clamped, not reordered.
  devices.WriteToDevice(LinkDevice::kLidar, EncodeX4Command(kX4CmdHealth), kStart);
  EXPECT_EQ(devices.stats().late_writes, 1u);
  out.clear();
  devices.AdvanceTo(kStart + FromSeconds(1.1), &out);
  ASSERT_EQ(out.empty(), false);
}

// End to end: device bytes -> link Telemetry -> TelemetryDecoder -> SensorLog
// -> Reconstruct, against reconstructing SimWorld's records directly.
TEST(SimDevicesTest, TelemetryPathReconstructsTheDirectCloud) {
  const sim::SimConfig config = ShortLab();
  SimDevices devices(config, SimDevices::Mode::kScripted, Streaming());
  const std::vector<TimedBytes> out = RunAll(&devices, FromSeconds(0.02));

  TelemetryDecoderOptions options;
  options.wheel_distance_m = config.geometry.wheel_distance_m;
  options.lidar_angle_convention = config.lidar.angle_convention;
  // The decoder's default transmission terms (82- and 24-byte frames at
  // 115200 baud) are the simulator's delays: no latency option needed.
  ASSERT_EQ(SerialTransmissionTime(82, options.imu_baud), devices.ImuTransmissionTime());
  ASSERT_EQ(SerialTransmissionTime(24, options.motor_baud), devices.MotorTransmissionTime());
  TelemetryDecoder decoder(options);
  for (const TimedBytes& b : out) {
    Telemetry t;
    t.device = static_cast<uint8_t>(b.device);
    t.receive_time = b.time;
    t.bytes = b.bytes;
    decoder.AddTelemetry(t);
  }
  SensorLog via_bytes;
  decoder.TakeInto(&via_bytes);

  sim::SimWorld world(config);
  const SensorLog direct = world.RunAll();
  const PoseBuffer truth = world.TruthPoses(1000.0);
  ASSERT_EQ(via_bytes.scans.size() + 1, direct.scans.size());
  ASSERT_EQ(via_bytes.imu.size(), direct.imu.size());
  ASSERT_EQ(via_bytes.wheels.size(), direct.wheels.size());

  for (PoseSource source : {PoseSource::kTruth, PoseSource::kEkf}) {
    ReconstructionOptions ro;
    ro.pose.source = source;
    ro.pose.initial_pose = config.start;
    // Off the cloud's 1 mm grid: the bytes' own quantisation, not the
    // grid's rounding (up to 0.87 mm more a point), is what is measured.
    ro.assembly.snap_to_grid = false;
    ReconstructionResult a, b;
    ASSERT_TRUE(Reconstruct(direct, config.geometry, ro, &truth, &a).ok());
    ASSERT_TRUE(Reconstruct(via_bytes, config.geometry, ro, &truth, &b).ok());
    std::map<std::pair<uint32_t, uint16_t>, const CloudPoint*> by_key;
    for (const CloudPoint& p : a.points) by_key[{p.scan, p.beam}] = &p;
    double worst_5m = 0, sum2 = 0;
    size_t matched = 0, near5 = 0;
    for (const CloudPoint& p : b.points) {
      const auto it = by_key.find({p.scan, p.beam});
      ASSERT_NE(it, by_key.end());
      const CloudPoint& q = *it->second;
      const double d = std::hypot(p.x - q.x, p.y - q.y, p.z - q.z);
      sum2 += d * d;
      ++matched;
      if (q.range_m <= 5.0f) {
        worst_5m = std::max(worst_5m, d);
        ++near5;
      }
    }
    ASSERT_GT(matched, b.points.size() * 99 / 100);
    ASSERT_GT(matched, 0u);
    const double rms = std::sqrt(sum2 / static_cast<double>(matched));
    std::printf(
        "%s poses: %zu points matched, rms %.3f mm, worst within 5 m %.3f mm (%zu points)\n",
        PoseSourceName(source), matched, rms * 1e3, worst_5m * 1e3, near5);
    // Truth poses isolate the lidar bytes: 1/128 deg at 5 m is 0.68 mm.
    // The EKF also sees the quantised wheel twist (1 mm/s, 1 mrad/s) and the
    // float IMU fields. Measured: truth rms 0.16 mm, worst 0.63 mm; EKF rms
    // 0.18 mm, worst 0.67 mm.
    EXPECT_LT(worst_5m, 0.001);
  }
}

}  // namespace
}  // namespace sweepscan::hardware
