// MCAP reader (https://mcap.dev/spec, major version 0) for the ROS 2 messages
// sweepscan decodes: channels whose schema name is LaserScan, Odometry, Imu
// or TFMessage (RosMessageKindFromType) with message_encoding "cdr".
// docs/ros-bags.md ("ROS 2 bags") describes the record layer as read here.
//
// Streaming: records are read one after another with pread(); only the record
// at hand is in memory (a Chunk: its compressed and its uncompressed records,
// one chunk at a time). Attachments, Metadata and index records are skipped
// without being read. Chunk compression "", "zstd" and "lz4" (LZ4 frame
// format); a chunk's uncompressed_crc (CRC-32 as zlib's) is checked when not
// zero.
//
// Order: messages reach the sink in log-time order. rosbag2 and the MCAP
// writers append messages as they arrive, and such a file is read in one
// pass in file order. When chunks go back in time or overlap (by their
// message_start_time / message_end_time; the spec allows it), the file is
// read twice: counted and checked first, then its chunks' messages are
// merged by log_time (holding only the chunks that overlap the current
// instant, see docs/ros-bags.md). Messages outside chunks
// that go back in time are read in file order, and Ros2ReadReport says how
// many went back.
//
// Bad input never crashes and always says where and why:
//   - truncated file (a recording killed mid-write): the messages before the
//     torn record are delivered, the Status is Ok, and report->torn_tail and a
//     warning say at which byte the file ends and inside which record; in a
//     file without its Footer (unfinished), opcode 0x00 (zeros the recorder
//     had not written) and a damaged record followed only by zeros are a
//     torn tail too (docs/ros-bags.md, "Truncated files");
//   - unknown compression, bad CRC, a message on an unknown channel, a record
//     whose fields overrun it: an error naming the byte offset, e.g.
//     "x.mcap: chunk at byte 1234: unknown compression 'brotli'".
//   - a decodable message whose CDR bytes are bad: sink->OnUndecodable and
//     stats->messages_undecodable, reading goes on.
//
// Thread: the functions are reentrant; the sink is called on the caller's
// thread. stats counters are added to (not reset), so several files can share
// one RosReadStats.
#ifndef SWEEPSCAN_CORE_IO_ROS2_MCAP_H_
#define SWEEPSCAN_CORE_IO_ROS2_MCAP_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"
#include "core/io/ros2/cdr.h"

namespace sweepscan::io {

// Fills *s (format "mcap"). Uses the summary section (Statistics, Channel,
// Schema, Chunk Index records) when the file has one with per-channel message
// counts and its CRC matches; then topics' first_ns/last_ns are 0 (unknown).
// Otherwise scans the whole file (streaming) and fills them. A summary
// section that cannot be used is a warning in *report (if given), then the
// file is scanned; `progress` (if given) then hears the fraction of bytes
// scanned and cancels the scan by returning false (an error "cancelled").
Status SummarizeMcap(const std::string& path, RosBagSummary* s, Ros2ReadReport* report = nullptr,
                     const std::function<bool(double)>& progress = nullptr);

// Decodes the messages of opt.topics (all decodable ones if empty) and hands
// them to the sink in log-time order (above). Fills *summary (if given) from
// what was read.
Status ReadMcap(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report = nullptr);

// The same on a file image in memory (tests and the fuzzer); errors name the
// file "<memory>".
Status SummarizeMcapFromMemory(const uint8_t* data, size_t n, RosBagSummary* s,
                               Ros2ReadReport* report = nullptr);
Status ReadMcapFromMemory(const uint8_t* data, size_t n, const RosReadOptions& opt,
                          RosMessageSink* sink, RosBagSummary* summary, RosReadStats* stats,
                          Ros2ReadReport* report = nullptr);

// CRC-32 as zlib's crc32() (poly 0xEDB88320 reflected, init and xorout
// 0xFFFFFFFF); `crc` continues a previous result (0 to start).
uint32_t McapCrc32(const uint8_t* data, size_t n, uint32_t crc = 0);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS2_MCAP_H_
