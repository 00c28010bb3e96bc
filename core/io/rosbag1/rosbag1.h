// ROS 1 bags (format 2.0; uncompressed, bz2 and lz4 chunks), read with the
// field's own library: Debian's rosbag_storage (noetic-era ros_comm 1.15)
// and the ROS message headers. This room is the only place those headers
// are seen (they drag in boost, pluginlib and class_loader); the rest of
// the build sees ros_messages.h only.
//
// A bag is read through its index (rosbag::View), so memory stays bounded by
// one chunk whatever the bag's size. A bag whose index is missing (a
// recording cut short, "rosbag reindex" not run) is refused with that advice.
//
// Any thread; calls are serialised (the last bag opened is kept open for the
// next call, ReleaseRosbag1Cache).
#ifndef SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_H_
#define SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_H_

#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

// True if the file starts with "#ROSBAG V2.0\n" (a ROS 1 bag of the format
// rosbag_storage reads). False for anything else, including a missing file.
bool LooksLikeRosbag1(const std::string& path);

// Topics, types, counts and the time span, from the bag's index (no message
// is decoded). `compression` is the first chunk's ("none", "bz2", "lz4").
// `progress` (optional) hears the fraction of the index walked (a ten-hour
// bag's takes a second or two) and cancels by returning false.
Status SummarizeRosbag1(const std::string& path, RosBagSummary* summary,
                        const std::function<bool(double)>& progress = nullptr);

// Decodes the messages of the requested topics (options.topics; empty =
// every topic of a type ros_messages.h knows) and hands them to the sink in
// the bag's time order. A message whose bytes do not deserialize (or whose
// definition's MD5 differs from the type sweepscan knows) is counted in
// stats->messages_undecodable and reported to the sink; the rest goes on.
Status ReadRosbag1(const std::string& path, const RosReadOptions& options, RosMessageSink* sink,
                   RosReadStats* stats);

// Readers keep the last bag opened (its index read) for the next call on
// the same unchanged file; this closes it. ImportRosBag calls it when done.
void ReleaseRosbag1Cache();

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_H_
