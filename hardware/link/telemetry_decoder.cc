#include "hardware/link/telemetry_decoder.h"

#include <cmath>
#include <sstream>

#include "core/common/json_reader.h"

namespace sweepscan {
namespace hardware {

bool TelemetryDecoderOptions::IsValid(std::string* error) const {
  if (!(wheel_distance_m > 0.0) || !std::isfinite(wheel_distance_m)) {
    *error = "wheel_distance_m must be > 0";
    return false;
  }
  if (lidar_angle_convention.sign != 1 && lidar_angle_convention.sign != -1) {
    *error = "lidar_angle_convention.sign must be 1 or -1";
    return false;
  }
  if (!(imu_baud >= 0) || !std::isfinite(imu_baud) || !(motor_baud >= 0) ||
      !std::isfinite(motor_baud)) {
    *error = "imu_baud and motor_baud must be finite and >= 0";
    return false;
  }
  return x4.IsValid(error);
}

Status SerialSettingsFromMeta(const SessionMeta& meta, const std::string& source,
                              TelemetryDecoderOptions* options) {
  const nlohmann::json& settings = meta.settings;
  if (!settings.is_object() || !settings.contains("serial")) return Status::Ok();
  TelemetryDecoderOptions o = *options;
  try {
    const JsonObject root(settings, "settings");
    const JsonObject serial = root.Object("serial");
    serial.AllowOnly({"lidar_baud", "imu_baud", "motor_baud", "lidar_latency_s", "imu_latency_s",
                      "motor_latency_s"});
    const auto baud = [&serial](const char* key, double* out) {
      if (serial.Has(key)) *out = serial.InRange(key, 0.0, 1e9, *out);
    };
    const auto latency = [&serial](const char* key, Duration* out) {
      if (serial.Has(key)) *out = FromSeconds(serial.InRange(key, 0.0, 1.0, 0.0));
    };
    baud("lidar_baud", &o.x4.baud_rate);
    baud("imu_baud", &o.imu_baud);
    baud("motor_baud", &o.motor_baud);
    latency("lidar_latency_s", &o.x4.latency);
    latency("imu_latency_s", &o.imu_latency);
    latency("motor_latency_s", &o.motor_latency);
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  *options = o;
  return Status::Ok();
}

std::string TelemetryDecoderStats::ToString() const {
  std::ostringstream s;
  s << "telemetry=" << telemetry_messages << " other=" << other_messages
    << " unknown_device=" << unknown_device_messages
    << " bytes(lidar/imu/motor)=" << device_bytes[0] << "/" << device_bytes[1] << "/"
    << device_bytes[2] << "\n  x4: " << x4.ToString() << "\n  hi219: " << hi219.ToString()
    << "\n  motor: " << motor.ToString();
  return s.str();
}

namespace {
X4DecoderOptions ScansOnly(X4DecoderOptions o) {
  o.keep_packets = false;
  return o;
}
}  // namespace

TelemetryDecoder::TelemetryDecoder(const TelemetryDecoderOptions& options)
    : options_(options), x4_(ScansOnly(options.x4)) {}

void TelemetryDecoder::Add(const LinkMessage& message) {
  if (message.header.sender == LinkSender::kAgent) {
    last_robot_time_ = std::max(last_robot_time_, message.header.time + time_shift_);
  }
  if (const auto* t = std::get_if<Telemetry>(&message.payload)) {
    AddTelemetry(*t);
    return;
  }
  ++stats_.other_messages;
  const auto* event = std::get_if<RecorderEvent>(&message.payload);
  if (event == nullptr || message.header.sender != LinkSender::kClient) return;
  if (event->kind == RecorderEventKind::kLinkLost) {
    SessionLinkGap gap;
    gap.lost_at_s = ToSeconds(last_robot_time_);
    gap.reason = event->reason;
    gaps_.push_back(gap);
    return;
  }
  if (gaps_.empty() || gaps_.back().restored) gaps_.emplace_back();  // A lost event was cut off.
  SessionLinkGap& gap = gaps_.back();
  gap.restored = true;
  gap.outage_s = ToSeconds(event->outage);
  gap.attempts = event->attempts;
  gap.resumed = event->resumed;
  gap.new_clock_epoch = event->new_clock_epoch;
  gap.epoch = event->epoch;
  gap.robot_time_shift_s = ToSeconds(event->robot_time_shift);
  gap.tie_uncertainty_s = ToSeconds(event->tie_uncertainty);
  SetTimeShift(event->robot_time_shift);
}

void TelemetryDecoder::AddTelemetry(const Telemetry& telemetry_in) {
  ++stats_.telemetry_messages;
  Telemetry shifted;
  const Telemetry* tp = &telemetry_in;
  if (time_shift_.count() != 0) {
    shifted = telemetry_in;
    shifted.receive_time += time_shift_;
    tp = &shifted;
  }
  const Telemetry& t = *tp;
  if (t.device >= 1 && t.device <= 3) {
    const int d = t.device - 1;
    if (t.flags & kTelemetryLate) {
      ++stats_.late_messages;
      stats_.late_bytes += t.bytes.size();
      if (!gaps_.empty()) {
        ++gaps_.back().late_messages;
        gaps_.back().late_bytes += t.bytes.size();
      }
    }
    if ((t.flags & kTelemetryBreak) && have_time_[d]) {
      // The agent says bytes of this device before these were lost: a frame
      // cut there must not be spliced onto these bytes. (A break before the
      // device's first bytes, as an agent marks a new client's first chunk
      // when nothing joins it to bytes the client had, breaks nothing.)
      ++stats_.breaks;
      if (d == 0) x4_.Reset();
      if (d == 1) hi219_.Reset();
      if (d == 2) motor_.Reset();
      if (!gaps_.empty()) {
        gaps_.back().data_lost_s[d] += std::max(0.0, ToSeconds(t.receive_time - last_time_[d]));
      }
    }
    have_time_[d] = true;
    last_time_[d] = t.receive_time;
  }
  switch (static_cast<LinkDevice>(t.device)) {
    case LinkDevice::kLidar: {
      stats_.device_bytes[0] += t.bytes.size();
      if (!options_.decode_lidar) break;
      x4_.Feed(t.bytes, t.receive_time);
      for (X4Scan& scan : x4_.TakeScans()) {
        LidarScan out;
        out.index = static_cast<uint32_t>(scan.index);
        out.samples.reserve(scan.samples.size());
        for (size_t i = 0; i < scan.samples.size(); ++i) {
          const X4Sample& s = scan.samples[i];
          LidarSample ls;
          ls.time = s.time;
          ls.range_m = s.valid ? static_cast<float>(s.distance_mm * 1e-3) : 0.0f;
          ls.theta =
              static_cast<float>(options_.lidar_angle_convention.ThetaFromX4Degrees(s.angle_deg));
          ls.beam = static_cast<uint16_t>(i);
          out.samples.push_back(ls);
        }
        pending_.scans.push_back(std::move(out));
      }
      break;
    }
    case LinkDevice::kImu: {
      stats_.device_bytes[1] += t.bytes.size();
      if (!options_.decode_motion) break;
      hi219_.Feed(t.bytes, t.receive_time);
      for (const ImuSample& s : hi219_.TakeSamples()) {
        ImuMeasurement m;
        m.time = s.receive_time - options_.imu_latency -
                 SerialTransmissionTime(static_cast<double>(s.frame_bytes), options_.imu_baud);
        m.has_gyro = s.Has(kImuGyro);
        m.has_attitude = s.Has(kImuEuler);
        if (!m.has_gyro && !m.has_attitude) {
          ++stats_.imu_samples_without_data;
          continue;
        }
        m.gyro_z = s.gyro_radps[2];
        m.roll = s.roll_rad;
        m.pitch = s.pitch_rad;
        m.yaw = s.yaw_rad;
        pending_.imu.push_back(m);
      }
      break;
    }
    case LinkDevice::kMotorBoard: {
      stats_.device_bytes[2] += t.bytes.size();
      if (!options_.decode_motion) break;
      motor_.Feed(t.bytes, t.receive_time);
      for (const MotorFeedback& f : motor_.TakeRecords()) {
        WheelSpeedMeasurement w;
        w.time =
            f.receive_time - options_.motor_latency -
            SerialTransmissionTime(static_cast<double>(kMotorFeedbackSize), options_.motor_baud);
        WheelsFromTwist(Twist2d{f.vx_mps, f.wz_radps}, options_.wheel_distance_m, &w.left_mps,
                        &w.right_mps);
        pending_.wheels.push_back(w);
      }
      break;
    }
    default:
      ++stats_.unknown_device_messages;
      break;
  }
}

void TelemetryDecoder::TakeInto(SensorLog* log) {
  auto move_append = [](auto* from, auto* to) {
    to->insert(to->end(), std::make_move_iterator(from->begin()),
               std::make_move_iterator(from->end()));
    from->clear();
  };
  move_append(&pending_.wheels, &log->wheels);
  move_append(&pending_.imu, &log->imu);
  move_append(&pending_.scans, &log->scans);
}

TelemetryDecoderStats TelemetryDecoder::stats() const {
  TelemetryDecoderStats s = stats_;
  s.x4 = x4_.stats();
  s.hi219 = hi219_.stats();
  s.motor = motor_.stats();
  return s;
}

std::string SessionLinkGap::ToString() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << "link lost " << lost_at_s << " s into the recording (" << reason << ")";
  if (!restored) {
    s << "; the recording ended before it came back";
    return s.str();
  }
  s << "; restored after " << outage_s << " s (" << attempts << " attempt"
    << (attempts == 1 ? "" : "s") << ")";
  if (new_clock_epoch) {
    s.precision(3);
    s << "; robot clock reset: epoch " << epoch << ", shifted " << robot_time_shift_s << " s +-";
    s.precision(1);
    s << tie_uncertainty_s * 1e3 << " ms";
    s.precision(1);
  }
  if (late_messages > 0) s << "; " << late_bytes << " bytes resent from the robot's buffer";
  static const char* kNames[3] = {"lidar", "IMU", "motor board"};
  bool lost = false;
  for (int d = 0; d < 3; ++d) {
    if (data_lost_s[d] <= 0.0) continue;
    s << (lost ? ", " : "; data lost: ") << kNames[d] << " " << data_lost_s[d] << " s";
    lost = true;
  }
  if (!lost) s << "; no data lost";
  return s.str();
}

std::string SessionDecodeInfo::ToString() const {
  std::ostringstream s;
  s << "frames.bin: " << frames.ToString() << "\n";
  if (measurements) {
    const MeasurementDecodeStats& m = measurement_stats;
    s << "content: decoded measurements (" << m.scans << " scans, " << m.samples << " samples, "
      << m.imu << " IMU, " << m.twists << " odometry twists)\n";
    if (frames_refused > 0)
      s << "records refused: " << frames_refused << " (first: " << first_refusal << ")\n";
    s << "robot time: " << ToSeconds(first_robot_time) << " .. " << ToSeconds(last_robot_time)
      << " s";
    return s.str();
  }
  s << "link: " << link.ToString() << "\n";
  if (frames_refused > 0)
    s << "records refused: " << frames_refused << " (first: " << first_refusal << ")\n";
  s << "robot time: " << ToSeconds(first_robot_time) << " .. " << ToSeconds(last_robot_time)
    << " s\n";
  s << "telemetry: " << telemetry.ToString();
  if (telemetry.late_messages > 0 || telemetry.breaks > 0) {
    s << "\n  resent after outages: " << telemetry.late_messages << " messages, "
      << telemetry.late_bytes << " bytes; breaks " << telemetry.breaks;
  }
  for (const SessionLinkGap& gap : gaps) s << "\ngap: " << gap.ToString();
  return s.str();
}

namespace {

// Decodes a session's records one at a time (each parsed strictly on its
// own, so a bad record cannot swallow the next one), handing what is
// decoded to the sinks every 256 records.
class SessionRecordDecoder {
 public:
  SessionRecordDecoder(const TelemetryDecoderOptions& options, const SessionStreamSinks& sinks,
                       SessionDecodeInfo* info)
      : decoder_(OnlyWhatIsTaken(options, sinks)), sinks_(sinks), info_(info) {}

