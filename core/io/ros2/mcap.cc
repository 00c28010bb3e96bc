#include "core/io/ros2/mcap.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <queue>
#include <set>
#include <vector>

#include "core/io/ros2/mcap_reader.h"
#include "core/io/ros2/mcap_records.h"

namespace sweepscan::io {

namespace {

using mcap_internal::ByteSource;
using mcap_internal::Fields;
using mcap_internal::OpName;
using mcap_internal::Reader;

}  // namespace

namespace mcap_internal {

Status Reader::TornTail(uint64_t pos, const std::string& why) {
  report_->torn_tail = true;
  report_->damaged = true;
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
    const double f = progress_offset_ + progress_scale_ * static_cast<double>(pos) / src_->size();
    if (!opt_->progress(f)) {
      cancelled_ = true;
      return Error("cancelled");
    }
  }
  return Status::Ok();
}

bool Reader::OnlyZerosFrom(uint64_t from) {
  std::vector<uint8_t> block(64 * 1024);
  for (uint64_t at = from, size = src_->size(); at < size;) {
    const size_t k = static_cast<size_t>(std::min<uint64_t>(block.size(), size - at));
    if (!src_->ReadAt(at, k, block.data()).ok()) return false;
    for (size_t i = 0; i < k; ++i) {
      if (block[i] != 0) return false;
    }
    at += k;
  }
  return true;
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
  if (sink_ == nullptr || ChunksInLogTimeOrder()) return Walk(footer_at);
  // Chunks out of log-time order (the spec allows it; readers are to use
  // the chunks' times): a first pass counts, checks and learns every channel
  // (a chunk late in time may define the channels of all), the second hands
  // the messages on in log-time order.
  reordered_ = true;
  RosMessageSink* sink = sink_;
  sink_ = nullptr;
  collect_units_ = true;
  progress_scale_ = 0.5;
  Status s = Walk(footer_at);
  sink_ = sink;
  collect_units_ = false;
  if (!s.ok()) return s;
  counting_ = false;
  return DeliverInLogTimeOrder();
}

Status Reader::Walk(uint64_t footer_at) {
  const uint64_t size = src_->size();
  uint8_t prefix[kPrefix];
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
    if (op == 0 && footer_at == 0) {
      // No opcode is 0: in a file without its Footer these are blocks the
      // recorder had not written when it stopped (a power loss leaves them
      // zero-filled). Nothing after them can be found.
      return TornTail(pos, std::string("at opcode 0x00 at byte ") + std::to_string(pos) + " (" +
                               (OnlyZerosFrom(pos) ? "zero bytes to the end of the file"
                                                   : "unwritten or damaged bytes") +
                               ")");
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
      if (s.ok() && collect_units_) {
        int64_t t = 0;
        memcpy(&t, record_.data() + 6, 8);  // log_time; the record has it (Message() checked)
        units_.push_back({pos, len, t, t, false, false, 1});
      }
    } else if (op == kSchema || op == kChannel || op == kMessage) {
      s = ReadContent(content, len, &record_);
      if (s.ok()) s = Inner(op, record_.data(), record_.size(), At(OpName(op), pos));
    }  // Other records (attachments, indexes, metadata, private ones) are skipped unread.
    if (!s.ok() && footer_at == 0 && !cancelled_ && OnlyZerosFrom(content + len)) {
      // An unfinished file whose last record is damaged (a chunk written in
      // part, then zero-padded): a torn tail too. Damage followed by more
      // data is refused as it is in a complete file.
      std::string why = s.message();
      if (why.rfind(src_->name() + ": ", 0) == 0) why = why.substr(src_->name().size() + 2);
      return TornTail(pos, "without a Footer, its last record (" + std::string(OpName(op)) +
                               " at byte " + std::to_string(pos) + ") damaged: " + why);
    }
    if (!s.ok()) return s;
    pos = content + len;
    s = Progress(pos);
    if (!s.ok()) return s;
  }
}

