// Decoded sensor records as the pose filter and the assembler consume them.
// Times are robot time (the agent's clock at reception, corrected for the
// device's known latency by the decoder).
#ifndef SWEEPSCAN_CORE_ROBOT_SENSOR_DATA_H_
#define SWEEPSCAN_CORE_ROBOT_SENSOR_DATA_H_

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <utility>
#include <vector>

#include "core/common/time.h"

namespace sweepscan {

// Wheel rim speeds, averaged over the encoder period that ends at `time`.
struct WheelSpeedMeasurement {
  Time time;
  double left_mps = 0.0;
  double right_mps = 0.0;
};

// One IMU output (HI219). Angles in radians, rates in rad/s, in the body
// frame (the IMU is mounted parallel to the body axes). The yaw is in the
// IMU's own heading reference; the pose estimator aligns it at start-up.
struct ImuMeasurement {
  Time time;
  double gyro_z = 0.0;
  double roll = 0.0;
  double pitch = 0.0;
  double yaw = 0.0;
  bool has_gyro = true;
  bool has_attitude = true;
};

// One lidar return. `theta` is the scan angle of Eq. 1 (radians, from the
// vertical); range 0 means "no return" (the X4 reports invalid samples so).
struct LidarSample {
  Time time;
  float range_m = 0.0f;
  float theta = 0.0f;
  uint16_t beam = 0;  // index within its scan
  // Return strength in the lidar's own units; 0 where the lidar reports none
  // (the X4). Kept from imported recordings (sensor_msgs/LaserScan
  // intensities); fits in the struct's padding (24 bytes either way).
  float intensity = 0.0f;
};

// One revolution of the lidar, samples in time order.
struct LidarScan {
  uint32_t index = 0;
  std::vector<LidarSample> samples;

  Time start_time() const { return samples.empty() ? Time() : samples.front().time; }
  Time end_time() const { return samples.empty() ? Time() : samples.back().time; }
};

// The scans looked up by index (a cloud point's `scan`). An imported
// recording's indices are whatever its file says: a table sized by the
// largest would be 32 GiB for one scan numbered 2^32 - 2 (and wrap to
// nothing at 2^32 - 1), so this holds one entry a scan, sorted. Of scans
// sharing an index, the last in the log is found.
class ScansByIndex {
 public:
  explicit ScansByIndex(const std::vector<LidarScan>& scans) {
    sorted_.reserve(scans.size());
    for (const LidarScan& s : scans) sorted_.emplace_back(s.index, &s);
    std::stable_sort(sorted_.begin(), sorted_.end(),
                     [](const Entry& a, const Entry& b) { return a.first < b.first; });
  }
  const LidarScan* Find(uint32_t index) const {
    const auto after = std::upper_bound(
        sorted_.begin(), sorted_.end(), index,
        [](uint32_t i, const Entry& e) { return i < e.first; });
    if (after == sorted_.begin() || std::prev(after)->first != index) return nullptr;
    return std::prev(after)->second;
  }

 private:
  using Entry = std::pair<uint32_t, const LidarScan*>;
  std::vector<Entry> sorted_;
};

// Everything a recording produced, in time order per stream.
struct SensorLog {
  std::vector<WheelSpeedMeasurement> wheels;
  std::vector<ImuMeasurement> imu;
  std::vector<LidarScan> scans;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_ROBOT_SENSOR_DATA_H_
