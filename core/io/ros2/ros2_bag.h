// A ROS 2 bag as the user names it: a rosbag2 folder (metadata.yaml with
// rosbag2_bagfile_information: storage_identifier, relative_file_paths) or a
// single .db3 / .mcap file. Dispatches to the sqlite3 (ros2_sqlite.h) or MCAP
// (mcap.h) reader and goes over all files of a split bag in order.
//
// Refused with a clear message: a folder without metadata.yaml holding
// neither one .db3 or .mcap file nor a split bag's NAME_0.mcap, NAME_1.mcap,
// ... (or .db3), a storage identifier other than
// sqlite3/mcap, rosbag2 compression (compression_mode FILE or MESSAGE), a
// listed file that is missing.
//
// Thread: reentrant; the sink is called on the caller's thread.
#ifndef SWEEPSCAN_CORE_IO_ROS2_ROS2_BAG_H_
#define SWEEPSCAN_CORE_IO_ROS2_ROS2_BAG_H_

#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"
#include "core/io/ros2/cdr.h"

namespace sweepscan::io {

// *storage = "sqlite3" or "mcap"; *files = full paths in the bag's order.
// A folder without metadata.yaml (a recording that did not close) holding
// NAME_0.mcap, NAME_1.mcap, ... (or .db3) is those files in numeric order,
// with a warning in *warnings (if given) that metadata.yaml is missing.
Status FindRos2Bag(const std::string& path, std::string* storage, std::vector<std::string>* files,
                   std::vector<std::string>* warnings = nullptr);

// Summary over all files: topics merged by name (counts added, first/last
// widened), file_bytes added, compression the union. format is
// "rosbag2-sqlite3" or "mcap".
// `progress` as SummarizeMcap's, over the whole bag (by file bytes).
Status SummarizeRos2Bag(const std::string& path, RosBagSummary* s, Ros2ReadReport* report = nullptr,
                        const std::function<bool(double)>& progress = nullptr);

// Reads every file in order; progress runs 0..1 over the whole bag (by file
// bytes). Stops at the first file that fails; a torn tail of one file is a
// warning in *report and reading goes on with the next file.
Status ReadRos2Bag(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                   RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report = nullptr);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS2_ROS2_BAG_H_
