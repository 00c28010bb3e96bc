#include "core/session/measurements.h"

#include <algorithm>
#include <cstring>
#include <limits>

namespace sweepscan {
namespace {

template <typename T>
void Put(T v, std::vector<uint8_t>* out) {
  // Little-endian on every platform sweepscan builds for (x86-64, arm64).
  uint8_t b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out->insert(out->end(), b, b + sizeof(T));
}

// Bounds-checked little-endian reads over one record.
class Reader {
 public:
  Reader(const uint8_t* data, size_t n) : data_(data), n_(n) {}
  template <typename T>
  T Get() {
    T v{};
    std::memcpy(&v, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  size_t left() const { return n_ - pos_; }

 private:
  const uint8_t* data_;
  size_t n_;
  size_t pos_ = 1;  // after the type byte
};

constexpr size_t kTwistBytes = 1 + 8 + 8 + 8;
constexpr size_t kImuBytes = 1 + 8 + 1 + 4 * 8;
constexpr size_t kScanHeaderBytes = 1 + 4 + 8 + 4;
constexpr size_t kSampleBytes = 4 + 4 + 4 + 2 + 4;

void Note(Time t, MeasurementDecodeStats* s) {
  if (!s->has_time || t < s->first_time) s->first_time = t;
  if (!s->has_time || t > s->last_time) s->last_time = t;
  s->has_time = true;
}

}  // namespace

void EncodeTwistRecord(const TwistMeasurement& m, std::vector<uint8_t>* out) {
  out->clear();
  Put<uint8_t>(static_cast<uint8_t>(MeasurementType::kTwist), out);
  Put<int64_t>(ToNanoseconds(m.time), out);
  Put<double>(m.v_mps, out);
  Put<double>(m.w_radps, out);
}

void EncodeImuRecord(const ImuMeasurement& m, std::vector<uint8_t>* out) {
  out->clear();
  Put<uint8_t>(static_cast<uint8_t>(MeasurementType::kImu), out);
  Put<int64_t>(ToNanoseconds(m.time), out);
  Put<uint8_t>(static_cast<uint8_t>((m.has_gyro ? 1 : 0) | (m.has_attitude ? 2 : 0)), out);
  Put<double>(m.gyro_z, out);
  Put<double>(m.roll, out);
  Put<double>(m.pitch, out);
  Put<double>(m.yaw, out);
}

Status EncodeScanRecord(const LidarScan& scan, std::vector<uint8_t>* out) {
  out->clear();
  if (scan.samples.size() > 65535) {
    return Status::Error("scan " + std::to_string(scan.index) + ": " +
                         std::to_string(scan.samples.size()) + " samples (at most 65535)");
  }
  const int64_t start = scan.samples.empty() ? 0 : ToNanoseconds(scan.samples.front().time);
  // Sized once and filled in place: an hour of scans is a third of a
  // gigabyte, written a field at a time.
  out->resize(kScanHeaderBytes + kSampleBytes * scan.samples.size());
  uint8_t* p = out->data();
  auto put = [&p](const auto& v) {
    std::memcpy(p, &v, sizeof(v));
    p += sizeof(v);
  };
  put(static_cast<uint8_t>(MeasurementType::kScan));
  put(scan.index);
  put(start);
  put(static_cast<uint32_t>(scan.samples.size()));
  for (const LidarSample& s : scan.samples) {
    const int64_t dt = ToNanoseconds(s.time) - start;
    if (dt < std::numeric_limits<int32_t>::min() || dt > std::numeric_limits<int32_t>::max()) {
      out->clear();
      return Status::Error("scan " + std::to_string(scan.index) + ": spans more than 2.1 s");
    }
    put(static_cast<int32_t>(dt));
    put(s.range_m);
    put(s.theta);
    put(s.beam);
    put(s.intensity);
  }
  return Status::Ok();
}

bool DecodeMeasurementRecord(const uint8_t* data, size_t n, const RobotGeometry& geometry,
                             SensorLog* log, std::string* why) {
  if (n == 0) {
    *why = "empty record";
    return false;
  }
  Reader r(data, n);
  switch (static_cast<MeasurementType>(data[0])) {
    case MeasurementType::kTwist: {
      if (n != kTwistBytes) {
        *why = "twist record: " + std::to_string(n) + " bytes, expected " +
               std::to_string(kTwistBytes);
        return false;
      }
      WheelSpeedMeasurement w;
      w.time = TimeFromNanoseconds(r.Get<int64_t>());
      Twist2d t;
      t.v = r.Get<double>();
      t.w = r.Get<double>();
      WheelsFromTwist(t, geometry.wheel_distance_m, &w.left_mps, &w.right_mps);
      log->wheels.push_back(w);
      return true;
    }
    case MeasurementType::kImu: {
      if (n != kImuBytes) {
        *why = "IMU record: " + std::to_string(n) + " bytes, expected " + std::to_string(kImuBytes);
        return false;
      }
      ImuMeasurement m;
      m.time = TimeFromNanoseconds(r.Get<int64_t>());
      const uint8_t flags = r.Get<uint8_t>();
      m.has_gyro = (flags & 1) != 0;
      m.has_attitude = (flags & 2) != 0;
      m.gyro_z = r.Get<double>();
      m.roll = r.Get<double>();
      m.pitch = r.Get<double>();
      m.yaw = r.Get<double>();
      log->imu.push_back(m);
      return true;
    }
    case MeasurementType::kScan: {
      if (n < kScanHeaderBytes) {
        *why = "scan record: " + std::to_string(n) + " bytes, shorter than its 17-byte header";
        return false;
      }
      LidarScan scan;
      scan.index = r.Get<uint32_t>();
      const int64_t start = r.Get<int64_t>();
      const uint32_t count = r.Get<uint32_t>();
      if (r.left() != static_cast<uint64_t>(count) * kSampleBytes) {
        *why = "scan record: " + std::to_string(n) + " bytes, needs " +
               std::to_string(kScanHeaderBytes + static_cast<uint64_t>(count) * kSampleBytes) +
               " for " + std::to_string(count) + " samples";
        return false;
      }
      scan.samples.resize(count);
      for (LidarSample& s : scan.samples) {
        int64_t t = 0;
        // A start near the int64 limits plus an offset overflowed (undefined).
        if (__builtin_add_overflow(start, int64_t{r.Get<int32_t>()}, &t)) {
          *why = "scan record: a sample's time is beyond the range of nanoseconds";
          return false;
        }
        s.time = TimeFromNanoseconds(t);
        s.range_m = r.Get<float>();
        s.theta = r.Get<float>();
        s.beam = r.Get<uint16_t>();
        s.intensity = r.Get<float>();
      }
      log->scans.push_back(std::move(scan));
      return true;
    }
  }
  *why = "unknown measurement type " + std::to_string(data[0]);
  return false;
}

void DecodeMeasurementRecords(const std::vector<SessionRecord>& records,
                              const RobotGeometry& geometry, SensorLog* log,
                              MeasurementDecodeStats* stats) {
  MeasurementDecodeStats st;
  SensorLog out;
  for (size_t i = 0; i < records.size(); ++i) {
    const std::vector<uint8_t>& b = records[i].bytes;
    std::string why;
    if (!DecodeMeasurementRecord(b.data(), b.size(), geometry, &out, &why)) {
      if (st.refused++ == 0) st.first_refusal = "record " + std::to_string(i) + ": " + why;
    }
  }
  // The importer writes each stream in time order; a hand-made or merged
  // file may not, and every consumer needs it (stable: ties keep file order).
  auto by_time = [](const auto& a, const auto& b) { return a.time < b.time; };
  std::stable_sort(out.wheels.begin(), out.wheels.end(), by_time);
  std::stable_sort(out.imu.begin(), out.imu.end(), by_time);
  std::stable_sort(out.scans.begin(), out.scans.end(), [](const LidarScan& a, const LidarScan& b) {
    return a.start_time() < b.start_time();
  });
  for (const WheelSpeedMeasurement& w : out.wheels) Note(w.time, &st);
  for (const ImuMeasurement& m : out.imu) Note(m.time, &st);
  for (const LidarScan& s : out.scans) {
    st.samples += s.samples.size();
    if (s.samples.empty()) continue;
    Note(s.start_time(), &st);
    Note(s.end_time(), &st);
  }
  st.twists = out.wheels.size();
  st.imu = out.imu.size();
  st.scans = out.scans.size();
  *log = std::move(out);
  if (stats != nullptr) *stats = st;
}

}  // namespace sweepscan
