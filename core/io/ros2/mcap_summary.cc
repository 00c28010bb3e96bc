// The MCAP reader's summary: from the summary section (Footer, Statistics,
// Schemas, Channels, Chunk Indexes) when it can be used, and the summary
// filled from what a pass read (docs/ros-bags.md, "Summary").
#include <algorithm>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "core/io/ros2/mcap.h"
#include "core/io/ros2/mcap_reader.h"

namespace sweepscan::io::mcap_internal {

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
    report_->damaged = true;
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
      report_->damaged = true;
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
      report_->damaged = true;
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
    // Writers need not repeat the channels in the summary section (the
    // @mcap/core and mcap CLI option repeatChannels false): nothing is
    // wrong, the file is scanned for them.
    if (it == channels_.end()) return Status::Ok();
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

}  // namespace sweepscan::io::mcap_internal
