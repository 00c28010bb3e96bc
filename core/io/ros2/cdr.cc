#include "core/io/ros2/cdr.h"

#include <cstdio>
#include <cstring>

namespace sweepscan::io {

namespace {

constexpr size_t kEncapsulationBytes = 4;

uint32_t Swap32(uint32_t v) { return __builtin_bswap32(v); }
uint64_t Swap64(uint64_t v) { return __builtin_bswap64(v); }

constexpr bool kHostLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

}  // namespace

Status CdrReader::Error(const char* field, const std::string& why) const {
  return Status::Error(std::string(message_) + ": " + field + ": " + why);
}

Status CdrReader::ReadEncapsulation() {
  if (size_ < kEncapsulationBytes) {
    return Error("encapsulation header", "needs 4 bytes, the message has " + std::to_string(size_));
  }
  // Representation identifier, big-endian on the wire (RTPS SerializedPayload).
  const unsigned id = (unsigned{data_[0]} << 8) | data_[1];
  if (id != 0x0000 && id != 0x0001) {
    char hex[8];
    snprintf(hex, sizeof(hex), "%04x", id);
    return Error("encapsulation header",
                 std::string("representation 0x") + hex +
                     " is not supported (only CDR_BE 0x0000 and CDR_LE 0x0001, the XCDR1 "
                     "that ROS 2's rmw writes) at byte 0");
  }
  big_endian_ = id == 0x0000;
  pos_ = kEncapsulationBytes;
  return Status::Ok();
}

Status CdrReader::Prepare(const char* field, size_t alignment, size_t n) {
  const size_t rel = pos_ - kEncapsulationBytes;
  const size_t pad = (alignment - rel % alignment) % alignment;
  const size_t left = size_ - pos_;
  if (pad + n > left) {
    return Error(field, "needs " + std::to_string(pad + n) + " bytes, " + std::to_string(left) +
                            " left at byte " + std::to_string(pos_));
  }
  pos_ += pad;
  return Status::Ok();
}

uint32_t CdrReader::Load32() {
  uint32_t v;
  memcpy(&v, data_ + pos_, 4);
  pos_ += 4;
  return big_endian_ == kHostLittleEndian ? Swap32(v) : v;
}

uint64_t CdrReader::Load64() {
  uint64_t v;
  memcpy(&v, data_ + pos_, 8);
  pos_ += 8;
  return big_endian_ == kHostLittleEndian ? Swap64(v) : v;
}

Status CdrReader::ReadUint32(const char* field, uint32_t* v) {
  Status s = Prepare(field, 4, 4);
  if (!s.ok()) return s;
  *v = Load32();
  return Status::Ok();
}

Status CdrReader::ReadInt32(const char* field, int32_t* v) {
  uint32_t u;
  Status s = ReadUint32(field, &u);
  if (s.ok()) *v = static_cast<int32_t>(u);
  return s;
}

Status CdrReader::ReadFloat32(const char* field, float* v) {
  uint32_t u;
  Status s = ReadUint32(field, &u);
  if (s.ok()) memcpy(v, &u, 4);
  return s;
}

Status CdrReader::ReadFloat64(const char* field, double* v) {
  Status s = Prepare(field, 8, 8);
  if (!s.ok()) return s;
  const uint64_t u = Load64();
  memcpy(v, &u, 8);
  return Status::Ok();
}

Status CdrReader::ReadFloat64s(const char* field, double* v, size_t n) {
  // One alignment for the whole array, then the elements back to back.
  Status s = Prepare(field, 8, 8 * n);
  if (!s.ok()) return s;
  for (size_t i = 0; i < n; ++i) {
    const uint64_t u = Load64();
    memcpy(&v[i], &u, 8);
  }
  return Status::Ok();
}

Status CdrReader::ReadString(const char* field, std::string* s) {
  uint32_t length;
  Status st = ReadUint32(field, &length);
  if (!st.ok()) return st;
  const size_t left = size_ - pos_;
  if (length > left) {
    return Error(field, "string of " + std::to_string(length) + " bytes, " + std::to_string(left) +
                            " left at byte " + std::to_string(pos_));
  }
  // The length counts the terminating NUL. 0 is not CDR, but some writers
  // emit it for the empty string: taken as "".
  if (length == 0) {
    s->clear();
    return Status::Ok();
  }
  if (data_[pos_ + length - 1] != 0) {
    return Error(field, "string of " + std::to_string(length) +
                            " bytes does not end with NUL at byte " +
                            std::to_string(pos_ + length - 1));
  }
  s->assign(reinterpret_cast<const char*>(data_ + pos_), length - 1);
  pos_ += length;
  return Status::Ok();
}

Status CdrReader::ReadSequenceCount(const char* field, size_t min_element_bytes, uint32_t* count) {
  Status s = ReadUint32(field, count);
  if (!s.ok()) return s;
  const uint64_t need = uint64_t{*count} * min_element_bytes;
  const size_t left = size_ - pos_;
  if (need > left) {
    return Error(field, "sequence of " + std::to_string(*count) + " elements needs " +
                            std::to_string(need) + " bytes, " + std::to_string(left) +
                            " left at byte " + std::to_string(pos_));
  }
  return Status::Ok();
}

Status CdrReader::ReadFloat32Sequence(const char* field, std::vector<float>* v) {
  uint32_t count;
  Status s = ReadSequenceCount(field, 4, &count);
  if (!s.ok()) return s;
  // The count was read at a 4-aligned position: the elements need no padding.
  v->resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t u = Load32();
    memcpy(&(*v)[i], &u, 4);
  }
  return Status::Ok();
}

