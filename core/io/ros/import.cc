#include "core/io/ros/import.h"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <future>
#include <limits>
#include <map>
#include <memory>

#include "core/io/ros/import_clocks.h"
#include "core/io/ros/provenance.h"
#include "core/io/ros/ros_bag.h"
#include "core/io/ros/tf_tree.h"
#include "core/robot/robot_model.h"
#include "core/session/measurements.h"
#include "core/session/session.h"

namespace sweepscan::io {
namespace {

// A crafted bag's log time (MCAP's is a u64, read as int64) near the
// limits would overflow (undefined); saturated, its offset is simply far
// beyond any clock's, and the clock check treats it so.
int64_t SaturatingAdd(int64_t a, int64_t b) {
  int64_t r;
  if (!__builtin_add_overflow(a, b, &r)) return r;
  return b > 0 ? std::numeric_limits<int64_t>::max() : std::numeric_limits<int64_t>::min();
}
int64_t SaturatingSub(int64_t a, int64_t b) {
  int64_t r;
  if (!__builtin_sub_overflow(a, b, &r)) return r;
  return b < 0 ? std::numeric_limits<int64_t>::max() : std::numeric_limits<int64_t>::min();
}

}  // namespace

namespace {

using import_internal::CheckClocks;
using import_internal::StampCheck;

constexpr int64_t kNsPerS = 1000000000;
// A LaserScan's beams, first to last: a session's scan record holds each
// beam's time after the first in int32 ns (docs/session-format.md), 2.147 s;
// any scanning lidar turns in less.
constexpr double kMaxScanSpanS = 2.1;

// L = Ry(-pi/2) S: the ROS scan frame's x (angle 0) becomes Eq. 1's z_L
// (theta 0) and y (angle +pi/2) stays y_L, so theta = angle.
Eigen::Quaterniond LidarFromScan() {
  return Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()));
}

// Pass 1 sink: every tf message, and the first message of each sensor topic
// (their frame ids and stamps), then it stops.
class FirstPassSink : public RosMessageSink {
 public:
  explicit FirstPassSink(std::set<std::string> sensor_topics)
      : waiting_(std::move(sensor_topics)) {}
  bool OnLaserScan(const RosMessageInfo& info, const RosLaserScan& m) override {
    return First(info, m.header);
  }
  bool OnOdometry(const RosMessageInfo& info, const RosOdometry& m) override {
    if (odom_child_.empty()) odom_child_ = m.child_frame_id;
    return First(info, m.header);
  }
  bool OnImu(const RosMessageInfo& info, const RosImu& m) override { return First(info, m.header); }
  bool OnTf(const RosMessageInfo& info, const RosTfMessage& m) override {
    const bool is_static = info.topic->find("static") != std::string::npos;
    tf_.Add(m, is_static);
    // A robot's /tf carries its motion (odom -> base) at the odometry's
    // rate, all the bag long; the joints it also carries are all in its
    // first messages. Enough of them to see a joint move.
    if (!is_static && ++dynamic_tf_ >= kDynamicTfMessages) {
      tf_stopped_ = true;
      return false;
    }
    return true;
  }

  static constexpr uint64_t kDynamicTfMessages = 1000;
  uint64_t dynamic_tf_ = 0;
  bool tf_stopped_ = false;

  TfTree tf_;
  std::map<std::string, RosHeader> first_;  // topic -> header of its first message
  std::map<std::string, int64_t> first_log_;  // topic -> log time of its first message
  std::string odom_child_;
  bool stopped_early_ = false;

 private:
  bool First(const RosMessageInfo& info, const RosHeader& h) {
    if (first_.count(*info.topic) == 0) {
      first_[*info.topic] = h;
      first_log_[*info.topic] = info.log_time_ns;
    }
    waiting_.erase(*info.topic);
    if (waiting_.empty()) stopped_early_ = true;
    return !stopped_early_;
  }
  std::set<std::string> waiting_;
};

struct OdometrySample {
  int64_t t_ns;
  double x, y, yaw, v, w;
  int64_t log_ns;
};

// Pass 2 sink: converts and writes every sensor message.
class WritingSink : public RosMessageSink {
 public:
  WritingSink(SessionWriter* writer, const RosImportReport& setup, const Rigid3d& base_from_imu,
              RosImportReport* report)
      : writer_(writer), setup_(setup), base_from_imu_(base_from_imu), report_(report) {}

