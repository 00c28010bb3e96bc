#include "core/io/rosbag1/rosbag1.h"

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#include <sys/stat.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>

#include "core/io/rosbag1/rosbag1_check.h"

namespace sweepscan::io {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";

int64_t Ns(const ros::Time& t) { return static_cast<int64_t>(t.toNSec()); }

RosHeader Header(const std_msgs::Header& h) { return {Ns(h.stamp), h.frame_id}; }

template <size_t N, typename Src>
void CopyArray(const Src& src, std::array<double, N>* dst) {
  std::copy(src.begin(), src.begin() + N, dst->begin());
}

RosLaserScan Convert(const sensor_msgs::LaserScan& m) {
  RosLaserScan s;
  s.header = Header(m.header);
  s.angle_min = m.angle_min;
  s.angle_max = m.angle_max;
  s.angle_increment = m.angle_increment;
  s.time_increment = m.time_increment;
  s.scan_time = m.scan_time;
  s.range_min = m.range_min;
  s.range_max = m.range_max;
  s.ranges = m.ranges;
  s.intensities = m.intensities;
  return s;
}

RosOdometry Convert(const nav_msgs::Odometry& m) {
  RosOdometry o;
  o.header = Header(m.header);
  o.child_frame_id = m.child_frame_id;
  const auto& p = m.pose.pose;
  o.position = {p.position.x, p.position.y, p.position.z};
  o.orientation = {p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w};
  CopyArray(m.pose.covariance, &o.pose_covariance);
  const auto& t = m.twist.twist;
  o.linear_velocity = {t.linear.x, t.linear.y, t.linear.z};
  o.angular_velocity = {t.angular.x, t.angular.y, t.angular.z};
  CopyArray(m.twist.covariance, &o.twist_covariance);
  return o;
}

RosImu Convert(const sensor_msgs::Imu& m) {
  RosImu i;
  i.header = Header(m.header);
  i.orientation = {m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w};
  CopyArray(m.orientation_covariance, &i.orientation_covariance);
  i.angular_velocity = {m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z};
  CopyArray(m.angular_velocity_covariance, &i.angular_velocity_covariance);
  i.linear_acceleration = {m.linear_acceleration.x, m.linear_acceleration.y,
                           m.linear_acceleration.z};
  CopyArray(m.linear_acceleration_covariance, &i.linear_acceleration_covariance);
  return i;
}

RosTfMessage Convert(const tf2_msgs::TFMessage& m) {
  RosTfMessage tf;
  tf.transforms.reserve(m.transforms.size());
  for (const auto& t : m.transforms) {
    RosTransform r;
    r.header = Header(t.header);
    r.child_frame_id = t.child_frame_id;
    r.translation = {t.transform.translation.x, t.transform.translation.y,
                     t.transform.translation.z};
    r.rotation = {t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                  t.transform.rotation.w};
    tf.transforms.push_back(std::move(r));
  }
  return tf;
}

// Deserialises a message's bytes as Msg and hands it on; throws (counted as
// undecodable by the caller) when the bag's definition of the type differs
// from the one sweepscan was built with (their MD5 sums disagree, as
// MessageInstance::instantiate checks) or the bytes do not hold the
// definition's fields (CheckRos1Message, before anything is allocated: roscpp
// resizes an array to whatever count the bytes say).
template <typename Msg, typename Fn>
bool Deliver(const rosbag::MessageInstance& m, RosMessageKind kind, std::vector<uint8_t>* bytes,
             Fn&& fn) {
  const std::string& md5 = m.getMD5Sum();
  if (md5 != "*" && md5 != ros::message_traits::MD5Sum<Msg>::value()) {
    throw std::runtime_error(std::string("message definition differs from ") +
                             ros::message_traits::DataType<Msg>::value() + "'s (MD5 " + md5 + ")");
  }
  bytes->resize(m.size());
  ros::serialization::OStream out(bytes->data(), static_cast<uint32_t>(bytes->size()));
  m.write(out);
  const Status s = CheckRos1Message(kind, bytes->data(), bytes->size());
  if (!s.ok()) throw std::runtime_error(s.message());
  Msg msg;
  ros::serialization::IStream in(bytes->data(), static_cast<uint32_t>(bytes->size()));
  ros::serialization::deserialize(in, msg);
  return fn(msg);
}

// Opens the bag; the library's exceptions become a Status with the advice an
// operator needs.
Status Open(const std::string& path, rosbag::Bag* bag, std::string* first_compression) {
  if (!LooksLikeRosbag1(path)) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Error(path + ": cannot open: " + std::strerror(errno));
    return Status::Error(path + ": not a ROS 1 bag (it does not start with \"#ROSBAG V2.0\")");
  }
  // rosbag trusts the bag's lengths and offsets (a bad one reads out of
  // bounds): the file's records are checked first, and a damaged bag
  // refused here; what the chunks hold is checked before messages are read
  // (Acquire's `messages`).
  const Status checked = CheckRosbag1File(path, false, nullptr, first_compression);
  if (!checked.ok()) return checked;
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagUnindexedException&) {
    return Status::Error(path +
                         ": the bag has no index (a recording cut short?): run `rosbag reindex " +
                         path + "` and import the reindexed bag");
  } catch (const std::exception& e) {
    return Status::Error(path + ": cannot read the ROS 1 bag: " + e.what());
  }
  return Status::Ok();
}

