#include "core/io/ros2/mcap.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "core/io/ros2/mcap_records.h"

namespace sweepscan::io {

namespace {

using mcap_internal::ByteSource;
using mcap_internal::Fields;
using mcap_internal::OpName;

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

std::string At(const std::string& what, uint64_t pos) {
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
      : src_(src), opt_(opt), sink_(sink), stats_(stats), report_(report) {}

  Status Scan();
  // Summary from the summary section; *used false if there is none usable.
  Status SummaryFromIndex(bool* used);
  void Fill(RosBagSummary* s) const;
  uint64_t backwards() const { return backwards_; }

 private:
  Status Error(const std::string& why) const { return Status::Error(src_->name() + ": " + why); }
  void Warn(const std::string& why) { report_->warnings.push_back(src_->name() + ": " + why); }
  Status TornTail(uint64_t pos, const std::string& why);
  Status ReadContent(uint64_t pos, uint64_t len, std::vector<uint8_t>* buf);
  // Schema, Channel and Message records, at the top level or inside a chunk.
  Status Inner(uint8_t op, const uint8_t* p, size_t n, const std::string& where);
  Status ParseSchema(Fields* f);
  Status ParseChannel(Fields* f);
  Status Message(Fields* f, const std::string& where);
  Status Chunk(uint64_t pos, uint64_t len);
  Status Decompress(const std::string& compression, const std::vector<uint8_t>& in, uint64_t total,
                    const std::string& where);
  Status Progress(uint64_t pos);

  ByteSource* src_;
  const RosReadOptions* opt_;
  RosMessageSink* sink_;
  RosReadStats* stats_;
  Ros2ReadReport* report_;
  std::map<uint16_t, std::string> schemas_;  // id -> name
  std::map<uint16_t, ChannelInfo> channels_;
  std::set<std::string> compressions_;
  uint64_t messages_ = 0;
  int64_t start_ns_ = 0, end_ns_ = 0;
  int64_t previous_log_ns_ = 0;
  uint64_t backwards_ = 0;      // messages whose log time is before their predecessor's
  uint64_t bytes_counted_ = 0;  // added to stats_->bytes_read so far
  uint64_t last_progress_ = 0;  // where opt_->progress was last called
  std::vector<uint8_t> record_, compressed_, chunk_;
  mcap_internal::Decompressors decompressors_;
};

Status Reader::TornTail(uint64_t pos, const std::string& why) {
  report_->torn_tail = true;
  Warn("file ends at byte " + std::to_string(src_->size()) + " " + why + ": the " +
       std::to_string(messages_) + " messages before byte " + std::to_string(pos) +
       " were read, the rest of the file is lost");
  return Status::Ok();
}

Status Reader::ReadContent(uint64_t pos, uint64_t len, std::vector<uint8_t>* buf) {
  buf->resize(len);  // len <= the file's size, checked by the caller
  return src_->ReadAt(pos, len, buf->data());
}

Status Reader::Progress(uint64_t pos) {
  if (pos <= bytes_counted_) return Status::Ok();
  if (stats_ != nullptr) stats_->bytes_read += pos - bytes_counted_;
  bytes_counted_ = pos;
  if (opt_ != nullptr && opt_->progress &&
      (pos - last_progress_ >= kProgressStep || pos == src_->size())) {
    last_progress_ = pos;
    if (!opt_->progress(static_cast<double>(pos) / src_->size())) return Error("cancelled");
  }
  return Status::Ok();
}

Status Reader::Scan() {
  const uint64_t size = src_->size();
  uint8_t prefix[kPrefix];
  if (size < sizeof(kMagic) || !src_->ReadAt(0, sizeof(kMagic), prefix).ok() ||
      memcmp(prefix, kMagic, 8) != 0) {
    return Error("not an MCAP file (no MCAP magic \\x89MCAP0\\r\\n at byte 0)");
  }
  // A file that ends in a Footer and the closing magic was written whole: a
  // record that overruns it is corrupt (a damaged length), not cut short by
  // a crash, and is refused rather than read as a torn tail.
  uint64_t footer_at = 0;
  if (size >= 2 * sizeof(kMagic) + kFooterBytes) {
    uint8_t tail[kFooterBytes + sizeof(kMagic)];
    const uint64_t at = size - sizeof(tail);
    uint64_t footer_len = 0;
    if (src_->ReadAt(at, sizeof(tail), tail).ok()) memcpy(&footer_len, tail + 1, 8);
    if (tail[0] == kFooter && footer_len == 20 && memcmp(tail + kFooterBytes, kMagic, 8) == 0) {
      footer_at = at;
    }
  }
  uint64_t pos = sizeof(kMagic);
  for (bool first = true;; first = false) {
    const uint64_t left = size - pos;
    if (left == 0) return TornTail(pos, "after a complete record, without Data End or Footer");
    if (left < kPrefix) return TornTail(pos, "inside a record's opcode and length");
    Status s = src_->ReadAt(pos, kPrefix, prefix);
    if (!s.ok()) return s;
    const uint8_t op = prefix[0];
    uint64_t len;
    memcpy(&len, prefix + 1, 8);  // MCAP is little-endian, like every host we build for
    static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP reader assumes little-endian");
    if (first && op != kHeader) {
      return Error(At("record", pos) + " is " + OpName(op) + ", not the Header record");
    }
    if (op == 0) return Error(At("record", pos) + " has opcode 0x00, which is invalid");
    if (footer_at != 0 && op != kFooter && (pos >= footer_at || len > footer_at - pos - kPrefix)) {
      return Error(
          At(OpName(op), pos) + " claims " + std::to_string(len) +
          " bytes, past the Footer at byte " + std::to_string(footer_at) +
          ": the file is complete, so the record's length is corrupt (not a file cut short)");
    }
    // Schemas and channels are a few kB, a message at most a chunk: a larger
    // length is damage, and reading it would allocate it.
    if ((op == kSchema || op == kChannel) && len > kMaxRecordBytes && len <= left - kPrefix) {
      return Error(At(OpName(op), pos) + " claims " + std::to_string(len) +
                   " bytes, more than the " + std::to_string(kMaxRecordBytes) + " accepted");
    }
    if (op == kMessage && len > kMaxChunkBytes && len <= left - kPrefix) {
      return Error(At(OpName(op), pos) + " claims " + std::to_string(len) +
                   " bytes, more than the " + std::to_string(kMaxChunkBytes) + " accepted");
    }
    if (len > left - kPrefix) {
      return TornTail(pos, std::string("inside the ") + OpName(op) + " record at byte " +
                               std::to_string(pos) + " (it needs " + std::to_string(kPrefix + len) +
                               " bytes, " + std::to_string(left) + " are left)");
    }
    const uint64_t content = pos + kPrefix;
    if (op == kFooter || op == kDataEnd) return Progress(size);  // the data section is over
    if (op == kChunk) {
      s = Chunk(pos, len);
    } else if (op == kMessage && sink_ == nullptr) {
      // Counting only: channel_id, sequence, log_time, publish_time suffice.
      s = ReadContent(content, std::min<uint64_t>(len, 22), &record_);
      if (s.ok()) s = Inner(op, record_.data(), record_.size(), At(OpName(op), pos));
    } else if (op == kSchema || op == kChannel || op == kMessage) {
      s = ReadContent(content, len, &record_);
      if (s.ok()) s = Inner(op, record_.data(), record_.size(), At(OpName(op), pos));
    }  // Other records (attachments, indexes, metadata, private ones) are skipped unread.
    if (!s.ok()) return s;
    pos = content + len;
    s = Progress(pos);
    if (!s.ok()) return s;
  }
}

Status Reader::Inner(uint8_t op, const uint8_t* p, size_t n, const std::string& where) {
  Fields f(p, n, where);
  if (op == kSchema) return ParseSchema(&f);
  if (op == kChannel) return ParseChannel(&f);
  if (op == kMessage) return Message(&f, where);
  return Status::Ok();
}

Status Reader::ParseSchema(Fields* f) {
  uint16_t id;
  std::string name, encoding;
  Status s = f->U16("id", &id);
  if (s.ok()) s = f->String("name", &name);
  if (s.ok()) s = f->String("encoding", &encoding);
  if (s.ok()) s = f->Skip32("data");
  if (!s.ok()) return Error(s.message());
  if (id == 0) return Status::Ok();  // invalid by the spec: ignored
  auto [it, inserted] = schemas_.emplace(id, name);
  if (!inserted && it->second != name) {
    return Error(f->where() + ": schema " + std::to_string(id) + " was '" + it->second +
                 "', now '" + name + "'");
  }
  return Status::Ok();
}

Status Reader::ParseChannel(Fields* f) {
  uint16_t id;
  ChannelInfo c;
  Status s = f->U16("id", &id);
  if (s.ok()) s = f->U16("schema_id", &c.schema_id);
  if (s.ok()) s = f->String("topic", &c.topic);
  if (s.ok()) s = f->String("message_encoding", &c.encoding);
  if (s.ok()) s = f->Skip32("metadata");
  if (!s.ok()) return Error(s.message());
  auto known = channels_.find(id);
  if (known != channels_.end()) {
    const ChannelInfo& k = known->second;
    if (k.topic != c.topic || k.schema_id != c.schema_id || k.encoding != c.encoding) {
      return Error(f->where() + ": channel " + std::to_string(id) + " was '" + k.topic +
                   "' (schema " + std::to_string(k.schema_id) + "), now '" + c.topic +
                   "' (schema " + std::to_string(c.schema_id) + ")");
    }
    return Status::Ok();
  }
  if (c.schema_id != 0) {
    auto schema = schemas_.find(c.schema_id);
    if (schema == schemas_.end()) {
      return Error(f->where() + ": channel " + std::to_string(id) + " ('" + c.topic +
                   "') refers to schema " + std::to_string(c.schema_id) +
                   ", which no earlier Schema record defines");
    }
    c.type = schema->second;
  }
  c.kind = RosMessageKindFromType(c.type);
  const bool wanted = opt_ == nullptr || opt_->topics.empty() || opt_->topics.count(c.topic);
  c.decode = c.kind != RosMessageKind::kOther && c.encoding == "cdr" && wanted;
  if (sink_ != nullptr && wanted && c.kind != RosMessageKind::kOther && c.encoding != "cdr") {
    Warn("topic " + c.topic + " (" + c.type + ") is in message encoding '" + c.encoding +
         "', not cdr: its messages are skipped");
  }
  channels_.emplace(id, std::move(c));
  return Status::Ok();
}

Status Reader::Message(Fields* f, const std::string& where) {
  uint16_t channel_id;
  uint32_t sequence;
  uint64_t log_time, publish_time;
  Status s = f->U16("channel_id", &channel_id);
  if (s.ok()) s = f->U32("sequence", &sequence);
  if (s.ok()) s = f->U64("log_time", &log_time);
  if (s.ok()) s = f->U64("publish_time", &publish_time);
  if (!s.ok()) return Error(s.message());
  auto it = channels_.find(channel_id);
  if (it == channels_.end()) {
    return Error(where + ": message on unknown channel " + std::to_string(channel_id) +
                 " (no earlier Channel record defines it)");
  }
  ChannelInfo& c = it->second;
  const int64_t t = static_cast<int64_t>(log_time);
  if (c.count == 0 || t < c.first_ns) c.first_ns = t;
  if (c.count == 0 || t > c.last_ns) c.last_ns = t;
  ++c.count;
  if (messages_ == 0 || t < start_ns_) start_ns_ = t;
  if (messages_ == 0 || t > end_ns_) end_ns_ = t;
  if (messages_ > 0 && t < previous_log_ns_) ++backwards_;
  previous_log_ns_ = t;
  ++messages_;
  if (sink_ == nullptr) return Status::Ok();
  if (!c.decode) {
    if (stats_ != nullptr) ++stats_->messages_skipped;
    return Status::Ok();
  }
  RosMessageInfo info;
  info.topic = &c.topic;
  info.type = &c.type;
  info.log_time_ns = t;
  if (!DispatchCdrMessage(c.kind, info, f->rest(), f->left(), sink_, stats_)) {
    return Error("cancelled");
  }
  return Status::Ok();
}

Status Reader::Chunk(uint64_t pos, uint64_t len) {
  const std::string where = At("chunk", pos);
  // Fixed fields (32 bytes), then the compression string and the records'
  // length; the records are read only once these check out.
  uint8_t fixed[32];
  if (len < sizeof(fixed) + 8) {
    return Error(where + ": record of " + std::to_string(len) + " bytes is too short");
  }
  Status s = src_->ReadAt(pos + kPrefix, sizeof(fixed), fixed);
  if (!s.ok()) return s;
  uint64_t uncompressed_size;
  uint32_t crc, compression_len;
  memcpy(&uncompressed_size, fixed + 16, 8);
  memcpy(&crc, fixed + 24, 4);
  memcpy(&compression_len, fixed + 28, 4);
  if (compression_len > len - sizeof(fixed) - 8) {
    return Error(where + ": compression: string of " + std::to_string(compression_len) +
                 " bytes overruns the record");
  }
  std::string compression(compression_len, '\0');
  uint64_t records_len;
  s = src_->ReadAt(pos + kPrefix + sizeof(fixed), compression_len,
                   reinterpret_cast<uint8_t*>(compression.data()));
  if (s.ok()) {
    s = src_->ReadAt(pos + kPrefix + sizeof(fixed) + compression_len, 8,
                     reinterpret_cast<uint8_t*>(&records_len));
  }
  if (!s.ok()) return s;
  const uint64_t records_at = pos + kPrefix + sizeof(fixed) + compression_len + 8;
  if (records_len > pos + kPrefix + len - records_at) {
    return Error(where + ": records: " + std::to_string(records_len) +
                 " bytes overrun the record (" + std::to_string(pos + kPrefix + len - records_at) +
                 " left)");
  }
  if (compression != "" && compression != "zstd" && compression != "lz4") {
    return Error(where + ": unknown compression '" + compression + "'");
  }
  if (uncompressed_size > kMaxChunkBytes) {
    return Error(where + ": uncompressed_size " + std::to_string(uncompressed_size) +
                 " is more than the " + std::to_string(kMaxChunkBytes) + " bytes accepted");
  }
  compressions_.insert(compression.empty() ? "none" : compression);
  if (compression.empty()) {
    if (records_len != uncompressed_size) {
      return Error(where + ": uncompressed chunk of " + std::to_string(records_len) +
                   " bytes says uncompressed_size " + std::to_string(uncompressed_size));
    }
    s = ReadContent(records_at, records_len, &chunk_);
  } else if (uncompressed_size == 0 && records_len == 0) {
    chunk_.clear();  // an empty chunk: nothing to decompress into
  } else {
    // A compressed chunk with bytes but uncompressed_size 0 is damage: the
    // decompression says so ("decompresses to more than 0 bytes") instead of
    // its messages vanishing unread.
    if (records_len > kMaxChunkBytes) {
      return Error(where + ": records: " + std::to_string(records_len) +
                   " compressed bytes, more than the " + std::to_string(kMaxChunkBytes) +
                   " accepted");
    }
    s = ReadContent(records_at, records_len, &compressed_);
    if (s.ok()) s = Decompress(compression, compressed_, uncompressed_size, where);
  }
  if (!s.ok()) return s;
  if (crc != 0) {
    const uint32_t actual = McapCrc32(chunk_.data(), chunk_.size());
    if (actual != crc) {
      char text[96];
      snprintf(text, sizeof(text),
               ": CRC-32 of the uncompressed records is 0x%08x, the chunk "
               "says 0x%08x",
               actual, crc);
      return Error(where + text);
    }
  }
  // The records inside: Schema, Channel, Message (others skipped).
  const uint8_t* p = chunk_.data();
  const size_t n = chunk_.size();
  for (size_t at = 0; at < n;) {
    if (n - at < kPrefix) {
      return Error(where + ": record at offset " + std::to_string(at) + " of its " +
                   std::to_string(n) + " uncompressed bytes is cut after " +
                   std::to_string(n - at) + " bytes");
    }
    uint64_t inner_len;
    memcpy(&inner_len, p + at + 1, 8);
    if (inner_len > n - at - kPrefix) {
      return Error(where + ": " + OpName(p[at]) + " record at offset " + std::to_string(at) +
                   " needs " + std::to_string(kPrefix + inner_len) + " bytes, " +
                   std::to_string(n - at) + " are left in the chunk");
    }
    s = Inner(p[at], p + at + kPrefix, inner_len,
              where + ": " + OpName(p[at]) + " record at offset " + std::to_string(at));
    if (!s.ok()) return s;
    at += kPrefix + inner_len;
  }
  return Status::Ok();
}

Status Reader::Decompress(const std::string& compression, const std::vector<uint8_t>& in,
                          uint64_t total, const std::string& where) {
  std::string why = decompressors_.Run(compression, in.data(), in.size(), total, &chunk_);
  if (!why.empty()) return Error(where + ": " + compression + ": " + why);
  return Status::Ok();
}

Status Reader::SummaryFromIndex(bool* used) {
  *used = false;
  const uint64_t size = src_->size();
  if (size < 2 * sizeof(kMagic) + kPrefix + kFooterBytes) return Status::Ok();
  const uint64_t footer_at = size - sizeof(kMagic) - kFooterBytes;
  uint8_t tail[kFooterBytes + sizeof(kMagic)];
  Status s = src_->ReadAt(footer_at, sizeof(tail), tail);
  if (!s.ok()) return s;
  uint64_t footer_len, summary_start, summary_offset_start;
  uint32_t summary_crc;
  memcpy(&footer_len, tail + 1, 8);
  memcpy(&summary_start, tail + 9, 8);
  memcpy(&summary_offset_start, tail + 17, 8);
  memcpy(&summary_crc, tail + 25, 4);
  if (tail[0] != kFooter || footer_len != 20 || memcmp(tail + kFooterBytes, kMagic, 8) != 0) {
    return Status::Ok();  // no footer: the scan will say why
  }
  if (summary_start == 0) return Status::Ok();
  const uint64_t end = summary_offset_start != 0 ? summary_offset_start : footer_at;
  if (summary_start < sizeof(kMagic) || summary_start > end || end > footer_at) {
    Warn("footer: summary_start " + std::to_string(summary_start) + " / summary_offset_start " +
         std::to_string(summary_offset_start) + " lie outside the file; scanning it instead");
    return Status::Ok();
  }
  if (summary_crc != 0) {
    // From the summary section's start through the footer's summary_offset_start.
    uint32_t crc = 0;
    std::vector<uint8_t> block(64 * 1024);
    for (uint64_t at = summary_start, stop = footer_at + 25; at < stop;) {
      const size_t k = static_cast<size_t>(std::min<uint64_t>(block.size(), stop - at));
      s = src_->ReadAt(at, k, block.data());
      if (!s.ok()) return s;
      crc = McapCrc32(block.data(), k, crc);
      at += k;
    }
    if (crc != summary_crc) {
      Warn("summary section's CRC-32 does not match the footer's; scanning the file instead");
      return Status::Ok();
    }
  }
  bool have_statistics = false;
  uint64_t message_count = 0, start = 0, finish = 0;
  uint32_t chunk_count = 0, chunk_indexes = 0;
  std::map<uint16_t, uint64_t> counts;
  for (uint64_t pos = summary_start; pos < end;) {
    uint8_t prefix[kPrefix];
    uint64_t len;
    if (end - pos < kPrefix || !src_->ReadAt(pos, kPrefix, prefix).ok() ||
        (memcpy(&len, prefix + 1, 8), len > end - pos - kPrefix)) {
      Warn(At("summary record", pos) + " overruns the summary section; scanning the file");
      return Status::Ok();
    }
    const uint8_t op = prefix[0];
    if (op == kSchema || op == kChannel || op == kStatistics || op == kChunkIndex) {
      s = ReadContent(pos + kPrefix, len, &record_);
      if (!s.ok()) return s;
      Fields f(record_.data(), record_.size(), At(OpName(op), pos));
      if (op == kSchema) s = ParseSchema(&f);
      if (op == kChannel) s = ParseChannel(&f);
      if (op == kStatistics) {
        uint16_t schema_count;
        uint32_t channel_count, attachment_count, metadata_count;
        s = f.U64("message_count", &message_count);
        if (s.ok()) s = f.U16("schema_count", &schema_count);
        if (s.ok()) s = f.U32("channel_count", &channel_count);
        if (s.ok()) s = f.U32("attachment_count", &attachment_count);
        if (s.ok()) s = f.U32("metadata_count", &metadata_count);
        if (s.ok()) s = f.U32("chunk_count", &chunk_count);
        if (s.ok()) s = f.U64("message_start_time", &start);
        if (s.ok()) s = f.U64("message_end_time", &finish);
        if (s.ok()) s = f.MapU16U64("channel_message_counts", &counts);
        have_statistics = s.ok();
      }
      if (op == kChunkIndex) {
        uint64_t skip;
        std::string compression;
        for (const char* name :
             {"message_start_time", "message_end_time", "chunk_start_offset", "chunk_length"}) {
          if (s.ok()) s = f.U64(name, &skip);
        }
        if (s.ok()) s = f.Skip32("message_index_offsets");
        if (s.ok()) s = f.U64("message_index_length", &skip);
        if (s.ok()) s = f.String("compression", &compression);
        if (s.ok()) compressions_.insert(compression.empty() ? "none" : compression);
        ++chunk_indexes;
      }
      if (!s.ok()) {
        // Schema/Channel errors already name the file, field errors do not.
        const std::string& m = s.message();
        report_->warnings.push_back(
            (m.rfind(src_->name() + ": ", 0) == 0 ? m : src_->name() + ": " + m) +
            "; scanning the file instead");
        return Status::Ok();
      }
    }
    pos += kPrefix + len;
  }
  if (!have_statistics || (message_count > 0 && counts.empty()) || chunk_indexes < chunk_count) {
    return Status::Ok();  // not enough to summarize from: scan
  }
  for (const auto& [id, count] : counts) {
    auto it = channels_.find(id);
    if (it == channels_.end()) {
      Warn("Statistics count messages on channel " + std::to_string(id) +
           ", which the summary section does not define; scanning the file instead");
      return Status::Ok();
    }
    it->second.count = count;
  }
  messages_ = message_count;
  start_ns_ = static_cast<int64_t>(start);
  end_ns_ = static_cast<int64_t>(finish);
  *used = true;
  return Status::Ok();
}

void Reader::Fill(RosBagSummary* s) const {
  s->format = "mcap";
  s->file_bytes = src_->size();
  s->message_count = messages_;
  s->start_ns = start_ns_;
  s->end_ns = end_ns_;
  std::set<std::string> names = compressions_;
  if (names.size() > 1) names.erase("none");
  s->compression.clear();
  for (const std::string& c : names) s->compression += (s->compression.empty() ? "" : ",") + c;
  if (s->compression.empty()) s->compression = "none";
  std::map<std::string, RosTopicInfo> topics;  // sorted by name; channels of a topic merged
  for (const auto& [id, c] : channels_) {
    auto [it, inserted] = topics.emplace(c.topic, RosTopicInfo());
    RosTopicInfo& t = it->second;
    if (inserted) {
      t.topic = c.topic;
      t.type = c.type;
      t.serialization = c.encoding;
    }
    if (c.count > 0) {
      t.first_ns = t.message_count == 0 ? c.first_ns : std::min(t.first_ns, c.first_ns);
      t.last_ns = t.message_count == 0 ? c.last_ns : std::max(t.last_ns, c.last_ns);
    }
    t.message_count += c.count;
  }
  s->topics.clear();
  for (auto& [name, t] : topics) s->topics.push_back(std::move(t));
}

Status Summarize(ByteSource* src, RosBagSummary* s, Ros2ReadReport* report,
                 const std::function<bool(double)>& progress = nullptr) {
  Ros2ReadReport local;
  if (report == nullptr) report = &local;
  {
    Reader index(src, nullptr, nullptr, nullptr, report);
    bool used = false;
    Status st = index.SummaryFromIndex(&used);
    if (!st.ok()) return st;
    if (used) {
      index.Fill(s);
      return Status::Ok();
    }
  }
  // No summary: the whole file is read, which a caller may follow and cancel.
  RosReadOptions opt;
  opt.progress = progress;
  Reader scan(src, progress ? &opt : nullptr, nullptr, nullptr, report);
  Status st = scan.Scan();
  if (st.ok()) scan.Fill(s);
  return st;
}

Status Read(ByteSource* src, const RosReadOptions& opt, RosMessageSink* sink,
            RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report) {
  Ros2ReadReport local_report;
  RosReadStats local_stats;
  if (report == nullptr) report = &local_report;
  if (stats == nullptr) stats = &local_stats;
  Reader reader(src, &opt, sink, stats, report);
  Status st = reader.Scan();
  if (reader.backwards() > 0) {
    report->warnings.push_back(src->name() + ": " + std::to_string(reader.backwards()) +
                               " messages have an earlier log time than the message before "
                               "them (delivered in file order)");
  }
  if (summary != nullptr) reader.Fill(summary);
  return st;
}

}  // namespace

Status SummarizeMcap(const std::string& path, RosBagSummary* s, Ros2ReadReport* report,
                     const std::function<bool(double)>& progress) {
  std::unique_ptr<ByteSource> src;
  Status st = mcap_internal::OpenFileSource(path, &src);
  return st.ok() ? Summarize(src.get(), s, report, progress) : st;
}

Status ReadMcap(const std::string& path, const RosReadOptions& opt, RosMessageSink* sink,
                RosBagSummary* summary, RosReadStats* stats, Ros2ReadReport* report) {
  std::unique_ptr<ByteSource> src;
  Status st = mcap_internal::OpenFileSource(path, &src);
  return st.ok() ? Read(src.get(), opt, sink, summary, stats, report) : st;
}

Status SummarizeMcapFromMemory(const uint8_t* data, size_t n, RosBagSummary* s,
                               Ros2ReadReport* report) {
  auto src = mcap_internal::MemorySource(data, n);
  return Summarize(src.get(), s, report);
}

Status ReadMcapFromMemory(const uint8_t* data, size_t n, const RosReadOptions& opt,
                          RosMessageSink* sink, RosBagSummary* summary, RosReadStats* stats,
                          Ros2ReadReport* report) {
  auto src = mcap_internal::MemorySource(data, n);
  return Read(src.get(), opt, sink, summary, stats, report);
}

}  // namespace sweepscan::io