namespace {

Status ReadHeader(CdrReader* r, RosHeader* h) {
  int32_t sec;
  uint32_t nanosec;
  Status s = r->ReadInt32("header.stamp.sec", &sec);
  if (s.ok()) s = r->ReadUint32("header.stamp.nanosec", &nanosec);
  if (s.ok()) s = r->ReadString("header.frame_id", &h->frame_id);
  if (s.ok()) h->stamp_ns = int64_t{sec} * 1000000000 + nanosec;  // no overflow: |sec| < 2^31
  return s;
}

// geometry_msgs/Quaternion or Vector3/Point: consecutive float64 fields.
template <size_t N>
Status ReadDoubles(CdrReader* r, const char* field, std::array<double, N>* v) {
  return r->ReadFloat64s(field, v->data(), N);
}

}  // namespace

Status DecodeCdrLaserScan(const uint8_t* data, size_t n, RosLaserScan* m) {
  CdrReader r(data, n, "LaserScan");
  Status s = r.ReadEncapsulation();
  if (s.ok()) s = ReadHeader(&r, &m->header);
  if (s.ok()) s = r.ReadFloat32("angle_min", &m->angle_min);
  if (s.ok()) s = r.ReadFloat32("angle_max", &m->angle_max);
  if (s.ok()) s = r.ReadFloat32("angle_increment", &m->angle_increment);
  if (s.ok()) s = r.ReadFloat32("time_increment", &m->time_increment);
  if (s.ok()) s = r.ReadFloat32("scan_time", &m->scan_time);
  if (s.ok()) s = r.ReadFloat32("range_min", &m->range_min);
  if (s.ok()) s = r.ReadFloat32("range_max", &m->range_max);
  if (s.ok()) s = r.ReadFloat32Sequence("ranges", &m->ranges);
  if (s.ok()) s = r.ReadFloat32Sequence("intensities", &m->intensities);
  return s;
}

Status DecodeCdrOdometry(const uint8_t* data, size_t n, RosOdometry* m) {
  CdrReader r(data, n, "Odometry");
  Status s = r.ReadEncapsulation();
  if (s.ok()) s = ReadHeader(&r, &m->header);
  if (s.ok()) s = r.ReadString("child_frame_id", &m->child_frame_id);
  if (s.ok()) s = ReadDoubles(&r, "pose.pose.position", &m->position);
  if (s.ok()) s = ReadDoubles(&r, "pose.pose.orientation", &m->orientation);
  if (s.ok()) s = ReadDoubles(&r, "pose.covariance", &m->pose_covariance);
  if (s.ok()) s = ReadDoubles(&r, "twist.twist.linear", &m->linear_velocity);
  if (s.ok()) s = ReadDoubles(&r, "twist.twist.angular", &m->angular_velocity);
  if (s.ok()) s = ReadDoubles(&r, "twist.covariance", &m->twist_covariance);
  return s;
}