  bool OnLaserScan(const RosMessageInfo& info, const RosLaserScan& m) override {
    if (*info.topic != setup_.scan_topic) return true;
    const int64_t stamp = Stamp(info, m.header);
    if (!stamps_.Observe(*info.topic, stamp, scan_messages_++, report_, &error_)) {
      return false;
    }
    LidarScan scan;
    std::string why;
    if (!ConvertScan(m, stamp, &scan, &why)) {
      if (report_->scans_refused++ == 0) {
        report_->first_scan_refusal =
            *info.topic + " message " + std::to_string(scan_messages_ - 1) + ": " + why;
      }
      return true;
    }
    const Status s = EncodeScanRecord(scan, &buffer_);
    if (!s.ok() || buffer_.size() > kSessionMaxRecordBytes) {
      // A scan of more returns than a session record holds (about 58,000):
      // skipped and counted, the import goes on.
      if (s.ok()) ++report_->scans_too_large;
      const std::string why = s.ok() ? std::to_string(scan.samples.size()) + " returns make a " +
                                           std::to_string(buffer_.size()) +
                                           "-byte session record, more than its " +
                                           std::to_string(kSessionMaxRecordBytes)
                                     : s.message();
      if (report_->scans_refused++ == 0) {
        report_->first_scan_refusal =
            *info.topic + " message " + std::to_string(scan_messages_ - 1) + ": " + why;
      }
      return true;
    }
    ++report_->scans;
    report_->samples += scan.samples.size();
    CheckBeamTimes(m, stamp);
    return Write(info.log_time_ns);
  }

  bool OnOdometry(const RosMessageInfo& info, const RosOdometry& m) override {
    if (*info.topic != setup_.odom_topic) return true;
    const int64_t stamp = Stamp(info, m.header);
    if (!stamps_.Observe(*info.topic, stamp, report_->odometry, report_, &error_)) {
      return false;
    }
    ++report_->odometry;
    const Rigid3d pose = RigidFromRos(m.position, m.orientation);
    odometry_.push_back({stamp - setup_.time_origin_ns, m.position[0], m.position[1],
                         YawFromQuaternion(pose.rotation()), m.linear_velocity[0],
                         m.angular_velocity[2], info.log_time_ns});
    return true;
  }

  bool OnImu(const RosMessageInfo& info, const RosImu& m) override {
    if (*info.topic != setup_.imu_topic) return true;
    const int64_t stamp = Stamp(info, m.header);
    if (!stamps_.Observe(*info.topic, stamp, report_->imu, report_, &error_)) {
      return false;
    }
    ++report_->imu;
    ImuMeasurement out;
    out.time = TimeFromNanoseconds(stamp - setup_.time_origin_ns);
    const auto& q = m.orientation;
    out.has_attitude = m.orientation_covariance[0] != -1.0 &&
                       (q[0] != 0.0 || q[1] != 0.0 || q[2] != 0.0 || q[3] != 0.0);
    out.has_gyro = m.angular_velocity_covariance[0] != -1.0;
    if (out.has_attitude) {
      // world_from_base = world_from_imu * imu_from_base.
      const Eigen::Quaterniond world_from_imu = RigidFromRos({0, 0, 0}, q).rotation();
      const Eigen::Vector3d rpy =
          RollPitchYawFromQuaternion(world_from_imu * base_from_imu_.rotation().inverse());
      out.roll = rpy[0];
      out.pitch = rpy[1];
      out.yaw = rpy[2];
    } else {
      ++report_->imu_without_attitude;
    }
    if (out.has_gyro) {
      const Eigen::Vector3d w(m.angular_velocity[0], m.angular_velocity[1], m.angular_velocity[2]);
      out.gyro_z = (base_from_imu_.rotation() * w).z();
    } else {
      ++report_->imu_without_gyro;
    }
    EncodeImuRecord(out, &buffer_);
    return Write(info.log_time_ns);
  }

  bool OnTf(const RosMessageInfo&, const RosTfMessage&) override { return true; }
  void OnUndecodable(const RosMessageInfo& info, const std::string& why) override {
    ++report_->undecodable;
    if (report_->undecodable == 1) {
      report_->warnings.push_back(*info.topic + ": a message did not decode (" + why +
                                  "); such messages are skipped");
    }
  }

