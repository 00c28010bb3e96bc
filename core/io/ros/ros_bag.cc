#include "core/io/ros/ros_bag.h"

#include <sys/stat.h>

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

}  // namespace

bool LooksLikeRosBag(const std::string& path) {
  if (IsDirectory(path)) {
    struct stat st;
    return stat((path + "/metadata.yaml").c_str(), &st) == 0;
  }
  return LooksLikeRosbag1(path) || IsRos2File(path);
}

Status SummarizeRosBag(const std::string& path, RosBagSummary* summary) {
  if (!IsDirectory(path) && LooksLikeRosbag1(path)) return SummarizeRosbag1(path, summary);
  if (LooksLikeRosBag(path)) return SummarizeRos2Bag(path, summary);
  return Status::Error(path + ": not a ROS bag (neither a ROS 1 .bag, an MCAP or sqlite3 file, "
                              "nor a ROS 2 bag folder with metadata.yaml)");
}

Status ReadRosBag(const std::string& path, const RosReadOptions& options, RosMessageSink* sink,
                  RosReadStats* stats) {
  if (!IsDirectory(path) && LooksLikeRosbag1(path)) return ReadRosbag1(path, options, sink, stats);
  if (LooksLikeRosBag(path)) {
    RosBagSummary ignored;
    return ReadRos2Bag(path, options, sink, &ignored, stats);
  }
  return Status::Error(path + ": not a ROS bag (neither a ROS 1 .bag, an MCAP or sqlite3 file, "
                              "nor a ROS 2 bag folder with metadata.yaml)");
}

void ReleaseRosBags() { ReleaseRosbag1Cache(); }

}  // namespace sweepscan::io
