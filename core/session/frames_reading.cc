// Reading frames.bin's records from memory (docs/session-format.md,
// "Reading rules"): torn tails, damage skipped and described, the load
// report. frames_file.cc maps the file and calls these.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>

#include "core/common/crc32c.h"
#include "core/session/frames_bytes.h"
#include "core/session/session.h"

namespace sweepscan {

using session_internal::GetI64;
using session_internal::GetU32;
using session_internal::RecordAt;

// ---------------------------------------------------------------------------
// frames.bin reading

double FramesDamage::SecondsLost() const {
  if (to_end_of_file) return estimated_seconds_lost;
  if (!has_before || !has_after || time_after_ns < time_before_ns) return 0.0;
  return static_cast<double>(time_after_ns - time_before_ns) * 1e-9;
}

uint64_t FramesLoadReport::damaged_bytes() const {
  uint64_t n = 0;
  for (const FramesDamage& d : damage) n += d.bytes;
  return n;
}

double FramesLoadReport::seconds_lost() const {
  double s = 0.0;
  for (const FramesDamage& d : damage) s += d.SecondsLost();
  return s;
}

std::string FramesLoadReport::DamageSummary() const {
  if (damage.empty()) return std::string();
  char buf[160];
  std::ostringstream s;
  std::snprintf(buf, sizeof(buf),
                "%llu damaged record%s skipped (%llu bytes; about %.2f s of data lost): ",
                static_cast<unsigned long long>(corrupt_records_skipped),
                corrupt_records_skipped == 1 ? "" : "s",
                static_cast<unsigned long long>(damaged_bytes()), seconds_lost());
  s << buf;
  const size_t shown = std::min<size_t>(damage.size(), 5);
  for (size_t i = 0; i < shown; ++i) {
    const FramesDamage& d = damage[i];
    if (i > 0) s << ", ";
    s << RecordAt(d.first_record, d.offset) << " (" << d.reason;
    if (d.to_end_of_file) s << ", to the end of the file";
    if (d.records > 1) s << ", " << (d.to_end_of_file ? "about " : "") << d.records << " records";
    if (d.has_before) {
      std::snprintf(buf, sizeof(buf), ", %.2f s at %.1f s into the recording", d.SecondsLost(),
                    static_cast<double>(d.time_before_ns - first_time_ns) * 1e-9);
      s << buf;
    } else {
      s << ", at the start of the recording";
    }
    s << ")";
  }
  if (damage.size() > shown) s << " and " << damage.size() - shown << " more places";
  return s.str();
}

std::string FramesLoadReport::ToString() const {
  std::ostringstream s;
  s << "format " << format_version << ", " << records << " records, " << record_bytes
    << " frame bytes, file " << file_bytes << " bytes";
  if (truncated_tail)
    s << "; torn tail dropped (" << tail_bytes_dropped << " bytes: " << tail_reason << ")";
  if (corrupt_records_skipped > 0) s << "; " << DamageSummary();
  return s.str();
}

namespace {

constexpr size_t kRecordHeader = 12;  // u32 length + i64 receive time.

// The receive times a record after damage may have: from a day before the
// last intact record's to 30 days after it (a recording lasts hours; clock
// steps are seconds), or any before the first intact record. Checked before
// the CRC, it turns away almost every false start of a byte-by-byte search
// for the price of a comparison: without it, bytes that keep every length
// plausible made the search compute a 1 MiB CRC at each offset, about 30 s
// a megabyte, with no way to cancel.
struct TimeWindow {
  int64_t lo = std::numeric_limits<int64_t>::min();
  int64_t hi = std::numeric_limits<int64_t>::max();
};
TimeWindow AfterRecordAt(int64_t t) {
  constexpr int64_t kDayNs = int64_t{86400} * 1000000000;
  TimeWindow w;
  if (__builtin_sub_overflow(t, kDayNs, &w.lo)) w.lo = std::numeric_limits<int64_t>::min();
  if (__builtin_add_overflow(t, 30 * kDayNs, &w.hi)) w.hi = std::numeric_limits<int64_t>::max();
  return w;
}

// True when an intact record starts at `pos`: plausible length, fits, time
// within `w`, CRC good. *crc_bytes counts the bytes the CRC went over.
bool IntactRecordAt(const uint8_t* data, size_t n, size_t pos, const TimeWindow& w,
                    uint64_t* crc_bytes = nullptr) {
  if (n - pos < kSessionRecordOverhead) return false;
  const uint32_t length = GetU32(data + pos);
  if (length > kSessionMaxRecordBytes || n - pos < kSessionRecordOverhead + length) return false;
  const int64_t t = GetI64(data + pos + 4);
  if (t < w.lo || t > w.hi) return false;
  if (crc_bytes != nullptr) *crc_bytes += kRecordHeader + length;
  return Crc32c(data + pos, kRecordHeader + length) == GetU32(data + pos + kRecordHeader + length);
}

// The next position after `pos`, before `limit`, where an intact record
// starts; `limit` if none. A search stops after 256 MiB of CRC work (bytes
// crafted so that every offset looks like a record of 1 MiB, before the
// first intact record, where no time window applies); real damage costs a
// few candidates, and what the search gives up on is reported as damaged.
size_t NextIntactRecord(const uint8_t* data, size_t n, size_t pos, size_t limit,
                        const TimeWindow& w) {
  constexpr uint64_t kCrcBudget = uint64_t{256} << 20;
  uint64_t crc_bytes = 0;
  for (size_t q = pos + 1; q < limit && q + kSessionRecordOverhead <= n; ++q) {
    if (IntactRecordAt(data, n, q, w, &crc_bytes)) return q;
    if (crc_bytes > kCrcBudget) break;
  }
  return limit;
}

// How many records the damaged bytes [pos, end) held, from their length
// fields while those are usable (at least 1).
uint64_t RecordsIn(const uint8_t* data, size_t pos, size_t end) {
  uint64_t count = 0;
  while (pos < end) {
    ++count;
    if (end - pos < kSessionRecordOverhead) break;
    const uint32_t length = GetU32(data + pos);
    if (length > kSessionMaxRecordBytes || end - pos < kSessionRecordOverhead + length) break;
    pos += kSessionRecordOverhead + length;
  }
  return std::max<uint64_t>(count, 1);
}

// True if data[from, n) is all zeros.
bool ZerosFrom(const uint8_t* data, size_t from, size_t n) {
  for (size_t i = from; i < n; ++i) {
    if (data[i] != 0) return false;
  }
  return true;
}

// Damage to the end of the file has no intact record after it to date it,
// and its length fields stop being usable within a record or two (it said
// "2 records, 0.00 s lost" for 1 578 records and 5.26 s). Its size in
// records and seconds is estimated from the intact records' mean size and
// data rate.
void EstimateDamageToTheEnd(FramesLoadReport* rep) {
  const uint64_t intact_bytes = rep->record_bytes + rep->records * kSessionRecordOverhead;
  const double span_s = static_cast<double>(rep->last_time_ns - rep->first_time_ns) * 1e-9;
  for (FramesDamage& d : rep->damage) {
    if (!d.to_end_of_file || rep->records < 2 || intact_bytes == 0) continue;
    const double mean_bytes = static_cast<double>(intact_bytes) / static_cast<double>(rep->records);
    const auto estimate =
        static_cast<uint64_t>(std::llround(static_cast<double>(d.bytes) / mean_bytes));
    if (estimate > d.records) {
      rep->corrupt_records_skipped += estimate - d.records;
      d.records = estimate;
    }
    if (span_s > 0.0) {
      d.estimated_seconds_lost =
          static_cast<double>(d.bytes) * span_s / static_cast<double>(intact_bytes);
    }
  }
}

}  // namespace

Status VisitFramesInMemory(const uint8_t* data, size_t n, const std::string& source,
                           const FramesLoadOptions& options, const FrameVisitor& visit,
                           FramesLoadReport* report) {
  FramesLoadReport rep;
  rep.file_bytes = n;
  if (n > 0 && data == nullptr) return Status::Error(source + ": no data");
  if (n < kSessionFramesHeaderSize) {
    // A session whose header never reached the disk is indistinguishable
    // from a foreign file; refuse rather than guess.
    return Status::Error(source + ": " + std::to_string(n) +
                         " bytes, too short for the 16-byte sweepscan frames header");
  }
  if (std::memcmp(data, kSessionFramesMagic, sizeof(kSessionFramesMagic)) != 0) {
    return Status::Error(source + ": not a sweepscan frames file (wrong magic bytes)");
  }
  rep.format_version = GetU32(data + 8);
  if (rep.format_version != kSessionFormatVersion) {
    return Status::Error(source + ": unsupported frames format version " +
                         std::to_string(rep.format_version) + " (this program reads " +
                         std::to_string(kSessionFormatVersion) + ")");
  }
  size_t pos = kSessionFramesHeaderSize;
  uint64_t index = 0;
  bool have_good = false;
  int64_t last_good_time = 0;
  // Skips damage starting at `pos` up to the next intact record (or the
  // end): the first intact record after `pos`, searched byte by byte. The
  // record's own length, when it leads to an intact record, bounds the
  // search (a flipped byte in the payload or CRC: nothing intact inside),
  // but is not trusted alone: a damaged length can also land on an intact
  // record further on, and the records between were intact too.
  auto window = [&] { return have_good ? AfterRecordAt(last_good_time) : TimeWindow(); };
  // The first intact record after `pos`, before `limit` (else `limit`):
  // within the time window, and failing that at any time, still CRC-checked
  // and within the search's budget. A wall-clock step at the damage (NTP
  // stepping a recorder that has no real-time clock) put every record after
  // it outside the window: one bad byte there lost the rest of the session.
  // Only a search to the end of the file falls back: one bounded by an
  // intact record (the damaged one's length led to it) has found its next
  // record, and searching its extent again without the window's cheap
  // filter cost up to another 256 MiB of CRC work per damaged record.
  auto next_intact = [&](size_t limit) {
    const size_t q = NextIntactRecord(data, n, pos, limit, window());
    if (q < limit || !have_good || limit != n) return q;
    return NextIntactRecord(data, n, pos, limit, TimeWindow());
  };
  auto skip_damage = [&](const std::string& why) {
    size_t next = n;
    const uint32_t length = GetU32(data + pos);
    const size_t by_length = pos + kSessionRecordOverhead + length;
    if (length <= kSessionMaxRecordBytes && by_length <= n &&
        (by_length == n || IntactRecordAt(data, n, by_length, window()))) {
      next = next_intact(by_length);
    } else {
      next = next_intact(n);
    }
    FramesDamage d;
    d.first_record = index;
    d.offset = pos;
    d.bytes = next - pos;
    d.records = RecordsIn(data, pos, next);
    d.reason = why;
    d.has_before = have_good;
    d.time_before_ns = last_good_time;
    if (next < n) {
      d.has_after = true;
      d.time_after_ns = GetI64(data + next + 4);
    } else {
      d.to_end_of_file = true;
    }
    rep.corrupt_records_skipped += d.records;
    index += d.records;
    rep.damage.push_back(std::move(d));
    pos = next;
  };
  while (pos < n) {
    const size_t left = n - pos;
    auto torn = [&](const std::string& why) {
      rep.truncated_tail = true;
      rep.tail_bytes_dropped = left;
      rep.tail_reason = RecordAt(index, pos) + ": " + why;
    };
    if (left < 4 + 8) {
      torn("only " + std::to_string(left) + " bytes left, a record header needs 12");
      break;
    }
    const uint32_t length = GetU32(data + pos);
    if (length > kSessionMaxRecordBytes) {
      const std::string why = "absurd length " + std::to_string(length) + " (limit " +
                              std::to_string(kSessionMaxRecordBytes) + ")";
      if (!options.skip_corrupt_records) {
        return Status::Error(source + ": " + RecordAt(index, pos) + ": " + why);
      }
      skip_damage(why);
      continue;
    }
    const size_t total = kSessionRecordOverhead + length;
    if (left < total) {
      // Either a torn tail or a damaged length field in the middle: with
      // skipping on, an intact record further on tells them apart.
      const size_t intact = next_intact(n);
      if (intact < n) {
        // Intact records after it: a damaged length, not a crash's tail.
        const std::string why = "length " + std::to_string(length) +
                                " runs past the end of the file, but an intact record follows at "
                                "byte " +
                                std::to_string(intact);
        if (!options.skip_corrupt_records) {
          return Status::Error(source + ": " + RecordAt(index, pos) + ": " + why);
        }
        skip_damage(why);
        continue;
      }
      torn("needs " + std::to_string(total) + " bytes, " + std::to_string(left) + " left");
      break;
    }
    const uint32_t crc = Crc32c(data + pos, 12 + length);
    if (crc != GetU32(data + pos + 12 + length)) {
      // A torn last record (below) never holds an intact record: one inside
      // its extent means its length is damaged and reaches the end of the
      // file (or the zeros) by chance, and the records it spans are intact.
      // Taken for a tail, they were dropped, in strict mode too, and cut by
      // a writer that reopened the session.
      const size_t intact =
          left == total || ZerosFrom(data, pos + total, n) ? next_intact(pos + total) : pos + total;
      if (intact < pos + total) {
        const std::string why = "CRC mismatch, and its length " + std::to_string(length) +
                                " spans an intact record at byte " + std::to_string(intact);
        if (!options.skip_corrupt_records) {
          return Status::Error(source + ": " + RecordAt(index, pos) + ": " + why);
        }
        skip_damage(why);
        continue;
      }
      if (left == total) {
        // The final record of the file: a write torn by a crash (its last
        // page never reached the disk) looks exactly like this.
        torn("CRC mismatch in the final record");
        break;
      }
      // After a power loss the file's size can have reached the disk ahead
      // of its last blocks' data (delayed allocation), which then read as
      // zeros: the records end in a run of zeros to the end of the file. No
      // record is zeros (its CRC covers a length and a time: never 0), so
      // this is a torn tail too, not damage.
      if (ZerosFrom(data, pos + total, n)) {
        torn("CRC mismatch in the last record, then " + std::to_string(n - pos - total) +
             " zero bytes to the end of the file (a power loss's unwritten blocks)");
        break;
      }
      if (!options.skip_corrupt_records) {
        return Status::Error(source + ": " + RecordAt(index, pos) + ": CRC mismatch");
      }
      skip_damage("CRC mismatch");
      continue;
    }
    SessionRecordView r;
    r.ordinal = rep.records;
    r.receive_time_ns = GetI64(data + pos + 4);
    r.bytes = data + pos + 12;
    r.size = length;
    r.offset = pos;
    r.file_bytes = n;
    rep.record_bytes += length;
    if (!have_good) rep.first_time_ns = r.receive_time_ns;
    rep.last_time_ns = r.receive_time_ns;
    have_good = true;
    last_good_time = r.receive_time_ns;
    ++rep.records;
    if (!visit(r)) return Status::Error(source + ": cancelled");
    pos += total;
    ++index;
  }
  rep.valid_bytes = rep.truncated_tail ? n - rep.tail_bytes_dropped : n;
  EstimateDamageToTheEnd(&rep);
  if (report != nullptr) *report = rep;
  return Status::Ok();
}

namespace {
// The loaders' visitor: a copy of each record.
FrameVisitor CollectRecords(std::vector<SessionRecord>* records) {
  return [records](const SessionRecordView& v) {
    SessionRecord r;
    r.receive_time_ns = v.receive_time_ns;
    r.bytes.assign(v.bytes, v.bytes + v.size);
    records->push_back(std::move(r));
    return true;
  };
}
}  // namespace

Status LoadFramesFromMemory(const uint8_t* data, size_t n, const std::string& source,
                            const FramesLoadOptions& options, std::vector<SessionRecord>* records,
                            FramesLoadReport* report) {
  records->clear();
  return VisitFramesInMemory(data, n, source, options, CollectRecords(records), report);
}

Status LoadFramesFile(const std::string& path, const FramesLoadOptions& options,
                      std::vector<SessionRecord>* records, FramesLoadReport* report) {
  records->clear();
  return VisitFramesFile(path, options, CollectRecords(records), report);
}

}  // namespace sweepscan