  // Writes the odometry twists (held until the end: a driver that fills
  // only the pose is recognised only once every twist was seen to be zero).
  bool Finish() {
    std::stable_sort(odometry_.begin(), odometry_.end(),
                     [](const OdometrySample& a, const OdometrySample& b) { return a.t_ns < b.t_ns; });
    bool all_zero = true;
    double path = 0.0;
    for (size_t k = 0; k < odometry_.size(); ++k) {
      all_zero = all_zero && odometry_[k].v == 0.0 && odometry_[k].w == 0.0;
      if (k > 0) path += std::hypot(odometry_[k].x - odometry_[k - 1].x, odometry_[k].y - odometry_[k - 1].y);
    }
    report_->twist_from_poses = all_zero && odometry_.size() > 1 && path > 0.01;
    if (!odometry_.empty()) {
      report_->has_start = true;
      report_->start_x_m = odometry_[0].x;
      report_->start_y_m = odometry_[0].y;
      report_->start_yaw_rad = odometry_[0].yaw;
    }
    for (size_t k = 0; k < odometry_.size(); ++k) {
      const OdometrySample& o = odometry_[k];
      TwistMeasurement t{TimeFromNanoseconds(o.t_ns), o.v, o.w};
      if (report_->twist_from_poses) {
        if (k == 0) continue;
        // The mean twist over the interval that ends at this pose, like an
        // encoder period: v along the mean heading, w the heading's change.
        const OdometrySample& p = odometry_[k - 1];
        const double dt = (o.t_ns - p.t_ns) * 1e-9;
        if (!(dt > 0.0)) continue;
        const double heading = p.yaw + 0.5 * WrapAngle(o.yaw - p.yaw);
        t.v_mps = ((o.x - p.x) * std::cos(heading) + (o.y - p.y) * std::sin(heading)) / dt;
        t.w_radps = WrapAngle(o.yaw - p.yaw) / dt;
      }
      EncodeTwistRecord(t, &buffer_);
      if (!Write(o.log_ns)) return false;
    }
    return true;
  }

  const std::string& error() const { return error_; }
  // The error was the session writer's (the output), not the bag's.
  bool write_failed() const { return write_failed_; }

 private:
  // The message's time on the bag's sensor clock: its header stamp, or for
  // a topic stamped on another clock its log time moved onto that clock.
  int64_t Stamp(const RosMessageInfo& info, const RosHeader& h) const {
    auto it = setup_.stamps_from_log_time.find(*info.topic);
    return it == setup_.stamps_from_log_time.end() ? h.stamp_ns
                                                   : SaturatingAdd(info.log_time_ns, it->second);
  }