// The last bag opened, kept open: reading a bag's index is most of the cost
// of opening it (an hour's bag: 750 000 entries, ~0.15 s), and an import
// opens the same bag five times (summary, /tf_static, /tf, the first
// messages, the messages). Keyed by path, size and modification time, so a
// changed file is read afresh; released by ReleaseRosbag1Cache.
struct CachedBag {
  std::string path;
  off_t size = 0;
  struct timespec mtime = {};
  bool chunks_checked = false;  // CheckRosbag1File with the chunks walked
  std::string first_compression = "none";  // for `info`
  rosbag::Bag bag;
};
// A plain pointer on purpose: a static unique_ptr would close the bag during
// static destruction, after rosbag's own statics (console_bridge,
// class_loader) are gone, and crash the process at exit.
std::mutex g_cache_mutex;
CachedBag* g_cache = nullptr;

// Opens `path` (or reuses it) with g_cache_mutex held by *lock for as long
// as the caller uses *bag: rosbag::Bag is not thread-safe. `messages`: the
// caller reads messages, so the chunks are checked too (once a bag).
Status Acquire(const std::string& path, std::unique_lock<std::mutex>* lock, rosbag::Bag** bag,
               bool messages, const std::function<bool(double)>& progress = nullptr) {
  *lock = std::unique_lock<std::mutex>(g_cache_mutex);
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return Status::Error(path + ": cannot open: " + std::strerror(errno));
  if (g_cache == nullptr || g_cache->path != path || g_cache->size != st.st_size ||
      g_cache->mtime.tv_sec != st.st_mtim.tv_sec || g_cache->mtime.tv_nsec != st.st_mtim.tv_nsec) {
    delete g_cache;
    g_cache = nullptr;
    auto fresh = std::make_unique<CachedBag>();
    const Status s = Open(path, &fresh->bag, &fresh->first_compression);
    if (!s.ok()) return s;
    fresh->path = path;
    fresh->size = st.st_size;
    fresh->mtime = st.st_mtim;
    g_cache = fresh.release();
  }
  if (messages && !g_cache->chunks_checked) {
    // Cancellable (the reader's progress at its start: a large bz2 bag takes
    // a while to decompress).
    std::function<bool(double)> poll;
    if (progress) poll = [&progress](double) { return progress(0.0); };
    const Status s = CheckRosbag1File(path, true, poll);
    if (!s.ok()) return s;
    g_cache->chunks_checked = true;
  }
  *bag = &g_cache->bag;
  return Status::Ok();
}

// Adds one read's counters to the caller's (RosReadStats is added to, so
// that several reads, and the caller's own warnings, share one).
void AddStats(const RosReadStats& st, RosReadStats* stats) {
  if (stats == nullptr) return;
  stats->messages_read += st.messages_read;
  stats->messages_skipped += st.messages_skipped;
  stats->messages_undecodable += st.messages_undecodable;
  stats->bytes_read += st.bytes_read;
  for (const std::string& w : st.warnings) stats->warnings.push_back(w);
}

}  // namespace

void ReleaseRosbag1Cache() {
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  delete g_cache;
  g_cache = nullptr;
}

bool LooksLikeRosbag1(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char head[sizeof(kMagic) - 1] = {};
  return f.read(head, sizeof(head)) && std::memcmp(head, kMagic, sizeof(head)) == 0;
}