bool Reader::ChunksInLogTimeOrder() {
  const uint64_t size = src_->size();
  int64_t latest_end = std::numeric_limits<int64_t>::min();
  for (uint64_t pos = sizeof(kMagic); size - pos >= kPrefix;) {
    uint8_t prefix[kPrefix];
    if (!src_->ReadAt(pos, kPrefix, prefix).ok()) return true;
    uint64_t len;
    memcpy(&len, prefix + 1, 8);
    const uint8_t op = prefix[0];
    if (op == 0 || op == kFooter || op == kDataEnd || len > size - pos - kPrefix) return true;
    // Messages outside chunks: an unchunked file, read in file order (and
    // each record's prefix read here would double its reads).
    if (op == kMessage) return true;
    if (op == kChunk && len >= 24) {
      uint64_t times[3];  // message_start_time, message_end_time, uncompressed_size
      if (!src_->ReadAt(pos + kPrefix, sizeof(times), reinterpret_cast<uint8_t*>(times)).ok()) {
        return true;
      }
      const int64_t start = static_cast<int64_t>(times[0]), end = static_cast<int64_t>(times[1]);
      if (times[2] != 0) {  // an empty chunk's times are 0
        if (start < latest_end) return false;
        latest_end = std::max(latest_end, end);
      }
    }
    pos += kPrefix + len;
  }
  return true;
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
  if (reading_ && wanted && c.kind != RosMessageKind::kOther && c.encoding != "cdr") {
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
  if (counting_) {
    if (c.count == 0 || t < c.first_ns) c.first_ns = t;
    if (c.count == 0 || t > c.last_ns) c.last_ns = t;
    ++c.count;
    if (messages_ == 0 || t < start_ns_) start_ns_ = t;
    if (messages_ == 0 || t > end_ns_) end_ns_ = t;
    if (messages_ > 0 && t < previous_log_ns_) ++backwards_;
    previous_log_ns_ = t;
    ++messages_;
  }
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
    cancelled_ = true;
    return Error("cancelled");
  }
  return Status::Ok();
}

Status Reader::Chunk(uint64_t pos, uint64_t len) {
  Status s = LoadChunk(pos, len);
  if (!s.ok()) return s;
  std::vector<Pending> pending;
  s = ChunkRecords(pos, &pending);
  // Messages before a damaged record are handed on before the error.
  size_t delivered = 0;
  Status d;
  for (; delivered < pending.size() && d.ok(); ++delivered) {
    d = Deliver(pending[delivered]);
    if (!d.ok()) break;
  }
  if (collect_units_ && delivered > 0) {
    // The first of two passes: counted and checked now, delivered later.
    // Recorded only with what this pass accepted: when the chunk's records
    // fail after some messages and the file ends there in zeros, Walk calls
    // it a torn tail and returns Ok, so the second pass must hand on the
    // same messages and stop there quietly, not fail on the same damage.
    // The span is the messages' own log times (pending is sorted), not the
    // chunk header's, which only the writer vouches for.
    const bool torn = !s.ok() || !d.ok();
    units_.push_back(
        {pos, len, pending.front().log_ns, pending[delivered - 1].log_ns, true, torn, delivered});
  }
  return d.ok() ? s : d;
}

Status Reader::Deliver(const Pending& m) {
  Fields f(m.p, m.n, "");
  return Message(&f,
                 At("chunk", m.chunk_pos) + ": Message record at offset " + std::to_string(m.at));
}

Status Reader::LoadChunk(uint64_t pos, uint64_t len) {
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
  return Status::Ok();
}

Status Reader::ChunkRecords(uint64_t pos, std::vector<Pending>* pending) {
  const std::string where = At("chunk", pos);
  // The records inside: Schema, Channel, Message (others skipped).
  const uint8_t* p = chunk_.data();
  const size_t n = chunk_.size();
  bool in_order = true;
  Status s;
  for (size_t at = 0; at < n;) {
    if (n - at < kPrefix) {
      s = Error(where + ": record at offset " + std::to_string(at) + " of its " +
                std::to_string(n) + " uncompressed bytes is cut after " + std::to_string(n - at) +
                " bytes");
      break;
    }
    uint64_t inner_len;
    memcpy(&inner_len, p + at + 1, 8);
    if (inner_len > n - at - kPrefix) {
      s = Error(where + ": " + OpName(p[at]) + " record at offset " + std::to_string(at) +
                " needs " + std::to_string(kPrefix + inner_len) + " bytes, " +
                std::to_string(n - at) + " are left in the chunk");
      break;
    }
    if (p[at] == kMessage) {
      // Read in log time order (writers may put a chunk's messages out of it).
      int64_t log_ns = 0;
      if (inner_len >= 14) memcpy(&log_ns, p + at + kPrefix + 6, 8);
      if (!pending->empty() && log_ns < pending->back().log_ns) in_order = false;
      pending->push_back({log_ns, p + at + kPrefix, static_cast<size_t>(inner_len), at, pos});
    } else {
      s = Inner(p[at], p + at + kPrefix, inner_len,
                where + ": " + OpName(p[at]) + " record at offset " + std::to_string(at));
      if (!s.ok()) break;
    }
    at += kPrefix + inner_len;
  }
  if (!in_order) {
    std::stable_sort(pending->begin(), pending->end(),
                     [](const Pending& a, const Pending& b) { return a.log_ns < b.log_ns; });
  }
  return s;
}