  bool ConvertScan(const RosLaserScan& m, int64_t stamp_ns, LidarScan* scan, std::string* why) {
    const size_t n = m.ranges.size();
    if (!(std::isfinite(m.angle_increment) && m.angle_increment != 0.0f &&
          std::isfinite(m.angle_min) && std::isfinite(m.angle_max))) {
      *why = "angle_increment " + std::to_string(m.angle_increment) + " cannot place the beams";
      return false;
    }
    const double span = (static_cast<double>(m.angle_max) - m.angle_min) / m.angle_increment;
    const double expected = std::floor(span + 0.5) + 1.0;
    if (std::abs(static_cast<double>(n) - expected) > 1.0) {
      *why = std::to_string(n) + " ranges, but angle_min..angle_max in steps of angle_increment make " +
             std::to_string(static_cast<long long>(expected));
      return false;
    }
    if (n > 65535) {
      *why = std::to_string(n) + " ranges (at most 65535)";
      return false;
    }
    // The beams' times must be numbers, and the scan's span within 2.1 s
    // (kMaxScanSpanS: a turn of any scanning lidar): NaN or a huge value would give times
    // near -9.2e18 ns, and the checks after this compare false with NaN.
    if (!std::isfinite(m.time_increment) || !std::isfinite(m.scan_time) ||
        std::abs(static_cast<double>(m.time_increment)) * static_cast<double>(n) > kMaxScanSpanS ||
        std::abs(static_cast<double>(m.scan_time)) > kMaxScanSpanS) {
      *why = "time_increment " + std::to_string(m.time_increment) + " s / scan_time " +
             std::to_string(m.scan_time) +
             " s cannot time the beams (span over 2.1 s or not a number)";
      return false;
    }
    double dt = m.time_increment;
    std::string rule = "time_increment";
    if (dt == 0.0 && m.scan_time > 0.0f) {
      dt = m.scan_time * std::abs(m.angle_increment) / (2.0 * M_PI);
      rule = "time_increment 0: scan_time * angle_increment / (2 pi)";
    } else if (dt == 0.0) {
      rule = "time_increment and scan_time 0: every beam at the scan's stamp (no deskew)";
    }
    if (report_->time_rule.empty()) {
      report_->time_rule = rule;
    } else if (report_->time_rule.find(rule) == std::string::npos) {
      report_->time_rule += "; " + rule;
    }
    const bool has_intensity = m.intensities.size() == n;
    if (!has_intensity && !m.intensities.empty()) ++report_->intensities_dropped;
    const int64_t stamp = stamp_ns - setup_.time_origin_ns;
    scan->index = static_cast<uint32_t>(report_->scans);
    scan->samples.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      // Keep time order when a driver counts beams backwards in time.
      const size_t i = dt < 0.0 ? n - 1 - k : k;
      const float r = m.ranges[i];
      if (!std::isfinite(r)) {
        ++report_->no_returns;
        continue;
      }
      if (r < m.range_min || (m.range_max > 0.0f && r > m.range_max) || r <= 0.0f) {
        ++report_->out_of_range;
        continue;
      }
      LidarSample s;
      s.time = TimeFromNanoseconds(stamp + std::llround(static_cast<double>(i) * dt * 1e9));
      s.range_m = r;
      s.theta = static_cast<float>(m.angle_min + static_cast<double>(i) * m.angle_increment);
      s.beam = static_cast<uint16_t>(i);
      s.intensity = has_intensity ? m.intensities[i] : 0.0f;
      scan->samples.push_back(s);
    }
    return true;
  }

  // A spinning lidar's beams span most of the time between two scans; a
  // driver that writes a wrong time_increment (seen in real bags: 2.2e-7 s
  // a beam at 12.5 scans/s) makes a span far shorter. Said once, not fixed:
  // nothing in the message tells the right value.
  void CheckBeamTimes(const RosLaserScan& m, int64_t stamp_ns) {
    const int64_t previous = previous_scan_stamp_;
    previous_scan_stamp_ = stamp_ns;
    if (previous != 0 && stamp_ns > previous) {
      const double period = (stamp_ns - previous) * 1e-9;
      if (min_period_s_ == 0.0 || period < min_period_s_) min_period_s_ = period;
    }
    beam_span_s_ = std::max(beam_span_s_, std::abs(static_cast<double>(m.time_increment)) * m.ranges.size());
    beams_ = std::max(beams_, m.ranges.size());
    // Judged on the shortest period of the first 20 scans (a stale first
    // stamp or a dropped scan makes single periods longer).
    if (++scans_checked_ != 20) return;
    if (beam_span_s_ > 0.0 && beam_span_s_ < 0.01 * min_period_s_) {
      char buf[256];
      std::snprintf(buf, sizeof(buf),
                    "beam times look wrong: a scan's beams span %.3g ms (time_increment x %zu) but scans "
                    "come every %.3g ms; the driver's time_increment is probably wrong, so the motion "
                    "during each scan is not undone",
                    beam_span_s_ * 1e3, beams_, min_period_s_ * 1e3);
      report_->warnings.push_back(buf);
    }
  }

  bool Write(int64_t log_time_ns) {
    const Status s = writer_->Append(buffer_, log_time_ns);
    if (!s.ok()) {
      error_ = s.message();
      write_failed_ = true;
      return false;
    }
    return true;
  }

  SessionWriter* writer_;
  const RosImportReport& setup_;
  Rigid3d base_from_imu_;
  RosImportReport* report_;
  StampCheck stamps_;
  std::vector<OdometrySample> odometry_;
  std::vector<uint8_t> buffer_;
  uint64_t scan_messages_ = 0;
  int64_t previous_scan_stamp_ = 0;
  double min_period_s_ = 0.0, beam_span_s_ = 0.0;
  size_t beams_ = 0;
  int scans_checked_ = 0;
  std::string error_;
  bool write_failed_ = false;
};

// Removes what a failed import wrote (only the files it creates).
void RemoveSession(const std::string& dir) {
  for (const char* f : {kSessionFramesFile, kSessionMetaFile}) unlink((dir + "/" + f).c_str());
  rmdir(dir.c_str());
}