  // False when the scan sink stopped the decode.
  bool Add(uint64_t ordinal, const uint8_t* bytes, size_t n) {
    LinkMessage m;
    const Status s = ParseLinkFrame(bytes, n, &m);
    if (!s.ok()) {
      if (info_->frames_refused++ == 0)
        info_->first_refusal = "record " + std::to_string(ordinal) + ": " + s.message();
      ++records_;
      return true;
    }
    // The link decoder only keeps the sequence accounting.
    const int k = m.header.sender == LinkSender::kAgent ? 0 : 1;
    trackers_[k].Observe(m.header.sequence);
    decoder_.Add(m);
    if (k == 0) {
      // On the first clock epoch's timeline (a reboot's epoch is shifted).
      const Time t = m.header.time + decoder_.time_shift();
      if (!have_time_) info_->first_robot_time = t;
      info_->last_robot_time = have_time_ ? std::max(info_->last_robot_time, t) : t;
      have_time_ = true;
    }
    return (records_++ & 255) != 0 || Hand();
  }

  bool Finish() {
    if (!Hand()) return false;
    info_->gaps = decoder_.gaps();
    // Said in seconds into the recording (the robot clock's origin is its boot).
    for (SessionLinkGap& gap : info_->gaps) gap.lost_at_s -= ToSeconds(info_->first_robot_time);
    for (int k = 0; k < 2; ++k) info_->link.sequence[k] = trackers_[k].stats();
    info_->link.codec.frames_ok = records_ - info_->frames_refused;
    info_->link.codec.payload_errors = info_->frames_refused;
    info_->telemetry = decoder_.stats();
    return true;
  }