Status Reader::DeliverInLogTimeOrder() {
  // A k-way merge: units in order of their first log time, their messages
  // queued by (log time, unit, place in the unit). Before a unit is loaded,
  // every queued message earlier than its first is handed on (no later unit
  // has one as early), and a chunk's buffer is freed with its last message.
  // Memory is then the chunks that overlap the current instant, however
  // long a chain of slightly overlapping chunks is, and progress and cancel
  // are checked per chunk. The order is that of a stable sort of all the
  // messages by log time over the units sorted by start (file order on ties).
  std::stable_sort(units_.begin(), units_.end(),
                   [](const Unit& a, const Unit& b) { return a.start < b.start; });
  struct Queued {
    Pending m;
    size_t unit, seq;
  };
  const auto later = [](const Queued& a, const Queued& b) {
    if (a.m.log_ns != b.m.log_ns) return a.m.log_ns > b.m.log_ns;
    return a.unit != b.unit ? a.unit > b.unit : a.seq > b.seq;
  };
  std::priority_queue<Queued, std::vector<Queued>, decltype(later)> queue(later);
  std::vector<std::vector<uint8_t>> buffers(units_.size());  // never resized: pointers stay valid
  std::vector<size_t> left(units_.size(), 0);                // queued messages per unit
  uint64_t held = 0;
  // Hands on the queued messages before `until` (all of them if `all`).
  const auto flush = [&](int64_t until, bool all) {
    while (!queue.empty() && (all || queue.top().m.log_ns < until)) {
      const Queued q = queue.top();
      queue.pop();
      const Status s = Deliver(q.m);
      if (!s.ok()) return s;
      if (--left[q.unit] == 0) {
        std::vector<uint8_t>().swap(buffers[q.unit]);
        --held;
      }
    }
    return Status::Ok();
  };
  const uint64_t size = src_->size();
  uint64_t bytes = 0;
  for (size_t k = 0; k < units_.size(); ++k) {
    const Unit& u = units_[k];
    Status s = flush(u.start, false);
    if (!s.ok()) return s;
    if (opt_ != nullptr && opt_->progress &&
        !opt_->progress(0.5 + 0.5 * std::min(1.0, static_cast<double>(bytes) / size))) {
      cancelled_ = true;
      return Error("cancelled");
    }
    std::vector<Pending> pending;
    if (u.chunk) {
      s = LoadChunk(u.pos, u.len);
      if (s.ok()) {
        s = ChunkRecords(u.pos, &pending);
        // The first pass read this far and no further (a torn tail).
        if (u.torn) s = Status::Ok();
      }
      buffers[k].swap(chunk_);  // the pending messages' pointers move with the storage
    } else {
      s = ReadContent(u.pos + kPrefix, u.len, &buffers[k]);
      if (s.ok()) pending.push_back({u.start, buffers[k].data(), buffers[k].size(), 0, u.pos});
    }
    if (!s.ok()) return s;
    bytes += u.len;
    if (pending.size() > u.messages) pending.resize(u.messages);
    if (pending.empty()) {
      std::vector<uint8_t>().swap(buffers[k]);
      continue;
    }
    left[k] = pending.size();
    report_->peak_chunks_held = std::max(report_->peak_chunks_held, ++held);
    for (size_t i = 0; i < pending.size(); ++i) queue.push({pending[i], k, i});
    report_->peak_messages_held =
        std::max(report_->peak_messages_held, static_cast<uint64_t>(queue.size()));
  }
  return flush(0, true);
}

Status Reader::Decompress(const std::string& compression, const std::vector<uint8_t>& in,
                          uint64_t total, const std::string& where) {
  std::string why = decompressors_.Run(compression, in.data(), in.size(), total, &chunk_);
  if (!why.empty()) return Error(where + ": " + compression + ": " + why);
  return Status::Ok();
}

}  // namespace mcap_internal

namespace {
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
  if (reader.backwards() > 0 && !reader.reordered()) {
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
