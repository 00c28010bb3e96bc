// libFuzzer target for the session loader. The first input byte selects:
//   even: the rest is frames.bin content -> LoadFramesFromMemory (both the
//         refusing and the skipping mode); loaded records are written back
//         in the documented format and must load again identically;
//   odd:  the rest is meta.json text -> ParseJson + SessionMetaFromJson; an
//         accepted document must survive ToJson -> FromJson unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/common/crc32c.h"
#include "core/common/json_reader.h"
#include "core/session/session.h"

namespace {

using namespace sweepscan;

void Check(bool ok) {
  if (!ok) std::abort();
}

void Put(uint64_t v, int bytes, std::vector<uint8_t>* out) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}

std::vector<uint8_t> Serialize(const std::vector<SessionRecord>& records) {
  std::vector<uint8_t> f(kSessionFramesMagic, kSessionFramesMagic + 8);
  Put(kSessionFormatVersion, 4, &f);
  Put(0, 4, &f);
  for (const SessionRecord& r : records) {
    const size_t start = f.size();
    Put(r.bytes.size(), 4, &f);
    Put(static_cast<uint64_t>(r.receive_time_ns), 8, &f);
    f.insert(f.end(), r.bytes.begin(), r.bytes.end());
    Put(Crc32c(f.data() + start, 12 + r.bytes.size()), 4, &f);
  }
  return f;
}

void FuzzFrames(const uint8_t* data, size_t size) {
  for (bool skip : {false, true}) {
    FramesLoadOptions options;
    options.skip_corrupt_records = skip;
    std::vector<SessionRecord> records;
    FramesLoadReport report;
    const Status s = LoadFramesFromMemory(data, size, "fuzz", options, &records, &report);
    if (!s.ok()) {
      Check(!s.message().empty());
      continue;
    }
    Check(report.records == records.size());
    Check(report.valid_bytes <= size);
    Check(report.valid_bytes + report.tail_bytes_dropped == size);
    uint64_t bytes = 0;
    for (const SessionRecord& r : records) bytes += r.bytes.size();
    Check(bytes == report.record_bytes);
    Check(bytes + records.size() * kSessionRecordOverhead + kSessionFramesHeaderSize <= size);
    const std::vector<uint8_t> again = Serialize(records);
    std::vector<SessionRecord> records2;
    FramesLoadReport report2;
    Check(LoadFramesFromMemory(again.data(), again.size(), "again", FramesLoadOptions(), &records2,
                               &report2)
              .ok());
    Check(!report2.truncated_tail && records2.size() == records.size());
    for (size_t i = 0; i < records.size(); ++i) {
      Check(records2[i].bytes == records[i].bytes);
      Check(records2[i].receive_time_ns == records[i].receive_time_ns);
    }
    // Without skipping and without a torn tail, the input was exactly this
    // file, apart from the reserved header bytes 12..15 (ignored by readers).
    if (!skip && !report.truncated_tail) {
      Check(again.size() == size && std::memcmp(again.data(), data, 12) == 0 &&
            std::memcmp(again.data() + 16, data + 16, size - 16) == 0);
    }
  }
}

void FuzzMeta(const uint8_t* data, size_t size) {
  nlohmann::json j;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (!ParseJson(text, "meta.json", &j).ok()) return;
  SessionMeta meta;
  if (!SessionMetaFromJson(j, "meta.json", &meta).ok()) return;
  SessionMeta again;
  Check(SessionMetaFromJson(SessionMetaToJson(meta), "again", &again).ok());
  Check(SessionMetaToJson(again) == SessionMetaToJson(meta));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (data[0] % 2 == 0) {
    FuzzFrames(data + 1, size - 1);
  } else {
    FuzzMeta(data + 1, size - 1);
  }
  return 0;
}