Status SummarizeRosbag1(const std::string& path, RosBagSummary* summary,
                        const std::function<bool(double)>& progress) {
  std::unique_lock<std::mutex> lock;
  rosbag::Bag* cached = nullptr;
  Status s = Acquire(path, &lock, &cached, false);
  if (!s.ok()) return s;
  rosbag::Bag& bag = *cached;
  RosBagSummary out;
  out.format = "rosbag1";
  try {
    out.file_bytes = bag.getSize();
    rosbag::View all(bag);
    std::map<std::string, RosTopicInfo> topics;
    for (const rosbag::ConnectionInfo* c : all.getConnections()) {
      RosTopicInfo& t = topics[c->topic];
      t.topic = c->topic;
      t.type = c->datatype;
      t.serialization = "ros1";
    }
    // One walk over the index counts every topic (an index entry names its
    // connection and time; no message is read), where a View a topic would
    // walk it once a topic.
    RosTopicInfo* last = nullptr;
    const uint32_t total = progress ? all.size() : 0;
    for (const rosbag::MessageInstance& m : all) {
      if (progress && (out.message_count & 65535) == 0 &&
          !progress(total == 0 ? 0.0 : static_cast<double>(out.message_count) / total)) {
        return Status::Error(path + ": cancelled");
      }
      if (last == nullptr || last->topic != m.getTopic()) last = &topics[m.getTopic()];
      const int64_t t = Ns(m.getTime());
      if (last->message_count++ == 0) last->first_ns = t;
      last->last_ns = t;
      if (out.message_count++ == 0) out.start_ns = t;
      out.end_ns = t;
    }
    for (auto& [name, t] : topics) out.topics.push_back(t);
  } catch (const std::exception& e) {
    return Status::Error(path + ": cannot read the ROS 1 bag's index: " + e.what());
  }
  out.compression = g_cache->first_compression;  // read by the check (Open), lock held
  *summary = std::move(out);
  return Status::Ok();
}

Status ReadRosbag1(const std::string& path, const RosReadOptions& options, RosMessageSink* sink,
                   RosReadStats* stats) {
  std::unique_lock<std::mutex> lock;
  rosbag::Bag* cached = nullptr;
  Status s = Acquire(path, &lock, &cached, true, options.progress);
  if (!s.ok()) return s;
  rosbag::Bag& bag = *cached;
  RosReadStats st;
  try {
    // The topics to decode: those asked for, or every known type's.
    std::vector<std::string> topics;
    {
      rosbag::View all(bag);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) {
        const bool wanted = options.topics.empty()
                                ? RosMessageKindFromType(c->datatype) != RosMessageKind::kOther
                                : options.topics.count(c->topic) > 0;
        if (wanted && std::find(topics.begin(), topics.end(), c->topic) == topics.end()) {
          topics.push_back(c->topic);
        }
      }
    }
    rosbag::View view(bag, rosbag::TopicQuery(topics));
    const uint32_t total = view.size();
    uint64_t done = 0;
    std::vector<uint8_t> bytes;  // one message's, reused
    for (const rosbag::MessageInstance& m : view) {
      if (options.progress && (done & 1023) == 0 &&
          !options.progress(total == 0 ? 0.0 : static_cast<double>(done) / total)) {
        return Status::Error(path + ": cancelled");
      }
      ++done;
      const std::string& topic = m.getTopic();
      const std::string& type = m.getDataType();
      RosMessageInfo info{&topic, &type, Ns(m.getTime())};
      st.bytes_read += m.size();
      const RosMessageKind kind = RosMessageKindFromType(type);
      bool go_on = true;
      try {
        switch (kind) {
          case RosMessageKind::kLaserScan:
            go_on = Deliver<sensor_msgs::LaserScan>(m, kind, &bytes, [&](const auto& p) {
              return sink->OnLaserScan(info, Convert(p));
            });
            break;
          case RosMessageKind::kOdometry:
            go_on = Deliver<nav_msgs::Odometry>(
                m, kind, &bytes, [&](const auto& p) { return sink->OnOdometry(info, Convert(p)); });
            break;
          case RosMessageKind::kImu:
            go_on = Deliver<sensor_msgs::Imu>(
                m, kind, &bytes, [&](const auto& p) { return sink->OnImu(info, Convert(p)); });
            break;
          case RosMessageKind::kTf:
            go_on = Deliver<tf2_msgs::TFMessage>(
                m, kind, &bytes, [&](const auto& p) { return sink->OnTf(info, Convert(p)); });
            break;
          case RosMessageKind::kOther:
            ++st.messages_skipped;
            continue;
        }
        ++st.messages_read;
      } catch (const rosbag::BagException&) {
        throw;  // the file itself: fails the read below
      } catch (const std::exception& e) {
        ++st.messages_undecodable;
        sink->OnUndecodable(info, e.what());
      }
      if (!go_on) {
        AddStats(st, stats);
        return Status::Error(path + ": cancelled");
      }
    }
    if (options.progress) options.progress(1.0);
  } catch (const std::exception& e) {
    AddStats(st, stats);
    return Status::Error(path + ": ROS 1 bag unreadable after " + std::to_string(st.messages_read) +
                         " messages: " + e.what());
  }
  AddStats(st, stats);
  return Status::Ok();
}

}  // namespace sweepscan::io
