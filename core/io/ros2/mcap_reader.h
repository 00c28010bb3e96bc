// The MCAP reader's one pass over one file (core/io/ros2/mcap.h): the
// record loop, chunks, the summary section. Internal to mcap.cc and
// mcap_summary.cc (the summary section's reading); not a public interface.
//
// Thread: one object per read, used from one thread.
#ifndef SWEEPSCAN_CORE_IO_ROS2_MCAP_READER_H_
#define SWEEPSCAN_CORE_IO_ROS2_MCAP_READER_H_

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/ros/ros_messages.h"
#include "core/io/ros2/cdr.h"
#include "core/io/ros2/mcap_records.h"

namespace sweepscan::io::mcap_internal {

constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kDataEnd = 0x0F,
};
constexpr uint64_t kPrefix = 9;        // opcode u8 + content length u64
constexpr uint64_t kFooterBytes = 29;  // prefix + summary_start, summary_offset_start, crc
// A chunk holds at least one message; rosbag2 closes chunks at ~1 MB. This
// cap only refuses absurd sizes before anything is allocated.
constexpr uint64_t kMaxChunkBytes = uint64_t{1} << 30;
constexpr uint64_t kMaxRecordBytes = uint64_t{16} << 20;  // a Schema or Channel record
constexpr uint64_t kProgressStep = uint64_t{1} << 20;

inline std::string At(const std::string& what, uint64_t pos) {
  return what + " at byte " + std::to_string(pos);
}

struct ChannelInfo {
  std::string topic, encoding, type;
  uint16_t schema_id = 0;
  RosMessageKind kind = RosMessageKind::kOther;
  bool decode = false;
  uint64_t count = 0;
  int64_t first_ns = 0, last_ns = 0;
};

// One pass over one file. Without a sink it only counts (SummarizeMcap).
class Reader {
 public:
  Reader(ByteSource* src, const RosReadOptions* opt, RosMessageSink* sink, RosReadStats* stats,
         Ros2ReadReport* report)
      : src_(src),
        opt_(opt),
        sink_(sink),
        stats_(stats),
        report_(report),
        reading_(sink != nullptr) {}

  Status Scan();
  // Summary from the summary section; *used false if there is none usable.
  Status SummaryFromIndex(bool* used);
  void Fill(RosBagSummary* s) const;
  uint64_t backwards() const { return backwards_; }
  bool reordered() const { return reordered_; }

 private:
  // A chunk, or a message outside chunks, and the log times it spans: what
  // is put in log-time order when the chunks are not (DeliverInLogTimeOrder).
  struct Unit {
    uint64_t pos, len;
    int64_t start, end;  // the log times of its first and last message
    bool chunk;
    bool torn;        // its records failed after `messages` (the file's torn tail)
    size_t messages;  // how many of its messages (in log-time order) the first pass accepted
  };
  // A message inside a chunk, waiting to be handed on in log-time order.
  struct Pending {
    int64_t log_ns;
    const uint8_t* p;  // the record's content
    size_t n;
    size_t at;  // the record's offset in its chunk (for messages naming it)
    uint64_t chunk_pos;
  };

  Status Error(const std::string& why) const { return Status::Error(src_->name() + ": " + why); }
  void Warn(const std::string& why) { report_->warnings.push_back(src_->name() + ": " + why); }
  Status TornTail(uint64_t pos, const std::string& why);
  // The record loop from byte 8 on; footer_at is the Footer's offset, or 0.
  Status Walk(uint64_t footer_at);
  // True when nothing but zero bytes lies in [from, the file's end).
  bool OnlyZerosFrom(uint64_t from);
  // False when a chunk starts before an earlier one ends (by the chunks'
  // message_start_time / message_end_time), looking no further than the
  // first damage or the end of the data section.
  bool ChunksInLogTimeOrder();
  Status DeliverInLogTimeOrder();
  Status ReadContent(uint64_t pos, uint64_t len, std::vector<uint8_t>* buf);
  // Schema, Channel and Message records, at the top level or inside a chunk.
  Status Inner(uint8_t op, const uint8_t* p, size_t n, const std::string& where);
  Status ParseSchema(Fields* f);
  Status ParseChannel(Fields* f);
  Status Message(Fields* f, const std::string& where);
  Status Chunk(uint64_t pos, uint64_t len);
  // Reads, decompresses and checks a chunk's records into chunk_.
  Status LoadChunk(uint64_t pos, uint64_t len);
  // Goes over chunk_'s records: Schema and Channel at once, messages into
  // *pending (in log-time order when they are not already).
  Status ChunkRecords(uint64_t pos, std::vector<Pending>* pending);
  Status Deliver(const Pending& m);
  Status Decompress(const std::string& compression, const std::vector<uint8_t>& in, uint64_t total,
                    const std::string& where);
  Status Progress(uint64_t pos);

  ByteSource* src_;
  const RosReadOptions* opt_;
  RosMessageSink* sink_;
  RosReadStats* stats_;
  Ros2ReadReport* report_;
  const bool reading_;                       // a read (with a sink), not a summary
  std::map<uint16_t, std::string> schemas_;  // id -> name
  std::map<uint16_t, ChannelInfo> channels_;
  std::set<std::string> compressions_;
  uint64_t messages_ = 0;
  int64_t start_ns_ = 0, end_ns_ = 0;
  int64_t previous_log_ns_ = 0;
  uint64_t backwards_ = 0;       // messages whose log time is before their predecessor's
  uint64_t bytes_counted_ = 0;   // added to stats_->bytes_read so far
  uint64_t last_progress_ = 0;   // where opt_->progress was last called
  double progress_scale_ = 1.0;  // a read in log-time order goes over the file twice
  double progress_offset_ = 0.0;
  bool cancelled_ = false;
  bool counting_ = true;        // Message() counts (false: the second pass delivers)
  bool collect_units_ = false;  // Walk() lists units_ (the first pass of two)
  bool reordered_ = false;
  std::vector<Unit> units_;
  std::vector<uint8_t> record_, compressed_, chunk_;
  mcap_internal::Decompressors decompressors_;
};

}  // namespace sweepscan::io::mcap_internal

#endif  // SWEEPSCAN_CORE_IO_ROS2_MCAP_READER_H_
