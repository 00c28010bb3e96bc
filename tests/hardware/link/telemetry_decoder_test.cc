#include "hardware/link/telemetry_decoder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>
#include "tests/testing/run_command.h"

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

const Time kT0 = TimeFromSeconds(50.0);
constexpr double kWheelDistance = 0.16;

double DistanceMm(int i) { return i % 5 == 4 ? 0.0 : 300.0 + 100.0 * i; }

// Two revolutions' worth of X4 bytes: ring start, one 40-sample packet from
// 10 to 49 deg at 0.3..4.2 m (every 5th invalid), ring start, and so on, ending
// with a ring start so the second revolution is emitted too.
Bytes MakeX4Bytes() {
  Bytes out = EncodeX4ScanStartHeader();
  for (int r = 0; r < 3; ++r) {
    X4PacketToEncode ring;
    ring.ring_start = true;
    ring.scan_frequency_hz = 7.0;
    ring.distances_mm = {0};
    ring.first_angle_deg = ring.last_angle_deg = 0.0;
    EncodeX4ScanPacket(ring, &out);
    if (r == 2) break;
    X4PacketToEncode p;
    for (int i = 0; i < 40; ++i) p.distances_mm.push_back(DistanceMm(i));
    p.first_angle_deg = 10.0;
    p.last_angle_deg = 49.0;
    EncodeX4ScanPacket(p, &out);
  }
  return out;
}

ImuSample MakeImu(double k) {
  ImuSample s;
  s.fields = kImuAcc | kImuGyro | kImuEuler | kImuQuat | kImuSystemTime;
  s.acc_g = {0.0f, 0.0f, 1.0f};
  s.gyro_dps = {1.0f, -2.0f, static_cast<float>(30.0 + k)};
  s.roll_deg = 1.5f;
  s.pitch_deg = -2.5f;
  s.yaw_deg = static_cast<float>(90.0 - k);
  s.quat_wxyz = {1, 0, 0, 0};
  return s;
}

MotorFeedback MakeFeedback(double k) {
  MotorFeedback f;
  f.vx_mps = 0.2 + 0.01 * k;
  f.wz_radps = 0.5;
  f.voltage_v = 12.0;
  return f;
}

// The link messages a robot agent would send: interleaved devices, robot receive times.
std::vector<Telemetry> MakeTelemetry() {
  std::vector<Telemetry> out;
  const Bytes x4 = MakeX4Bytes();
  // The X4 bytes in 3 reads.
  const size_t third = x4.size() / 3;
  for (int i = 0; i < 3; ++i) {
    const size_t a = i * third, b = i == 2 ? x4.size() : (i + 1) * third;
    out.push_back(Telemetry{uint8_t(LinkDevice::kLidar), kT0 + std::chrono::milliseconds(10 * i),
                            Bytes(x4.begin() + a, x4.begin() + b)});
    out.push_back(Telemetry{uint8_t(LinkDevice::kImu), kT0 + std::chrono::milliseconds(10 * i + 1),
                            EncodeHi219Packet91Frame(MakeImu(i))});
    out.push_back(Telemetry{uint8_t(LinkDevice::kMotorBoard),
                            kT0 + std::chrono::milliseconds(10 * i + 2),
                            EncodeMotorFeedback(MakeFeedback(i))});
  }
  return out;
}

TelemetryDecoderOptions Options() {
  TelemetryDecoderOptions o;
  o.wheel_distance_m = kWheelDistance;
  o.lidar_angle_convention.sign = -1;
  o.lidar_angle_convention.offset_rad = 0.25;
  return o;
}