Status ResolveMount(const RosImportOptions& options, const FirstPassSink& first,
                    RosImportReport* r) {
  if (options.has_mount) {
    r->base_from_scan = options.base_from_scan;
    r->mount_source = "--mount";
    return Status::Ok();
  }
  std::string path;
  bool moving = false;
  Status s = first.tf_.Resolve(r->base_frame, r->scan_frame, &r->base_from_scan, &path, &moving);
  if (!s.ok()) {
    return Status::Error(s.message() + "; give the lidar's mount with --mount x,y,z,roll,pitch,yaw "
                                       "(base_from_scan, m and rad) or the robot's frame with --base-frame");
  }
  r->mount_source = "tf: " + path;
  if (moving) {
    r->warnings.push_back("the mount " + path +
                          " moves during the bag (a joint on /tf); its first value is used");
  }
  return Status::Ok();
}

}  // namespace

Status ChooseTopic(const RosBagSummary& summary, RosMessageKind kind, const std::string& requested,
                   bool required, std::string* topic, std::vector<std::string>* warnings) {
  topic->clear();
  if (requested == "none" && !required) return Status::Ok();
  const auto encoding = [&](const RosTopicInfo& t) {
    return t.topic + " is in encoding '" + t.serialization + "': sweepscan reads " +
           (summary.format == "rosbag1" ? "ros1" : "cdr") + " from " + summary.format + " bags";
  };
  std::vector<std::string> candidates;
  for (const RosTopicInfo& t : summary.topics) {
    if (!requested.empty() && t.topic == requested) {
      if (t.kind() != kind) {
        return Status::Error(requested + " is " + t.type + ", not " + RosMessageKindName(kind));
      }
      if (!summary.Decodable(t)) return Status::Error(encoding(t));
      *topic = requested;
      return Status::Ok();
    }
    if (t.kind() != kind || t.message_count == 0) continue;
    if (summary.Decodable(t)) {
      candidates.push_back(t.topic);
    } else if (warnings != nullptr) {
      warnings->push_back(encoding(t) + ": not used");
    }
  }
  if (!requested.empty()) return Status::Error("the bag has no topic " + requested);
  if (candidates.size() == 1) {
    *topic = candidates[0];
    return Status::Ok();
  }
  const char* option = kind == RosMessageKind::kLaserScan  ? "--scan"
                       : kind == RosMessageKind::kOdometry ? "--odom"
                                                           : "--imu";
  if (candidates.empty()) {
    if (!required) return Status::Ok();
    return Status::Error(std::string("the bag has no ") + RosMessageKindName(kind) + " topic");
  }
  std::string list;
  for (const std::string& c : candidates) list += (list.empty() ? "" : ", ") + c;
  return Status::Error(std::to_string(candidates.size()) + " " + RosMessageKindName(kind) +
                       " topics (" + list + "): choose one with " + option);
}

