// rosbag2's sqlite3 storage (*.db3), as written by rosbag2_storage_default_plugins:
//   topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, serialization_format TEXT,
//          offered_qos_profiles TEXT)
//   messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB)
// timestamp is the receive (log) time in ns since the epoch; data is the
// serialized message (CDR for serialization_format "cdr"). docs/ros-bags.md
// ("ROS 2 bags") has the details.
//
// The database is opened read-only. Messages are streamed with sqlite3_step in
// ORDER BY timestamp, id: the sort runs over (id, topic_id, timestamp) only
// and each message's blob is fetched by id when it is decoded, so memory stays
// bounded however large the bag is (sqlite spills big sorts to temp files;
// rosbag2's timestamp index, when present, avoids the sort).
//
// Thread: the functions are reentrant; the sink is called on the caller's
// thread. stats counters are added to, so several files can share one.
#ifndef SWEEPSCAN_CORE_IO_ROS2_ROS2_SQLITE_H_
#define SWEEPSCAN_CORE_IO_ROS2_ROS2_SQLITE_H_

#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"
#include "core/io/ros2/cdr.h"

namespace sweepscan::io {

// Fills *s (format "rosbag2-sqlite3", compression "none") from the topics
// table and a GROUP BY over messages (counts, first and last timestamp).
//
// A damaged or truncated file (a recording cut short: sqlite calls it
// "database disk image is malformed") is read as far as it can be: the
// messages sqlite can still read are counted and delivered, and a warning
// in *report says so ("the database is damaged or truncated (...): N
// messages could be read, the rest is lost"). When not even the topics table
// can be read, the error says the file is damaged or truncated.
// `progress` (optional) is asked while the count runs (at fraction 0) and
// cancels it by returning false ("PATH: cancelled").
Status SummarizeRos2Sqlite(const std::string& path, RosBagSummary* s,
                           Ros2ReadReport* report = nullptr,
                           const std::function<bool(double)>& progress = nullptr);

// Decodes the messages of opt.topics (all decodable ones if empty) whose
// serialization_format is "cdr" and hands them to the sink by timestamp.
// Fills *summary (if given) as SummarizeRos2Sqlite does. report (if given)
// gets a warning per decodable topic in another serialization format.
Status ReadRos2Sqlite(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                      RosBagSummary* summary, RosReadStats* stats,
                      Ros2ReadReport* report = nullptr);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS2_ROS2_SQLITE_H_
