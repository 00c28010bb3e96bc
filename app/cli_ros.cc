// sweepscan-cli's ROS commands: `info BAG` (what a bag holds) and `import
// BAG --out NAME.sweepscan` (a bag -> a session that reconstruct, calibrate,
// evaluate, sfm and the app open like a native one). docs/ros-bags.md.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "app/cli_recording.h"
#include "core/calibration/calibration.h"
#include "core/cloud/reconstruct.h"
#include "core/io/ros/import.h"
#include "core/io/ros/ros_bag.h"
#include "core/io/ros/tf_tree.h"
#include "core/io/rosbag1/rosbag1_writer.h"
#include "core/session/session.h"

namespace sweepscan::app {

const char* const kImportUsage =
    "usage: sweepscan-cli import BAG --out NAME.sweepscan [options]\n"
    "\n"
    "Turns a ROS recording of a 2D lidar on a moving robot into a session:\n"
    "a ROS 1 .bag, a ROS 2 bag folder (sqlite3 or MCAP storage; or its\n"
    "metadata.yaml) or a single .db3 / .mcap file. LaserScans keep their\n"
    "per-beam times and intensities, nav_msgs/Odometry gives the EKF its speed,\n"
    "sensor_msgs/Imu its attitude and turn rate, and tf the lidar's mount. Then\n"
    "use reconstruct, calibrate, evaluate and sfm on NAME.sweepscan\n"
    "(docs/ros-bags.md).\n"
    "\n"
    "Options:\n"
    "  --scan TOPIC           sensor_msgs/LaserScan topic (default: the only one)\n"
    "  --odom TOPIC|none      nav_msgs/Odometry topic (default: the only one, if any)\n"
    "  --imu TOPIC|none       sensor_msgs/Imu topic (default: the only one, if any)\n"
    "  --base-frame F         the robot's frame (default: the odometry's child frame,\n"
    "                         else base_footprint, else base_link)\n"
    "  --mount x,y,z,roll,pitch,yaw   the lidar's pose in the base frame (m, rad),\n"
    "                         instead of tf's base -> scan frame\n"
    "  --imu-mount x,y,z,roll,pitch,yaw   the IMU's pose in the base frame, instead of tf's\n"
    "  --wheel-distance M     half the wheel track (m; default 0.15): sets how much the\n"
    "                         odometry's turn rate is trusted\n"
    "  --notes TEXT           notes for meta.json\n"
    "  --json                 print the report as JSON\n";

const char* const kBagInfoUsage =
    "usage: sweepscan-cli info BAG [--strict] [--json]\n"
    "\n"
    "Describes a ROS bag: format, compression, topics with types, counts and\n"
    "rates, the time span, and the frames in tf with the lidar's mount.\n"
    "A damaged bag is described as far as it reads, with a warning for each\n"
    "damage; --strict: exit 2 if damaged.\n";

namespace {

std::string Seconds(int64_t ns) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3f", static_cast<double>(ns) * 1e-9);
  return buf;
}

// Messages a second over the topic's own span; NaN when the bag does not
// give the span (an MCAP summary counts a channel's messages, not its times).
double Rate(const io::RosTopicInfo& t) {
  return t.message_count > 1 && t.last_ns > t.first_ns
             ? static_cast<double>(t.message_count - 1) /
                   (static_cast<double>(t.last_ns - t.first_ns) * 1e-9)
             : std::nan("");
}

std::string RateText(const io::RosTopicInfo& t) {
  const double hz = Rate(t);
  if (std::isnan(hz)) return "       ? Hz";
  char text[32];
  std::snprintf(text, sizeof(text), "%8.2f Hz", hz);
  return text;
}

bool ParseMount(const std::string& text, Rigid3d* mount) {
  std::vector<double> v;
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(x)) return false;
    v.push_back(x);
  }
  if (v.size() != 6) return false;
  *mount = Rigid3d::FromPose(v[0], v[1], v[2], v[3], v[4], v[5]);
  return true;
}

// tf's frames and the mount import would use, read from the bag (a short
// import dry run would cost a whole pass; this reads only tf).
class TfSink : public io::RosMessageSink {
 public:
  bool OnLaserScan(const io::RosMessageInfo&, const io::RosLaserScan&) override { return true; }
  bool OnOdometry(const io::RosMessageInfo&, const io::RosOdometry&) override { return true; }
  bool OnImu(const io::RosMessageInfo&, const io::RosImu&) override { return true; }
  bool OnTf(const io::RosMessageInfo& info, const io::RosTfMessage& m) override {
    const bool is_static = info.topic->find("static") != std::string::npos;
    for (const io::RosTransform& t : m.transforms) {
      edges.insert(io::NormalizeFrame(t.header.frame_id) + " -> " + io::NormalizeFrame(t.child_frame_id) +
                   (is_static ? " (static)" : ""));
    }
    // /tf repeats its edges at the odometry's rate all the bag long: its
    // first thousand messages name them (as the import reads it).
    return is_static || ++dynamic < 1000;
  }
  std::set<std::string> edges;
  uint64_t dynamic = 0;
};