void ExpectExpectedLog(const SensorLog& log, const TelemetryDecoderOptions& o) {
  // Wheels: WheelsFromTwist of each feedback frame.
  ASSERT_EQ(log.wheels.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const double v = std::round((0.2 + 0.01 * i) * 1000) / 1000;  // mm/s on the wire.
    EXPECT_NEAR(log.wheels[i].left_mps, v - 0.5 * kWheelDistance, 1e-12);
    EXPECT_NEAR(log.wheels[i].right_mps, v + 0.5 * kWheelDistance, 1e-12);
    // Receive time - latency - 24 bytes * 10 / 115200 baud (2 083 333 ns).
    EXPECT_EQ(log.wheels[i].time,
              kT0 + std::chrono::milliseconds(10 * i + 2) - o.motor_latency - Duration(2'083'333));
  }
  // IMU: SI units.
  ASSERT_EQ(log.imu.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(log.imu[i].gyro_z, (30.0 + i) * M_PI / 180.0, 1e-6);
    EXPECT_NEAR(log.imu[i].roll, 1.5 * M_PI / 180.0, 1e-6);
    EXPECT_NEAR(log.imu[i].pitch, -2.5 * M_PI / 180.0, 1e-6);
    EXPECT_NEAR(log.imu[i].yaw, (90.0 - i) * M_PI / 180.0, 1e-6);
    EXPECT_TRUE(log.imu[i].has_gyro && log.imu[i].has_attitude);
    // Receive time - latency - 82 bytes * 10 / 115200 baud (7 118 056 ns).
    EXPECT_EQ(log.imu[i].time,
              kT0 + std::chrono::milliseconds(10 * i + 1) - o.imu_latency - Duration(7'118'056));
  }
  // Lidar: two revolutions of 1 + 40 samples.
  ASSERT_EQ(log.scans.size(), 2u);
  for (size_t r = 0; r < 2; ++r) {
    const LidarScan& scan = log.scans[r];
    EXPECT_EQ(scan.index, r);
    ASSERT_EQ(scan.samples.size(), 41u);
    EXPECT_EQ(scan.samples[0].range_m, 0.0f);  // The ring-start sample is invalid.
    for (int i = 0; i < 40; ++i) {
      const LidarSample& s = scan.samples[1 + i];
      EXPECT_EQ(s.beam, 1 + i);
      if (i % 5 == 4) {
        EXPECT_EQ(s.range_m, 0.0f);
      } else {
        EXPECT_FLOAT_EQ(s.range_m, static_cast<float>(DistanceMm(i) * 1e-3));
      }
      // The raw X4 angle the decoder must produce: the end samples' first-level
      // angles (desired corrected angle minus their own second-level
      // correction), interpolated, plus each sample's correction; within the
      // 1/64 deg field resolution. Then mapped by the convention.
      const double f0 = 10.0 - X4AngleCorrectionDeg(DistanceMm(0));
      const double f1 = 49.0 - X4AngleCorrectionDeg(DistanceMm(39));
      const double expected_deg =
          WrapDegrees360(f0 + (f1 - f0) * i / 39.0 + X4AngleCorrectionDeg(DistanceMm(i)));
      EXPECT_NEAR(s.theta, o.lidar_angle_convention.ThetaFromX4Degrees(expected_deg),
                  0.02 * M_PI / 180.0)
          << r << " " << i;
    }
    // Sample times 200 us apart (5 kHz) within the packet.
    EXPECT_NEAR(ToSeconds(scan.samples[40].time - scan.samples[1].time), 39 * 200e-6, 1e-9);
  }
}

TEST(TelemetryDecoderTest, DeviceBytesDecodeIntoTheExpectedSensorLog) {
  const TelemetryDecoderOptions o = Options();
  TelemetryDecoder d(o);
  for (const Telemetry& t : MakeTelemetry()) d.AddTelemetry(t);
  SensorLog log;
  d.TakeInto(&log);
  ExpectExpectedLog(log, o);
  const TelemetryDecoderStats s = d.stats();
  EXPECT_EQ(s.telemetry_messages, 9u);
  EXPECT_EQ(s.x4.bytes_skipped, 0u);
  EXPECT_EQ(s.hi219.frames_ok, 3u);
  EXPECT_EQ(s.motor.frames_ok, 3u);

  // The lidar samples are exactly what the X4 decoder produced, mapped.
  X4Decoder x4;
  for (const Telemetry& t : MakeTelemetry()) {
    if (t.device == uint8_t(LinkDevice::kLidar)) x4.Feed(t.bytes, t.receive_time);
  }
  const auto scans = x4.TakeScans();
  ASSERT_EQ(scans.size(), 2u);
  for (size_t i = 0; i < scans[1].samples.size(); ++i) {
    EXPECT_EQ(log.scans[1].samples[i].time, scans[1].samples[i].time);
    EXPECT_EQ(log.scans[1].samples[i].theta,
              static_cast<float>(
                  o.lidar_angle_convention.ThetaFromX4Degrees(scans[1].samples[i].angle_deg)));
  }
}