Status ImportRosBag(const std::string& bag_path, const std::string& session_dir,
                    const RosImportOptions& options, RosImportReport* report,
                    RosImportFailure* failure) {
  const std::string bag = RosBagPath(bag_path);
  RosImportFailure local_failure;
  if (failure == nullptr) failure = &local_failure;
  // Everything below is the bag's fault unless said otherwise.
  *failure = RosImportFailure::kBag;
  // The readers keep the bag open across the passes; closed when done.
  struct Release {
    ~Release() { ReleaseRosBags(); }
  } release;
  RosImportReport r;
  r.bag = bag;
  r.session = session_dir;
  RosBagSummary summary;
  std::vector<std::string> summary_warnings;
  // A read that stopped because options.progress said so is a cancel;
  // known by the answer, not by the message's words (a bag under
  // /data/cancelled/ that fails is the bag's fault).
  bool cancel_asked = false;
  auto progress = [&](double from, double to) {
    return [&options, &cancel_asked, from, to](double f) {
      if (!options.progress || options.progress(from + (to - from) * f)) return true;
      cancel_asked = true;
      return false;
    };
  };
  const auto cancelled_or = [&](const Status& st) {
    if (cancel_asked) *failure = RosImportFailure::kCancelled;
    return st;
  };
  // The summary reads a bag without an index whole (an MCAP without its
  // summary section): cancellable, at the start of the work.
  Status s = SummarizeRosBag(bag, &summary, &summary_warnings, progress(0.0, 0.0));
  if (!s.ok()) return cancelled_or(s);
  RosReadStats stats;
  // A refusal says what the readers read past too: a bag torn before its
  // first scan has no LaserScan topic, because of the tear.
  const auto refuse = [&](const std::string& why) {
    std::string text = bag + ": " + why;
    std::vector<std::string> said = summary_warnings;
    for (const std::string& w : stats.warnings) {
      if (std::find(said.begin(), said.end(), w) == said.end()) said.push_back(w);
    }
    for (const std::string& w : said) text += "; " + w;
    return Status::Error(text);
  };
  r.format = summary.format;
  for (auto [kind, requested, required, topic] :
       {std::tuple{RosMessageKind::kLaserScan, options.scan_topic, false, &r.scan_topic},
        std::tuple{RosMessageKind::kOdometry, options.odom_topic, false, &r.odom_topic},
        std::tuple{RosMessageKind::kImu, options.imu_topic, false, &r.imu_topic}}) {
    s = ChooseTopic(summary, kind, requested, required, topic, &r.warnings);
    if (!s.ok()) return Status::Error(bag + ": " + s.message());
  }

  if (r.scan_topic.empty() && r.odom_topic.empty() && r.imu_topic.empty()) {
    std::string why;
    for (const std::string& w : r.warnings) why += "; " + w;
    return refuse(
        "no sensor_msgs/LaserScan, nav_msgs/Odometry or sensor_msgs/Imu topic: nothing sweepscan "
        "reads" +
        why);
  }

  // Pass 1: tf, and the first message of each sensor topic.
  std::set<std::string> sensors;
  if (!r.scan_topic.empty()) sensors.insert(r.scan_topic);
  if (!r.odom_topic.empty()) sensors.insert(r.odom_topic);
  if (!r.imu_topic.empty()) sensors.insert(r.imu_topic);
  FirstPassSink first(sensors);
  RosReadOptions read;
  for (const RosTopicInfo& t : summary.topics) {
    if (t.kind() == RosMessageKind::kTf) read.topics.insert(t.topic);
  }
  read.progress = progress(0.0, 0.05);
  // /tf_static whole (a few messages), then the first of /tf's: reading
  // both at once would stop /tf_static where /tf stops.
  for (const bool statics : {true, false}) {
    RosReadOptions part = read;
    part.topics.clear();
    for (const std::string& t : read.topics) {
      if ((t.find("static") != std::string::npos) == statics) part.topics.insert(t);
    }
    if (part.topics.empty()) continue;
    s = ReadRosBag(bag, part, &first, &stats);
    if (!s.ok() && !first.tf_stopped_) return cancelled_or(s);
  }
  read.topics = sensors;
  read.progress = progress(0.05, 0.1);
  s = ReadRosBag(bag, read, &first, &stats);
  if (!s.ok() && !first.stopped_early_) return cancelled_or(s);
  for (const std::string& topic : sensors) {
    if (first.first_.count(topic) == 0) return refuse(topic + " holds no message");
  }
  r.base_frame = options.base_frame;
  if (r.base_frame.empty()) r.base_frame = NormalizeFrame(first.odom_child_);
  for (const char* f : {"base_footprint", "base_link"}) {
    if (r.base_frame.empty() && first.tf_.HasFrame(f)) r.base_frame = f;
  }
  if (r.base_frame.empty()) r.base_frame = "base_link";
  if (!r.scan_topic.empty()) {
    r.scan_frame = NormalizeFrame(first.first_[r.scan_topic].frame_id);
    s = ResolveMount(options, first, &r);
    if (!s.ok()) return Status::Error(bag + ": " + s.message());
  } else {
    // No lidar: poses only. The mount stays sweepscan's drawn one (unused).
    r.base_from_scan = options.has_mount ? options.base_from_scan : Rigid3d::Translation({0.1, 0.0, 0.4}) *
                                                                        Rigid3d::Rotation(LidarFromScan());
    r.mount_source = options.has_mount ? "--mount" : "none (no LaserScan)";
    r.warnings.push_back("no LaserScan: the session has poses (odometry, IMU) but no cloud");
  }
  Rigid3d base_from_imu;
  if (!r.imu_topic.empty() && options.has_imu_mount) {
    base_from_imu = options.base_from_imu;
    r.imu_mount_source = "--imu-mount";
  } else if (!r.imu_topic.empty()) {
    const std::string imu_frame = NormalizeFrame(first.first_[r.imu_topic].frame_id);
    std::string path;
    bool moving = false;
    if (first.tf_.Resolve(r.base_frame, imu_frame, &base_from_imu, &path, &moving).ok()) {
      r.imu_mount_source = "tf: " + path;
    } else {
      base_from_imu = Rigid3d::Identity();
      r.imu_mount_source = "none: the IMU's axes are the robot's";
      if (imu_frame != r.base_frame) {
        r.warnings.push_back("tf has no path from " + r.base_frame + " to the IMU's frame " + imu_frame +
                             ": its axes are taken as the robot's (--imu-mount gives its mount)");
      }
    }
  }
  if (!first.odom_child_.empty() && NormalizeFrame(first.odom_child_) != r.base_frame) {
    r.warnings.push_back("the odometry's twist is in " + first.odom_child_ + ", not in " + r.base_frame +
                         ": it is used as the robot's");
  }
  if (r.odom_topic.empty()) {
    r.warnings.push_back("no odometry: the EKF has no speed, so the robot stays where it started" +
                         std::string(r.imu_topic.empty() ? "" : " (its attitude from the IMU)"));
  }
  if (r.imu_topic.empty()) r.warnings.push_back("no IMU: the heading comes from the odometry alone");

  std::vector<std::pair<std::string, int64_t>> offsets;  // topic, stamp - log time
  for (const std::string* topic : {&r.scan_topic, &r.odom_topic, &r.imu_topic}) {
    if (!topic->empty())
      offsets.emplace_back(
          *topic, SaturatingSub(first.first_.at(*topic).stamp_ns, first.first_log_.at(*topic)));
  }
  CheckClocks(offsets, &r);
  // Robot time: shifted by whole seconds to start near 1 s.
  int64_t earliest = std::numeric_limits<int64_t>::max();
  for (const auto& [topic, h] : first.first_) {
    auto log = r.stamps_from_log_time.find(topic);
    earliest = std::min(earliest, log == r.stamps_from_log_time.end()
                                      ? h.stamp_ns
                                      : SaturatingAdd(first.first_log_.at(topic), log->second));
  }
  r.time_origin_ns = (earliest / kNsPerS - 1) * kNsPerS;

  RobotGeometry g;
  const Eigen::Vector3d t = r.base_from_scan.translation();
  g.lidar_offset_x_m = t.x();
  g.lidar_offset_y_m = t.y();
  g.lidar_height_m = t.z();
  g.imu_offset_x_m = base_from_imu.translation().x();
  g.wheel_distance_m = options.wheel_distance_m;
  g.lidar_mount = (r.base_from_scan.rotation() * LidarFromScan().inverse()).normalized();
  std::string error;
  if (g.lidar_height_m <= 0.0) {
    r.warnings.push_back("the lidar is not above " + r.base_frame + " (z = " + std::to_string(g.lidar_height_m) +
                         " m): heights in the cloud are relative to that frame, not to the floor");
  }
  if (!g.IsValid(&error)) {
    return Status::Error(bag + ": " + error + " (mount " + r.mount_source + ")");
  }

  SessionMeta meta;
  meta.created_utc = UtcNowIso8601();
  meta.geometry = g;
  meta.content = kSessionContentMeasurements;
  meta.link = r.format + ":" + bag;
  meta.agent = "sweepscan import";
  meta.notes = options.notes;
  std::unique_ptr<SessionWriter> writer;
  const std::string writing = SessionWritingDir(session_dir, "importing");
  s = CheckNewSessionFolder(session_dir);
  if (s.ok()) {
    RemoveSession(writing);  // one of a killed import whose PID this process has
    s = SessionWriter::Create(writing, meta, SessionWriterOptions(), &writer);
  }
  if (!s.ok()) {
    *failure = RosImportFailure::kOutput;
    return SaidOfSession(s, writing, session_dir);
  }

  // The bag's SHA-256 on the second core while pass 2 reads it.
  std::atomic<bool> stop_hash{false};
  std::string sha;
  std::future<Status> hash = std::async(std::launch::async, [&] { return HashBag(bag, &sha, &stop_hash); });

  // Pass 2: the sensor topics, written as they are read.
  WritingSink sink(writer.get(), r, base_from_imu, &r);
  read.progress = progress(0.1, 1.0);
  s = ReadRosBag(bag, read, &sink, &stats);
  if (s.ok() && !sink.Finish()) s = Status::Error(sink.error());
  if (!s.ok() && sink.write_failed()) {
    // The session writer's error names the session's file.
    *failure = RosImportFailure::kOutput;
    s = Status::Error(sink.error());
  } else if (!s.ok() && !sink.error().empty()) {
    s = Status::Error(bag + ": " + sink.error());
  } else if (!s.ok() && cancel_asked) {
    *failure = RosImportFailure::kCancelled;
  }
  if (s.ok() && !r.scan_topic.empty() && r.scans == 0) {
    s = refuse(
        "no usable scan on " + r.scan_topic +
        (r.first_scan_refusal.empty() ? "" : " (first refused: " + r.first_scan_refusal + ")"));
  }
  if (s.ok()) {
    s = writer->Close();
    if (!s.ok()) *failure = RosImportFailure::kOutput;
  }
  if (s.ok()) {
    // What the readers read past (a file cut short, a damaged summary).
    for (const std::string& w : summary_warnings) r.warnings.push_back(w);
    for (const std::string& w : stats.warnings) {
      if (std::find(r.warnings.begin(), r.warnings.end(), w) == r.warnings.end())
        r.warnings.push_back(w);
    }
    if (r.scans_refused > 0) {
      r.warnings.push_back(
          std::to_string(r.scans_refused) + " scans refused (first: " + r.first_scan_refusal + ")" +
          (r.scans_too_large == 0 ? ""
                                  : "; " + std::to_string(r.scans_too_large) +
                                        " of them too large for a session record"));
    }
    if (r.out_of_order > 0) {
      r.warnings.push_back(std::to_string(r.out_of_order) +
                           " messages stamped before their predecessor on the same topic (put in order)");
    }
    if (r.time_gaps > 0) {
      r.warnings.push_back(std::to_string(r.time_gaps) + " gaps of more than 1 s within a topic");
    }
    if (r.intensities_dropped > 0) {
      r.warnings.push_back(std::to_string(r.intensities_dropped) +
                           " scans with their intensities dropped: not one for each range");
    }
    const Status h = hash.get();
    nlohmann::json provenance = r.ToJson();
    provenance["sha256"] = h.ok() ? sha : "";
    if (r.has_start) {
      provenance["start"] = {{"x_m", r.start_x_m}, {"y_m", r.start_y_m}, {"yaw_rad", r.start_yaw_rad}};
    }
    meta.settings["import"] = provenance;
    s = writer->UpdateMeta(meta);
    if (!s.ok()) *failure = RosImportFailure::kOutput;
  }
  writer.reset();
  if (s.ok()) {
    s = RenameSessionIntoPlace(writing, session_dir);
    if (!s.ok()) *failure = RosImportFailure::kOutput;
  }
  if (!s.ok()) {
    stop_hash = true;
    if (hash.valid()) hash.wait();
    RemoveSession(writing);
    return SaidOfSession(s, writing, session_dir);
  }
  if (report != nullptr) *report = std::move(r);
  *failure = RosImportFailure::kNone;
  return Status::Ok();
}

