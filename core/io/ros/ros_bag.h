// Any ROS bag, whichever its format: a ROS 1 .bag (rosbag_storage), a ROS 2
// bag folder (metadata.yaml with sqlite3 or MCAP storage), or a single .db3
// or .mcap file. Picks the reader by what the path holds (magic bytes, not
// the suffix) and forwards to it (docs/ros-bags.md).
//
// Pure functions; any thread.
#ifndef SWEEPSCAN_CORE_IO_ROS_ROS_BAG_H_
#define SWEEPSCAN_CORE_IO_ROS_ROS_BAG_H_

#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

// The bag a path names: a rosbag2 folder's metadata.yaml (what a file
// chooser picks, and what a shell completes to) stands for its folder; any
// other path is itself. The functions below take either.
std::string RosBagPath(const std::string& path);

// True if `path` is something ReadRosBag would try: a ROS 1 bag, an MCAP or
// sqlite3 file, or a folder with a metadata.yaml (the CLI uses it to tell a
// bag from a sweepscan session folder).
bool LooksLikeRosBag(const std::string& path);

// `warnings` (optional) gets what the summary read past (ROS 2: a damaged
// summary section, a file cut short). `progress` (optional) hears the
// fraction read of a bag that must be read whole for its summary (an MCAP
// without a summary section), of a ROS 1 bag's index walked, or 0 while a
// rosbag2 sqlite3 bag's messages are counted, and cancels any of them by
// returning false ("PATH: cancelled").
Status SummarizeRosBag(const std::string& path, RosBagSummary* summary,
                       std::vector<std::string>* warnings = nullptr,
                       const std::function<bool(double)>& progress = nullptr);
Status ReadRosBag(const std::string& path, const RosReadOptions& options, RosMessageSink* sink,
                  RosReadStats* stats);
// Closes what the readers keep open between calls (the last ROS 1 bag).
void ReleaseRosBags();

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS_ROS_BAG_H_
