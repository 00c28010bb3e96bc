// Decoded sensor measurements as session records: the content of a session
// whose meta.json says "content": "measurements" (docs/session-format.md,
// "Measurement records"). An imported ROS bag becomes such a session, so
// everything that opens sessions (info, reconstruct, calibrate, evaluate,
// repair, the app) opens it through the same frames.bin container, with its
// CRCs, torn-tail and damage handling.
//
// Three record types, little-endian (byte 0 is the type):
//   1 twist: i64 time_ns, f64 v_mps, f64 w_radps           (25 bytes)
//   2 IMU:   i64 time_ns, u8 flags (1 gyro, 2 attitude), f64 gyro_z,
//            f64 roll, f64 pitch, f64 yaw                   (42 bytes)
//   3 scan:  u32 index, i64 start_ns, u32 n, then n samples of
//            i32 dt_ns (from start_ns), f32 range_m, f32 theta, u16 beam,
//            f32 intensity                                  (17 + 18 n bytes)
// A twist becomes a WheelSpeedMeasurement through the session's wheel
// distance d (Eq. 2-3 inverted: v_l = v - w d, v_r = v + w d), which the
// pose estimator turns back into the same v, w (to rounding).
//
// Pure functions; any thread.
#ifndef SWEEPSCAN_CORE_SESSION_MEASUREMENTS_H_
#define SWEEPSCAN_CORE_SESSION_MEASUREMENTS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/robot/robot_model.h"
#include "core/robot/sensor_data.h"
#include "core/session/session.h"

namespace sweepscan {

enum class MeasurementType : uint8_t { kTwist = 1, kImu = 2, kScan = 3 };

struct TwistMeasurement {
  Time time;
  double v_mps = 0.0;
  double w_radps = 0.0;
};

void EncodeTwistRecord(const TwistMeasurement& m, std::vector<uint8_t>* out);
void EncodeImuRecord(const ImuMeasurement& m, std::vector<uint8_t>* out);
// Fails for scans of more than 65535 samples or spanning more than +-2.1 s
// (the i32 time offsets).
Status EncodeScanRecord(const LidarScan& scan, std::vector<uint8_t>* out);

// What decoding a measurement session found.
struct MeasurementDecodeStats {
  uint64_t twists = 0, imu = 0, scans = 0, samples = 0;
  uint64_t refused = 0;        // records that are not one valid measurement
  std::string first_refusal;   // "record 12: scan record: 40 bytes, needs 53 for 2 samples"
  Time first_time, last_time;  // earliest / latest measurement time
  bool has_time = false;
};

// Decodes the records of a measurement session into a SensorLog (streams in
// time order as recorded; twists become wheel speeds through
// geometry.wheel_distance_m). Invalid records are counted and skipped.
void DecodeMeasurementRecords(const std::vector<SessionRecord>& records,
                              const RobotGeometry& geometry, SensorLog* log,
                              MeasurementDecodeStats* stats);
// One record; false with *why on a malformed one.
bool DecodeMeasurementRecord(const uint8_t* data, size_t n, const RobotGeometry& geometry,
                             SensorLog* log, std::string* why);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_SESSION_MEASUREMENTS_H_
