// Bounds checks on a ROS 1 bag before rosbag_storage reads it.
//
// rosbag_storage (ros_comm 1.15) trusts the bag's lengths and offsets: an
// index entry that points past its chunk, a record header whose field
// lengths overrun it, or a message array whose count exceeds its bytes make
// it read out of bounds (a crash) or allocate what the count says (4 G
// floats from one flipped length). ROS's Python reader raises on the same
// files. These checks walk the bag as the format specifies
// (wiki.ros.org/Bags/Format/2.0, docs/ros-bags.md) with every length checked
// against what holds it, so that a damaged bag is refused with the byte and
// the reason before the library sees it, and a damaged message is counted
// and skipped instead of decoded.
//
// Pure C++ over bytes (bz2 and roslz4 for the chunks): no ROS headers, so
// the fuzz target builds it alone.
#ifndef SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_CHECK_H_
#define SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_CHECK_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

// The whole bag image (file contents) `data` of `size` bytes, named `name`
// in messages: every record inside the file and inside its chunk's
// decompressed bytes, header fields inside their header, the bag header's
// counts and index position, index entries pointing at a message record of
// their connection in the chunk before them, chunk infos at a chunk. An
// index position beyond the end (a copy cut short) says to reindex. A bag
// without an index (index position 0) passes: rosbag refuses it with its
// own advice.
//
// `chunks` false checks the file's own records only: each chunk's record,
// not what it compresses, and index entries against the chunk's stated
// size. That is all rosbag reads for a summary (the index: connections,
// chunk infos, index data) and costs a read of the records' headers, where
// the full check decompresses every chunk (minutes for a large bz2 bag):
// the reader does the full check before it reads messages.
Status CheckRosbag1Image(const uint8_t* data, size_t size, const std::string& name,
                         bool chunks = true);
// The same on the file at `path` (read in pieces, a chunk's decompressed
// bytes at a time). `progress` (optional) hears the fraction checked, a
// chunk at a time, and cancels ("cancelled") by returning false.
// `first_compression` (optional) gets the compression of the bag's first
// chunk ("none", "bz2", "lz4"; unchanged if it has none), for `info`.
Status CheckRosbag1File(const std::string& path, bool chunks = true,
                        const std::function<bool(double)>& progress = nullptr,
                        std::string* first_compression = nullptr);

// A message body in ROS 1 serialisation (little-endian, unaligned, u32
// lengths before strings and variable arrays) walked as `kind`'s message
// definition: every length within the bytes left, and nothing left over.
// kOther passes. The message says which field and where.
Status CheckRos1Message(RosMessageKind kind, const uint8_t* data, size_t size);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROSBAG1_ROSBAG1_CHECK_H_