nlohmann::json RosImportReport::ToJson() const {
  const Eigen::Vector3d t = base_from_scan.translation();
  const Eigen::Vector3d rpy = RollPitchYawFromQuaternion(base_from_scan.rotation());
  return {{"bag", bag},
          {"format", format},
          {"session", session},
          {"topics", {{"scan", scan_topic}, {"odometry", odom_topic}, {"imu", imu_topic}}},
          {"base_frame", base_frame},
          {"scan_frame", scan_frame},
          {"mount",
           {{"source", mount_source},
            {"x_m", t.x()},
            {"y_m", t.y()},
            {"z_m", t.z()},
            {"roll_rad", rpy[0]},
            {"pitch_rad", rpy[1]},
            {"yaw_rad", rpy[2]}}},
          {"imu_mount", imu_mount_source},
          {"time_rule", time_rule},
          {"time_origin_ns", time_origin_ns},
          {"scans", scans},
          {"samples", samples},
          {"no_returns", no_returns},
          {"out_of_range", out_of_range},
          {"scans_refused", scans_refused},
          {"odometry", odometry},
          {"twist_from_poses", twist_from_poses},
          {"imu", imu},
          {"imu_without_attitude", imu_without_attitude},
          {"imu_without_gyro", imu_without_gyro},
          {"out_of_order", out_of_order},
          {"time_gaps", time_gaps},
          {"intensities_dropped", intensities_dropped},
          {"undecodable", undecodable},
          {"scans_too_large", scans_too_large},
          {"stamps_from_log_time_ns", stamps_from_log_time},
          {"warnings", warnings}};
}

}  // namespace sweepscan::io