// Reads every message for `info BAG --strict`, keeping only what did not
// decode.
class CheckSink : public io::RosMessageSink {
 public:
  bool OnLaserScan(const io::RosMessageInfo&, const io::RosLaserScan&) override { return true; }
  bool OnOdometry(const io::RosMessageInfo&, const io::RosOdometry&) override { return true; }
  bool OnImu(const io::RosMessageInfo&, const io::RosImu&) override { return true; }
  bool OnTf(const io::RosMessageInfo&, const io::RosTfMessage&) override { return true; }
  void OnUndecodable(const io::RosMessageInfo& info, const std::string& why) override {
    if (undecodable++ == 0) first_undecodable = *info.topic + " (" + why + ")";
  }
  uint64_t undecodable = 0;
  std::string first_undecodable;
};

}  // namespace

int RunBagInfo(int argc, char** argv) {
  // The readers keep the bag open between calls: closed on every way out.
  struct Release {
    ~Release() { io::ReleaseRosBags(); }
  } release;
  Args args({"json", "help", "strict"}, {});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error) || args.positional().size() != 1) {
    PrintError(SeeHelp(error.empty() ? "expected one BAG" : error, "info"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kBagInfoUsage;
    return kExitOk;
  }
  const std::string bag = args.positional()[0];
  io::RosBagSummary summary;
  std::vector<std::string> warnings;
  Status s = io::SummarizeRosBag(bag, &summary, &warnings);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  // Said before tf is read: a tf read that fails would lose them.
  for (const std::string& w : warnings) std::cerr << "sweepscan-cli: warning: " << w << "\n";
  TfSink tf;
  io::RosReadOptions read;
  for (const io::RosTopicInfo& t : summary.topics) {
    if (t.kind() == io::RosMessageKind::kTf) read.topics.insert(t.topic);
  }
  // /tf_static whole, then the first of /tf (a stop there ends the read).
  for (const bool statics : {true, false}) {
    io::RosReadOptions part;
    for (const std::string& t : read.topics) {
      if ((t.find("static") != std::string::npos) == statics) part.topics.insert(t);
    }
    if (part.topics.empty()) continue;
    s = io::ReadRosBag(bag, part, &tf, nullptr);
    if (!s.ok() && tf.dynamic < 1000) {
      PrintError(s.message());
      return kExitBadInput;
    }
  }
  // As `info SESSION --strict`, which reads every record: every message is
  // read (the description needs only the summary and tf), and a damaged bag
  // is refused, its warnings saying where. An intact bag's warnings (a
  // topic in another encoding, messages back in time) are not damage.
  if (args.Flag("strict")) {
    CheckSink check;
    io::RosReadStats stats;
    s = io::ReadRosBag(bag, io::RosReadOptions(), &check, &stats);
    if (!s.ok()) {
      PrintError(s.message());
      return kExitBadInput;
    }
    std::set<std::string> said(warnings.begin(), warnings.end());
    for (const std::string& w : stats.warnings) {
      if (said.insert(w).second) std::cerr << "sweepscan-cli: warning: " << w << "\n";
    }
    if (check.undecodable > 0) {
      std::cerr << "sweepscan-cli: warning: " << check.undecodable
                << " messages did not decode, the first on " << check.first_undecodable << "\n";
    }
    // The message read never looks at an MCAP's summary: its damage was
    // found by the description (SummarizeRosBag).
    if (stats.damaged || summary.damaged || check.undecodable > 0) {
      PrintError(bag + ": damaged (--strict)");
      return kExitBadInput;
    }
  }
  nlohmann::json topics = nlohmann::json::array();
  for (const io::RosTopicInfo& t : summary.topics) {
    topics.push_back({{"topic", t.topic},
                      {"type", t.type},
                      {"serialization", t.serialization},
                      {"messages", t.message_count},
                      {"rate_hz", std::isnan(Rate(t)) ? nlohmann::json() : nlohmann::json(Rate(t))},
                      {"sweepscan_reads", t.kind() != io::RosMessageKind::kOther}});
  }
  if (args.Flag("json")) {
    std::cout << nlohmann::json{{"bag", bag},
                                {"format", summary.format},
                                {"compression", summary.compression},
                                {"bytes", summary.file_bytes},
                                {"messages", summary.message_count},
                                {"start_s", static_cast<double>(summary.start_ns) * 1e-9},
                                {"end_s", static_cast<double>(summary.end_ns) * 1e-9},
                                {"duration_s", static_cast<double>(summary.end_ns - summary.start_ns) * 1e-9},
                                {"topics", topics},
                                {"tf", tf.edges}}
                     .dump(2)
              << "\n";
    return kExitOk;
  }
  std::printf("bag %s (%s, compression %s, %llu bytes)\n", bag.c_str(), summary.format.c_str(),
              summary.compression.c_str(), static_cast<unsigned long long>(summary.file_bytes));
  std::printf("%llu messages, %s s (%s .. %s s since the epoch)\n",
              static_cast<unsigned long long>(summary.message_count),
              Seconds(summary.end_ns - summary.start_ns).c_str(), Seconds(summary.start_ns).c_str(),
              Seconds(summary.end_ns).c_str());
  std::printf("topics:\n");
  for (const io::RosTopicInfo& t : summary.topics) {
    std::printf("  %-28s %-30s %8llu msgs %s%s\n", t.topic.c_str(), t.type.c_str(),
                static_cast<unsigned long long>(t.message_count), RateText(t).c_str(),
                summary.Decodable(t) ? ""
                : t.kind() == io::RosMessageKind::kOther
                    ? "  (not used)"
                    : ("  (not used: encoding " + t.serialization + ")").c_str());
  }
  std::printf("tf:%s\n", tf.edges.empty() ? " none" : "");
  for (const std::string& e : tf.edges) std::printf("  %s\n", e.c_str());
  return kExitOk;
}

int RunImport(int argc, char** argv) {
  Args args({"json", "help"}, {"out", "scan", "odom", "imu", "base-frame", "mount", "imu-mount", "wheel-distance", "notes"});
  std::string error;
  if (!args.Parse(argc, argv, 2, &error)) {
    PrintError(SeeHelp(error, "import"));
    return kExitBadInput;
  }
  if (args.Flag("help")) {
    std::cout << kImportUsage;
    return kExitOk;
  }
  if (args.positional().size() != 1 || !args.Has("out")) {
    PrintError(SeeHelp(
        args.positional().size() != 1 ? "expected one BAG" : "import needs --out NAME.sweepscan",
        "import"));
    return kExitBadInput;
  }
  io::RosImportOptions options;
  options.scan_topic = args.Get("scan");
  options.odom_topic = args.Get("odom");
  options.imu_topic = args.Get("imu");
  options.base_frame = args.Get("base-frame");
  options.notes = args.Get("notes");
  if (args.Has("mount")) {
    if (!ParseMount(args.Get("mount"), &options.base_from_scan)) {
      PrintError("--mount wants six numbers x,y,z,roll,pitch,yaw (m, rad), got '" + args.Get("mount") + "'");
      return kExitBadInput;
    }
    options.has_mount = true;
  }
  if (args.Has("imu-mount")) {
    if (!ParseMount(args.Get("imu-mount"), &options.base_from_imu)) {
      PrintError("--imu-mount wants six numbers x,y,z,roll,pitch,yaw (m, rad), got '" + args.Get("imu-mount") + "'");
      return kExitBadInput;
    }
    options.has_imu_mount = true;
  }
  if (args.Has("wheel-distance")) {
    char* end = nullptr;
    options.wheel_distance_m = std::strtod(args.Get("wheel-distance").c_str(), &end);
    if (*end != '\0' || !(options.wheel_distance_m > 0.0)) {
      PrintError("--wheel-distance wants a positive number of metres, got '" + args.Get("wheel-distance") + "'");
      return kExitBadInput;
    }
  }
  io::RosImportReport report;
  io::RosImportFailure failure = io::RosImportFailure::kNone;
  const Status s =
      io::ImportRosBag(args.positional()[0], args.Get("out"), options, &report, &failure);
  if (!s.ok()) {
    PrintError(s.message());
    // A session folder in the way or an unwritable output (a full disk
    // while writing) is a failure while working; everything else is about
    // the bag.
    return failure == io::RosImportFailure::kOutput ? kExitFailure : kExitBadInput;
  }
  if (args.Flag("json")) {
    std::cout << report.ToJson().dump(2) << "\n";
    return kExitOk;
  }
  for (const std::string& w : report.warnings) std::cerr << "sweepscan-cli: warning: " << w << "\n";
  std::printf("imported %s (%s) into %s\n", report.bag.c_str(), report.format.c_str(), report.session.c_str());
  std::printf("scans: %s, %llu scans, %llu samples (%llu beams without a return, %llu out of range)\n",
              report.scan_topic.empty() ? "none" : report.scan_topic.c_str(),
              static_cast<unsigned long long>(report.scans), static_cast<unsigned long long>(report.samples),
              static_cast<unsigned long long>(report.no_returns),
              static_cast<unsigned long long>(report.out_of_range));
  std::printf("odometry: %s, IMU: %s\n",
              report.odom_topic.empty() ? "none" : (report.odom_topic + " (" + std::to_string(report.odometry) + ")").c_str(),
              report.imu_topic.empty() ? "none" : (report.imu_topic + " (" + std::to_string(report.imu) + ")").c_str());
  const Eigen::Vector3d t = report.base_from_scan.translation();
  const Eigen::Vector3d rpy = RollPitchYawFromQuaternion(report.base_from_scan.rotation());
  if (report.scan_topic.empty()) return kExitOk;
  std::printf("mount: %s\n  %s_from_%s: x %.4f y %.4f z %.4f m, roll %.4f pitch %.4f yaw %.4f rad\n",
              report.mount_source.c_str(), report.base_frame.c_str(), report.scan_frame.c_str(), t.x(), t.y(),
              t.z(), rpy[0], rpy[1], rpy[2]);
  std::printf("beam times: %s\n", report.time_rule.c_str());
  return kExitOk;
}

int ExportRosbag(const Args& args, const SensorLog& log, const SessionMeta& meta) {
  ReconstructionOptions options;
  if (args.Flag("no-ekf")) options.pose.source = PoseSource::kOdometry;
  if (const int code = SessionReconstructionOptions(args, meta, &options); code != kExitOk) return code;
  ReconstructionResult result;
  Status s = Reconstruct(log, meta.geometry, options, nullptr, &result);
  if (!s.ok()) {
    PrintError(args.positional()[0] + ": " + s.message());
    return kExitFailure;
  }
  // Robot time back to the bag's clock for an imported session (its
  // whole-second origin, docs/ros-bags.md); a native session's robot time
  // is the agent's clock, kept as it is.
  int64_t origin = 0;
  if (meta.settings.contains("import") && meta.settings["import"].contains("time_origin_ns")) {
    origin = meta.settings["import"]["time_origin_ns"].get<int64_t>();
  }
  // Intensities are the samples', found by (scan, beam): the cloud keeps
  // provenance, not the intensity itself. Points come scan by scan, so one
  // beam table a scan.
  const ScansByIndex scans(log.scans);
  io::RosExport out;
  out.frame_id = args.Has("frame") ? args.Get("frame") : "odom";
  out.points.reserve(result.points.size());
  std::vector<float> beam_intensity;
  uint32_t table_scan = std::numeric_limits<uint32_t>::max();
  for (const CloudPoint& p : result.points) {
    if (p.scan != table_scan) {
      table_scan = p.scan;
      beam_intensity.assign(65536, 0.0f);
      if (const LidarScan* scan = scans.Find(p.scan)) {
        for (const LidarSample& sample : scan->samples) beam_intensity[sample.beam] = sample.intensity;
      }
    }
    out.points.push_back({p.x, p.y, p.z, beam_intensity[p.beam], p.time_ns + origin});
  }
  // The poses at up to 20 Hz: RViz draws a Path of an hour's drive at once.
  int64_t next = std::numeric_limits<int64_t>::min();
  for (size_t i = 0; i < result.poses.size(); ++i) {
    const int64_t t = ToNanoseconds(result.poses.time(i));
    if (t < next && i + 1 != result.poses.size()) continue;
    next = t + 50000000;
    const Rigid3d& pose = result.poses.pose(i);
    const Eigen::Quaterniond& q = pose.rotation();
    out.poses.push_back({t + origin,
                         {pose.translation().x(), pose.translation().y(), pose.translation().z()},
                         {q.x(), q.y(), q.z(), q.w()}});
  }
  s = io::WriteRosbag1Export(args.Get("out"), out);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitFailure;
  }
  if (args.Flag("json")) {
    std::cout << nlohmann::json{{"out", args.Get("out")},
                                {"points", out.points.size()},
                                {"poses", out.poses.size()},
                                {"frame", out.frame_id},
                                {"pose_source", PoseSourceName(options.pose.source)}}
                     .dump(2)
              << "\n";
  } else {
    std::printf("wrote %zu points (/sweepscan/cloud) and %zu poses (/sweepscan/path) in frame %s to %s\n",
                out.points.size(), out.poses.size(), out.frame_id.c_str(), args.Get("out").c_str());
  }
  return kExitOk;
}

}  // namespace sweepscan::app