 private:
  // A device nobody takes records of is not decoded.
  static TelemetryDecoderOptions OnlyWhatIsTaken(TelemetryDecoderOptions options,
                                                 const SessionStreamSinks& sinks) {
    if (!sinks.scan) options.decode_lidar = false;
    if (sinks.motion == nullptr) options.decode_motion = false;
    return options;
  }

  bool Hand() {
    decoder_.TakeInto(&taken_);
    if (sinks_.motion != nullptr) {
      SensorLog* m = sinks_.motion;
      m->wheels.insert(m->wheels.end(), taken_.wheels.begin(), taken_.wheels.end());
      m->imu.insert(m->imu.end(), taken_.imu.begin(), taken_.imu.end());
    }
    bool go = true;
    for (LidarScan& scan : taken_.scans) {
      if (go && sinks_.scan) go = sinks_.scan(std::move(scan));
    }
    taken_.wheels.clear();
    taken_.imu.clear();
    taken_.scans.clear();
    return go;
  }

  TelemetryDecoder decoder_;
  const SessionStreamSinks& sinks_;
  SessionDecodeInfo* info_;
  std::array<SequenceTracker, 2> trackers_;
  bool have_time_ = false;
  uint64_t records_ = 0;
  SensorLog taken_;
};

// Sinks that keep everything in *log (DecodeSession).
SessionStreamSinks KeepAll(SensorLog* log) {
  SessionStreamSinks sinks;
  sinks.motion = log;
  sinks.scan = [log](LidarScan&& scan) {
    log->scans.push_back(std::move(scan));
    return true;
  };
  return sinks;
}

}  // namespace

bool DecodeSessionRecords(const std::vector<SessionRecord>& records,
                          const TelemetryDecoderOptions& options, SensorLog* log,
                          SessionDecodeInfo* info, const DecodeProgress& progress) {
  const SessionStreamSinks sinks = KeepAll(log);
  SessionRecordDecoder decoder(options, sinks, info);
  for (size_t i = 0; i < records.size(); ++i) {
    if (progress && (i & 4095) == 0 && !progress(static_cast<double>(i) / records.size())) {
      return false;
    }
    decoder.Add(i, records[i].bytes.data(), records[i].bytes.size());
  }
  return decoder.Finish();
}

Status DecodeSessionStreaming(const std::string& session_dir, const TelemetryDecoderOptions& options,
                              const FramesLoadOptions& frames_options, const SessionStreamSinks& sinks,
                              SessionDecodeInfo* info, const DecodeProgress& progress) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(session_dir + ": decoder options: " + error);
  if (progress && !progress(0.0)) return Status::Error(session_dir + ": cancelled");
  const std::string sep = session_dir.empty() || session_dir.back() == '/' ? "" : "/";
  SessionDecodeInfo result;
  Status s = ReadSessionMeta(session_dir + sep + kSessionMetaFile, &result.meta);
  if (!s.ok()) return s;
  if (result.meta.content == kSessionContentMeasurements) {
    // An imported recording: the records are measurements, decoded together
    // (docs/ros-bags.md), so the whole session is loaded; bags are imported
    // in pieces an operator chose, not 10-hour drives.
    Session session;
    s = LoadSession(session_dir, frames_options, &session);
    if (!s.ok()) return s;
    result.frames = session.frames;
    SensorLog decoded;
    DecodeMeasurementRecords(session.records, session.meta.geometry, &decoded, &result.measurement_stats);
    session.records.clear();
    result.measurements = true;
    result.frames_refused = result.measurement_stats.refused;
    result.first_refusal = result.measurement_stats.first_refusal;
    result.first_robot_time = result.measurement_stats.first_time;
    result.last_robot_time = result.measurement_stats.last_time;
    if (sinks.motion != nullptr) {
      sinks.motion->wheels = std::move(decoded.wheels);
      sinks.motion->imu = std::move(decoded.imu);
    }
    for (LidarScan& scan : decoded.scans) {
      if (sinks.scan && !sinks.scan(std::move(scan))) return Status::Error(session_dir + ": cancelled");
    }
    if (progress) progress(1.0);
    if (info != nullptr) *info = std::move(result);
    return Status::Ok();
  }
  SessionRecordDecoder decoder(options, sinks, &result);
  bool cancelled = false;  // by the progress callback or the scan sink
  s = VisitFramesFile(session_dir + sep + kSessionFramesFile, frames_options,
                      [&](const SessionRecordView& r) {
                        cancelled = (progress && (r.ordinal & 4095) == 0 &&
                                     !progress(static_cast<double>(r.offset) / static_cast<double>(r.file_bytes))) ||
                                    !decoder.Add(r.ordinal, r.bytes, r.size);
                        return !cancelled;
                      },
                      &result.frames);
  if (cancelled) return Status::Error(session_dir + ": cancelled");
  if (!s.ok()) return s;
  if (!decoder.Finish()) return Status::Error(session_dir + ": cancelled");
  if (progress) progress(1.0);
  if (info != nullptr) *info = std::move(result);
  return Status::Ok();
}

namespace {

Status DecodeSessionWithProgress(const std::string& session_dir,
                                 const TelemetryDecoderOptions& options,
                                 const FramesLoadOptions& frames_options, SensorLog* log,
                                 SessionDecodeInfo* info, const DecodeProgress& progress) {
  SensorLog decoded;
  const Status s = DecodeSessionStreaming(session_dir, options, frames_options, KeepAll(&decoded), info, progress);
  if (!s.ok()) return s;
  *log = std::move(decoded);
  return Status::Ok();
}

// The decoder options a session's meta.json implies.
Status DecoderOptionsFromMeta(const std::string& session_dir, TelemetryDecoderOptions* options) {
  SessionMeta meta;
  const std::string meta_path = session_dir +
                                (session_dir.empty() || session_dir.back() == '/' ? "" : "/") +
                                kSessionMetaFile;
  const Status s = ReadSessionMeta(meta_path, &meta);
  if (!s.ok()) return s;
  options->wheel_distance_m = meta.geometry.wheel_distance_m;
  options->lidar_angle_convention = meta.lidar_angle_convention;
  return SerialSettingsFromMeta(meta, meta_path, options);
}

Status DecodeSessionWithMeta(const std::string& session_dir,
                             const FramesLoadOptions& frames_options, SensorLog* log,
                             SessionDecodeInfo* info, const DecodeProgress& progress) {
  TelemetryDecoderOptions options;
  const Status s = DecoderOptionsFromMeta(session_dir, &options);
  if (!s.ok()) return s;
  return DecodeSessionWithProgress(session_dir, options, frames_options, log, info, progress);
}

}  // namespace

FramesLoadOptions DefaultSessionFramesOptions() {
  FramesLoadOptions options;
  options.skip_corrupt_records = true;
  return options;
}

Status DecodeSession(const std::string& session_dir, const TelemetryDecoderOptions& options,
                     SensorLog* log, SessionDecodeInfo* info) {
  return DecodeSessionWithProgress(session_dir, options, DefaultSessionFramesOptions(), log, info,
                                   nullptr);
}

Status DecodeSession(const std::string& session_dir, SensorLog* log, SessionDecodeInfo* info) {
  return DecodeSessionWithMeta(session_dir, DefaultSessionFramesOptions(), log, info, nullptr);
}

Status DecodeSession(const std::string& session_dir, SensorLog* log, SessionDecodeInfo* info,
                     const DecodeProgress& progress) {
  return DecodeSessionWithMeta(session_dir, DefaultSessionFramesOptions(), log, info, progress);
}

Status DecodeSession(const std::string& session_dir, const FramesLoadOptions& frames_options,
                     SensorLog* log, SessionDecodeInfo* info, const DecodeProgress& progress) {
  return DecodeSessionWithMeta(session_dir, frames_options, log, info, progress);
}

Status DecodeSessionStreaming(const std::string& session_dir, const FramesLoadOptions& frames_options,
                              const SessionStreamSinks& sinks, SessionDecodeInfo* info,
                              const DecodeProgress& progress) {
  TelemetryDecoderOptions options;
  const Status s = DecoderOptionsFromMeta(session_dir, &options);
  if (!s.ok()) return s;
  return DecodeSessionStreaming(session_dir, options, frames_options, sinks, info, progress);
}

}  // namespace hardware
}  // namespace sweepscan
