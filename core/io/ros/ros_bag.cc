#include "core/io/ros/ros_bag.h"

#include <sys/stat.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include "core/io/ros2/ros2_bag.h"
#include "core/io/rosbag1/rosbag1.h"

namespace sweepscan::io {
namespace {

bool IsDirectory(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool StartsWith(const std::string& path, const char* magic, size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string head(n, '\0');
  return f.read(&head[0], n) && std::memcmp(head.data(), magic, n) == 0;
}

bool IsRos2File(const std::string& path) {
  return StartsWith(path, "\x89MCAP0\r\n", 8) || StartsWith(path, "SQLite format 3\0", 16);
}

// Appends each of `from` not in *to yet (a bag read in several passes
// meets the same torn tail each time).
void AddOnce(const std::vector<std::string>& from, std::vector<std::string>* to) {
  for (const std::string& w : from) {
    if (std::find(to->begin(), to->end(), w) == to->end()) to->push_back(w);
  }
}

Status NotABag(const std::string& path) {
  if (IsDirectory(path)) {
    // FindRos2Bag says what the folder lacks (metadata.yaml, bag files).
    std::string storage;
    std::vector<std::string> files;
    const Status s = FindRos2Bag(path, &storage, &files);
    if (!s.ok()) return Status::Error(s.message() + ": not a ROS 2 bag folder");
  }
  return Status::Error(path +
                       ": not a ROS bag (neither a ROS 1 .bag, an MCAP or sqlite3 file, "
                       "nor a ROS 2 bag folder)");
}

}  // namespace

std::string RosBagPath(const std::string& path) {
  const size_t slash = path.rfind('/');
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  if (base != "metadata.yaml" || IsDirectory(path)) return path;
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

bool LooksLikeRosBag(const std::string& given) {
  const std::string path = RosBagPath(given);
  if (IsDirectory(path)) {
    // A rosbag2 folder, or (as FindRos2Bag takes it) a folder without
    // metadata.yaml holding exactly one .db3 or .mcap and no sweepscan
    // session's meta.json.
    struct stat st;
    if (stat((path + "/metadata.yaml").c_str(), &st) == 0) return true;
    if (stat((path + "/meta.json").c_str(), &st) == 0) return false;
    std::string storage;
    std::vector<std::string> files;
    return FindRos2Bag(path, &storage, &files).ok();
  }
  return LooksLikeRosbag1(path) || IsRos2File(path);
}

Status SummarizeRosBag(const std::string& given, RosBagSummary* summary,
                       std::vector<std::string>* warnings,
                       const std::function<bool(double)>& progress) {
  const std::string path = RosBagPath(given);
  if (!IsDirectory(path) && LooksLikeRosbag1(path))
    return SummarizeRosbag1(path, summary, progress);
  if (LooksLikeRosBag(path)) {
    Ros2ReadReport report;
    const Status s = SummarizeRos2Bag(path, summary, &report, progress);
    summary->damaged = summary->damaged || report.damaged;
    if (warnings != nullptr) AddOnce(report.warnings, warnings);
    return s;
  }
  return NotABag(path);
}

Status ReadRosBag(const std::string& given, const RosReadOptions& options, RosMessageSink* sink,
                  RosReadStats* stats) {
  const std::string path = RosBagPath(given);
  if (!IsDirectory(path) && LooksLikeRosbag1(path)) return ReadRosbag1(path, options, sink, stats);
  if (LooksLikeRosBag(path)) {
    RosBagSummary ignored;
    Ros2ReadReport report;
    const Status s = ReadRos2Bag(path, options, sink, &ignored, stats, &report);
    if (stats != nullptr) {
      AddOnce(report.warnings, &stats->warnings);
      stats->damaged = stats->damaged || report.damaged;
    }
    return s;
  }
  return NotABag(path);
}

void ReleaseRosBags() { ReleaseRosbag1Cache(); }

}  // namespace sweepscan::io