Status DecodeCdrImu(const uint8_t* data, size_t n, RosImu* m) {
  CdrReader r(data, n, "Imu");
  Status s = r.ReadEncapsulation();
  if (s.ok()) s = ReadHeader(&r, &m->header);
  if (s.ok()) s = ReadDoubles(&r, "orientation", &m->orientation);
  if (s.ok()) s = ReadDoubles(&r, "orientation_covariance", &m->orientation_covariance);
  if (s.ok()) s = ReadDoubles(&r, "angular_velocity", &m->angular_velocity);
  if (s.ok()) {
    s = ReadDoubles(&r, "angular_velocity_covariance", &m->angular_velocity_covariance);
  }
  if (s.ok()) s = ReadDoubles(&r, "linear_acceleration", &m->linear_acceleration);
  if (s.ok()) {
    s = ReadDoubles(&r, "linear_acceleration_covariance", &m->linear_acceleration_covariance);
  }
  return s;
}

Status DecodeCdrTfMessage(const uint8_t* data, size_t n, RosTfMessage* m) {
  CdrReader r(data, n, "TFMessage");
  Status s = r.ReadEncapsulation();
  uint32_t count = 0;
  // Smallest TransformStamped: stamp 8 + two empty strings 4 + 4 + 7 float64
  // 56 (padding not counted, so this is a lower bound).
  constexpr size_t kMinTransformBytes = 72;
  if (s.ok()) s = r.ReadSequenceCount("transforms", kMinTransformBytes, &count);
  if (!s.ok()) return s;
  m->transforms.assign(count, RosTransform());
  for (uint32_t i = 0; i < count && s.ok(); ++i) {
    RosTransform& t = m->transforms[i];
    s = ReadHeader(&r, &t.header);
    if (s.ok()) s = r.ReadString("transforms[].child_frame_id", &t.child_frame_id);
    if (s.ok()) s = ReadDoubles(&r, "transforms[].transform.translation", &t.translation);
    if (s.ok()) s = ReadDoubles(&r, "transforms[].transform.rotation", &t.rotation);
    if (!s.ok()) {
      s = Status::Error(s.message() + " (transform " + std::to_string(i) + " of " +
                        std::to_string(count) + ")");
    }
  }
  return s;
}

bool DispatchCdrMessage(RosMessageKind kind, const RosMessageInfo& info, const uint8_t* data,
                        size_t n, RosMessageSink* sink, RosReadStats* stats) {
  Status s;
  bool go_on = true;
  switch (kind) {
    case RosMessageKind::kLaserScan: {
      RosLaserScan m;
      s = DecodeCdrLaserScan(data, n, &m);
      if (s.ok()) go_on = sink->OnLaserScan(info, m);
      break;
    }
    case RosMessageKind::kOdometry: {
      RosOdometry m;
      s = DecodeCdrOdometry(data, n, &m);
      if (s.ok()) go_on = sink->OnOdometry(info, m);
      break;
    }
    case RosMessageKind::kImu: {
      RosImu m;
      s = DecodeCdrImu(data, n, &m);
      if (s.ok()) go_on = sink->OnImu(info, m);
      break;
    }
    case RosMessageKind::kTf: {
      RosTfMessage m;
      s = DecodeCdrTfMessage(data, n, &m);
      if (s.ok()) go_on = sink->OnTf(info, m);
      break;
    }
    case RosMessageKind::kOther:
      if (stats != nullptr) ++stats->messages_skipped;
      return true;
  }
  if (!s.ok()) {
    if (stats != nullptr) ++stats->messages_undecodable;
    sink->OnUndecodable(info, s.message());
    return true;
  }
  if (stats != nullptr) ++stats->messages_read;
  return go_on;
}

}  // namespace sweepscan::io