// Each frame's own length and the configured baud set its transmission
// time (docs/device-codecs.md, "Frame times of the IMU and the motor board");
// a session's settings.serial configures them. Hand-checked values.
TEST(TelemetryDecoderTest, SerialSettingsOfTheSessionSetFrameTimes) {
  auto decode = [](const TelemetryDecoderOptions& o, const Bytes& imu_frame) {
    TelemetryDecoder d(o);
    d.AddTelemetry(Telemetry{uint8_t(LinkDevice::kImu), kT0, imu_frame});
    d.AddTelemetry(
        Telemetry{uint8_t(LinkDevice::kMotorBoard), kT0, EncodeMotorFeedback(MakeFeedback(0))});
    SensorLog log;
    d.TakeInto(&log);
    EXPECT_EQ(log.imu.size(), 1u);
    EXPECT_EQ(log.wheels.size(), 1u);
    return log;
  };
  const Bytes frame91 = EncodeHi219Packet91Frame(MakeImu(0));
  const Bytes legacy = EncodeHi219LegacyFrame(MakeImu(0));
  // acc, gyro, Euler and quaternion items: 7 + 7 + 7 + 17 = 38 payload bytes.
  ASSERT_EQ(legacy.size(), 6u + 38u);

  // Defaults, as before they were configurable: 82 bytes at 115200 baud =
  // 7 118 056 ns, 24 bytes = 2 083 333 ns; a 44-byte legacy frame: 3 819 444 ns.
  TelemetryDecoderOptions o;
  EXPECT_EQ(decode(o, frame91).imu[0].time, kT0 - Duration(7'118'056));
  EXPECT_EQ(decode(o, frame91).wheels[0].time, kT0 - Duration(2'083'333));
  EXPECT_EQ(decode(o, legacy).imu[0].time, kT0 - Duration(3'819'444));

  // A session without settings.serial keeps them.
  SessionMeta meta;
  TelemetryDecoderOptions from_meta;
  ASSERT_TRUE(SerialSettingsFromMeta(meta, "meta.json", &from_meta).ok());
  EXPECT_EQ(from_meta.imu_baud, 115200.0);
  EXPECT_EQ(from_meta.x4.baud_rate, 128000.0);

  // IMU at 460800 baud plus 1 ms: 82 * 10 / 460800 = 1 779 514 ns + 1 ms;
  // motor board without the transmission term (baud 0); lidar at 230400.
  meta.settings = nlohmann::json::parse(
      R"({"serial": {"imu_baud": 460800, "imu_latency_s": 0.001, "motor_baud": 0,
                     "lidar_baud": 230400, "lidar_latency_s": 0.0005}})");
  ASSERT_TRUE(SerialSettingsFromMeta(meta, "meta.json", &from_meta).ok());
  EXPECT_EQ(from_meta.x4.baud_rate, 230400.0);
  EXPECT_EQ(from_meta.x4.latency, Duration(500'000));
  EXPECT_EQ(decode(from_meta, frame91).imu[0].time, kT0 - Duration(2'779'514));
  EXPECT_EQ(decode(from_meta, frame91).wheels[0].time, kT0);

  // Strict: unknown keys, wrong types, out-of-range values.
  for (const char* bad : {R"({"serial": {"imu_bud": 9600}})", R"({"serial": {"imu_baud": "fast"}})",
                          R"({"serial": {"motor_baud": -1}})",
                          R"({"serial": {"imu_latency_s": 2}})", R"({"serial": 5})"}) {
    meta.settings = nlohmann::json::parse(bad);
    TelemetryDecoderOptions x;
    const Status st = SerialSettingsFromMeta(meta, "s/meta.json", &x);
    EXPECT_FALSE(st.ok()) << bad;
    EXPECT_NE(st.message().find("s/meta.json: settings.serial"), std::string::npos) << st.message();
    EXPECT_EQ(x.imu_baud, 115200.0) << bad;  // Untouched on error.
  }
}

TEST(TelemetryDecoderTest, OtherMessagesAndUnknownDevicesAreIgnoredAndCounted) {
  TelemetryDecoder d(Options());
  LinkMessage m;
  m.payload = Heartbeat{};
  d.Add(m);
  d.AddTelemetry(Telemetry{9, kT0, Bytes{1, 2, 3}});
  SensorLog log;
  d.TakeInto(&log);
  EXPECT_TRUE(log.scans.empty() && log.imu.empty() && log.wheels.empty());
  EXPECT_EQ(d.stats().other_messages, 1u);
  EXPECT_EQ(d.stats().unknown_device_messages, 1u);
}

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/sweepscan_telemetry_test_XXXXXX";
    path_ = ::mkdtemp(tmpl);
  }
  ~TempDir() { sweepscan::testing::ShellOrFail("rm -rf '" + path_ + "'"); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

TEST(DecodeSessionTest, RecordedFramesDecodeWithTheSessionsGeometry) {
  TempDir tmp;
  const std::string dir = tmp.path() + "/rec.sweepscan";
  SessionMeta meta;
  meta.geometry.wheel_distance_m = kWheelDistance;
  meta.lidar_angle_convention = Options().lidar_angle_convention;
  std::unique_ptr<SessionWriter> w;
  ASSERT_TRUE(SessionWriter::Create(dir, meta, SessionWriterOptions(), &w).ok());
  LinkEncoder agent(LinkSender::kAgent);
  LinkEncoder client(LinkSender::kClient);
  int64_t wall = 1700000000000000000;
  ASSERT_TRUE(w->Append(agent.Encode(kT0, Hello{1, false, "sim", {}}), wall++).ok());
  ASSERT_TRUE(
      w->Append(client.EncodeHeartbeat(kT0), wall++).ok());  // Sent frames may be recorded too.
  const auto telemetry = MakeTelemetry();
  for (size_t i = 0; i < telemetry.size(); ++i) {
    const Telemetry& t = telemetry[i];
    if (i == 4) agent.Encode(kT0, Heartbeat{});  // A frame lost on the link: a sequence gap.
    ASSERT_TRUE(w->Append(agent.EncodeTelemetry(t.receive_time, LinkDevice(t.device),
                                                t.receive_time, t.bytes.data(), t.bytes.size()),
                          wall++)
                    .ok());
  }
  ASSERT_TRUE(
      w->Append(Bytes{0xE7, 0x5C, 1, 2, 3}, wall++).ok());  // Not a frame: refused, skipped.
  ASSERT_TRUE(w->Close().ok());

  SensorLog log;
  SessionDecodeInfo info;
  const Status s = DecodeSession(dir, &log, &info);
  ASSERT_TRUE(s.ok()) << s.message();
  ExpectExpectedLog(log, Options());
  EXPECT_EQ(info.frames.records, 12u);
  EXPECT_EQ(info.frames_refused, 1u);
  EXPECT_NE(info.first_refusal.find("record 11: link frame"), std::string::npos)
      << info.first_refusal;
  EXPECT_EQ(info.link.sequence[0].gaps, 1u);
  EXPECT_EQ(info.link.sequence[0].frames_missing, 1u);
  EXPECT_EQ(info.link.sequence[1].frames, 1u);
  EXPECT_EQ(info.telemetry.telemetry_messages, 9u);
  EXPECT_EQ(info.telemetry.other_messages, 2u);
  EXPECT_EQ(info.first_robot_time, kT0);
  EXPECT_EQ(info.meta.geometry.wheel_distance_m, kWheelDistance);
  EXPECT_FALSE(info.ToString().empty());

  // A corrupt session is an error, not a crash.
  SensorLog unused;
  EXPECT_FALSE(DecodeSession(tmp.path() + "/missing.sweepscan", &unused, &info).ok());
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
