#include "core/session/session.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/common/checked_file.h"
#include "core/common/crc32c.h"
#include "core/common/json_reader.h"

namespace sweepscan {
namespace {

using json = nlohmann::json;

void PutU32(uint32_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void PutI64(int64_t v, std::vector<uint8_t>* out) {
  const uint64_t u = static_cast<uint64_t>(v);
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<uint8_t>(u >> (8 * i)));
}
uint32_t GetU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}
int64_t GetI64(const uint8_t* p) {
  return static_cast<int64_t>(static_cast<uint64_t>(GetU32(p)) |
                              static_cast<uint64_t>(GetU32(p + 4)) << 32);
}

std::string Join(const std::string& dir, const char* file) {
  return dir.empty() || dir.back() == '/' ? dir + file : dir + "/" + file;
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

// mkdir -p.
Status MakeDirs(const std::string& dir) {
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part;
    if (::mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) {
      return Status::Error(Errno(partial + ": cannot create folder"));
    }
    partial += "/";
  }
  return Status::Ok();
}

// fsync of the folder makes new directory entries (frames.bin, the renamed
// meta.json) durable, not only the files' contents.
void SyncDir(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

bool WriteAll(int fd, const uint8_t* p, size_t n) {
  while (n > 0) {
    const ssize_t k = ::write(fd, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<size_t>(k);
  }
  return true;
}

std::string RecordAt(uint64_t index, uint64_t offset) {
  return "record " + std::to_string(index) + " at byte " + std::to_string(offset);
}

}  // namespace

std::string UtcNowIso8601() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// ---------------------------------------------------------------------------
// meta.json

Pose2d SessionStartPose(const SessionMeta& meta) {
  Pose2d start;
  const json& s = meta.settings;
  if (!s.is_object()) return start;
  const json* found = nullptr;
  if (s.contains("scenario")) {
    const json& sc = s["scenario"];
    if (sc.is_object() && sc.contains("path") && sc["path"].is_object() &&
        sc["path"].contains("start") && sc["path"]["start"].is_object()) {
      found = &sc["path"]["start"];
    }
  } else if (s.contains("import") && s["import"].is_object() && s["import"].contains("start") &&
             s["import"]["start"].is_object()) {
    found = &s["import"]["start"];  // an imported bag: its odometry frame
  }
  if (found == nullptr) return start;
  const json& st = *found;
  const auto number = [&](const char* key, double* out) {
    if (st.contains(key) && st[key].is_number() && std::isfinite(st[key].get<double>())) {
      *out = st[key].get<double>();
    }
  };
  number("x_m", &start.x);
  number("y_m", &start.y);
  number("yaw_rad", &start.yaw);
  return start;
}

json SessionMetaToJson(const SessionMeta& m) {
  json j{
      {"format", "sweepscan-session"},
      {"format_version", m.format_version},
      {"created_utc", m.created_utc},
      {"robot",
       {{"lidar_height_m", m.geometry.lidar_height_m},
        {"lidar_offset_x_m", m.geometry.lidar_offset_x_m},
        {"imu_offset_x_m", m.geometry.imu_offset_x_m},
        {"wheel_distance_m", m.geometry.wheel_distance_m}}},
      {"lidar_angle_convention",
       {{"sign", m.lidar_angle_convention.sign},
        {"offset_rad", m.lidar_angle_convention.offset_rad}}},
      {"calibration",
       {{"alpha_rad", m.calibration.alpha},
        {"beta_rad", m.calibration.beta},
        {"gamma_rad", m.calibration.gamma}}},
      {"link", m.link},
      {"agent", m.agent},
      {"settings", m.settings.is_object() ? m.settings : json::object()},
      {"notes", m.notes},
  };
  // A mount other than sweepscan's own (an imported ROS bag's tf): written
  // only when set, so native sessions' meta.json is unchanged.
  if (!m.content.empty()) j["content"] = m.content;
  if (m.geometry.lidar_offset_y_m != 0.0) {
    j["robot"]["lidar_offset_y_m"] = m.geometry.lidar_offset_y_m;
  }
  if (m.geometry.HasNominalMountRotation()) {
    const Eigen::Quaterniond& q = m.geometry.lidar_mount;
    j["robot"]["lidar_mount"] = {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
  }
  return j;
}

Status SessionMetaFromJson(const json& j, const std::string& source, SessionMeta* meta) {
  SessionMeta m;
  try {
    const JsonObject root(j, "");
    root.AllowOnly({"format", "format_version", "created_utc", "robot", "lidar_angle_convention",
                    "calibration", "link", "agent", "settings", "notes", "content"});
    if (root.String("format") != "sweepscan-session") {
      root.Fail("format", "expected \"sweepscan-session\", got \"" + root.String("format") + "\"");
    }
    const int64_t version = root.Integer("format_version");
    if (version < 1 || version > kSessionFormatVersion) {
      root.Fail("format_version", "unsupported version " + std::to_string(version) +
                                      " (this program reads 1.." +
                                      std::to_string(kSessionFormatVersion) + ")");
    }
    m.format_version = static_cast<uint32_t>(version);
    m.created_utc = root.String("created_utc");
    m.content = root.String("content", "");
    if (!m.content.empty() && m.content != kSessionContentMeasurements) {
      root.Fail("content", "unknown content \"" + m.content + "\" (this program reads \"" +
                               kSessionContentMeasurements + "\" or none: link frames)");
    }
    const JsonObject r = root.Object("robot");
    r.AllowOnly({"lidar_height_m", "lidar_offset_x_m", "imu_offset_x_m", "wheel_distance_m",
                 "lidar_offset_y_m", "lidar_mount"});
    // sweepscan's robot has its lidar above the floor; an imported robot's
    // may sit at or below its base frame's origin.
    m.geometry.lidar_height_m = m.content.empty() ? r.Positive("lidar_height_m")
                                                  : r.Number("lidar_height_m");
    m.geometry.lidar_offset_x_m = r.Number("lidar_offset_x_m");
    m.geometry.imu_offset_x_m = r.Number("imu_offset_x_m");
    m.geometry.wheel_distance_m = r.Positive("wheel_distance_m");
    m.geometry.lidar_offset_y_m = r.Number("lidar_offset_y_m", 0.0);
    if (r.Has("lidar_mount")) {
      const JsonObject q = r.Object("lidar_mount");
      q.AllowOnly({"x", "y", "z", "w"});
      const Eigen::Quaterniond mount(q.Number("w"), q.Number("x"), q.Number("y"), q.Number("z"));
      if (std::abs(mount.norm() - 1.0) > 1e-6) {
        q.Fail("w", "not a unit quaternion (norm " + std::to_string(mount.norm()) + ")");
      }
      m.geometry.lidar_mount = mount;
    }
    const JsonObject a = root.Object("lidar_angle_convention");
    a.AllowOnly({"sign", "offset_rad"});
    const int64_t sign = a.Integer("sign");
    if (sign != 1 && sign != -1) a.Fail("sign", "must be 1 or -1, got " + std::to_string(sign));
    m.lidar_angle_convention.sign = static_cast<int>(sign);
    m.lidar_angle_convention.offset_rad = a.Number("offset_rad");
    const JsonObject c = root.Object("calibration");
    c.AllowOnly({"alpha_rad", "beta_rad", "gamma_rad"});
    // Mounting errors are small angles; anything beyond pi is a unit mistake (degrees).
    auto angle = [&c](const char* key) {
      c.Number(key);  // Required: reports "missing" / wrong type first.
      return c.InRange(key, -M_PI, M_PI, 0.0);
    };
    m.calibration.alpha = angle("alpha_rad");
    m.calibration.beta = angle("beta_rad");
    m.calibration.gamma = angle("gamma_rad");
    m.link = root.String("link", "");
    m.agent = root.String("agent", "");
    if (root.Has("settings")) {
      root.Object("settings");  // Must be an object; its content is not ours to check.
      m.settings = j.at("settings");
    }
    m.notes = root.String("notes", "");
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  *meta = std::move(m);
  return Status::Ok();
}

Status ReadSessionMeta(const std::string& path, SessionMeta* meta) {
  json j;
  const Status s = ReadJsonFile(path, &j);
  if (!s.ok()) return s;
  return SessionMetaFromJson(j, path, meta);
}

Status WriteSessionMeta(const std::string& path, const SessionMeta& meta) {
  return WriteFileAtomically(path, SessionMetaToJson(meta).dump(2) + "\n");
}

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
  std::snprintf(buf, sizeof(buf), "%llu damaged record%s skipped (%llu bytes; about %.2f s of data lost): ",
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
  auto next_intact = [&](size_t limit) {
    const size_t q = NextIntactRecord(data, n, pos, limit, window());
    if (q < limit || !have_good) return q;
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
  return VisitFramesInMemory(data, n, source, options,
                             CollectRecords(records),
                             report);
}

Status LoadFramesFile(const std::string& path, const FramesLoadOptions& options,
                      std::vector<SessionRecord>* records, FramesLoadReport* report) {
  records->clear();
  return VisitFramesFile(path, options,
                         CollectRecords(records),
                         report);
}

Status LoadSession(const std::string& dir, const FramesLoadOptions& options, Session* session) {
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    return Status::Error(dir + ": not a session folder (does not exist or is not a folder)");
  }
  Session s;
  s.dir = dir;
  Status status = ReadSessionMeta(Join(dir, kSessionMetaFile), &s.meta);
  if (!status.ok()) return status;
  status = LoadFramesFile(Join(dir, kSessionFramesFile), options, &s.records, &s.frames);
  if (!status.ok()) return status;
  *session = std::move(s);
  return Status::Ok();
}

// ---------------------------------------------------------------------------
// Writing

bool SessionWriterOptions::IsValid(std::string* error) const {
  if (flush_interval <= std::chrono::steady_clock::duration::zero()) {
    *error = "flush_interval must be > 0";
    return false;
  }
  if (max_buffered_bytes == 0) {
    *error = "max_buffered_bytes must be > 0";
    return false;
  }
  return true;
}

SessionWriter::SessionWriter(std::string dir, int fd, uint64_t file_bytes,
                             const SessionWriterOptions& options)
    : dir_(std::move(dir)),
      fd_(fd),
      options_(options),
      file_bytes_(file_bytes),
      last_sync_(std::chrono::steady_clock::now()) {}

SessionWriter::~SessionWriter() { Close(); }

Status SessionWriter::Create(const std::string& dir, const SessionMeta& meta,
                             const SessionWriterOptions& options,
                             std::unique_ptr<SessionWriter>* out) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(dir + ": " + error);
  if (!meta.geometry.IsValid(&error)) return Status::Error(dir + ": " + error);
  struct stat st;
  bool made_dir = false;
  if (::stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) return Status::Error(dir + ": exists and is not a folder");
    bool empty = true;
    if (DIR* d = ::opendir(dir.c_str())) {
      while (const dirent* e = ::readdir(d)) {
        if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) empty = false;
      }
      ::closedir(d);
    }
    if (!empty && !options.overwrite) {
      return Status::Error(dir +
                           ": folder exists and is not empty; refusing to overwrite a "
                           "session (ask for overwrite explicitly)");
    }
    if (!empty) {
      for (const char* f :
           {kSessionFramesFile, kSessionMetaFile, "picks.json", "calibration.json"}) {
        const std::string p = Join(dir, f);
        if (::unlink(p.c_str()) != 0 && errno != ENOENT) {
          return Status::Error(Errno(p + ": cannot remove old session file"));
        }
      }
    }
  } else {
    const Status s = MakeDirs(dir);
    if (!s.ok()) return s;
    made_dir = true;
  }
  const std::string frames = Join(dir, kSessionFramesFile);
  // A session that could not be begun (a full disk) leaves nothing behind:
  // its empty folder made the next `record` refuse it as an existing one.
  auto undo = [&](const Status& failed) {
    ::unlink(frames.c_str());
    ::unlink(Join(dir, kSessionMetaFile).c_str());
    if (made_dir) ::rmdir(dir.c_str());
    return failed;
  };
  SessionMeta m = meta;
  m.format_version = kSessionFormatVersion;
  if (m.created_utc.empty()) m.created_utc = UtcNowIso8601();
  Status s = WriteSessionMeta(Join(dir, kSessionMetaFile), m);
  if (!s.ok()) return undo(s);
  const int fd = ::open(frames.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return undo(Status::Error(Errno(frames + ": cannot create")));
  const std::vector<uint8_t> header = SessionFramesHeader();
  if (!WriteAll(fd, header.data(), header.size()) || ::fsync(fd) != 0) {
    const Status failed = Status::Error(Errno(frames + ": cannot write the file header"));
    ::close(fd);
    return undo(failed);
  }
  SyncDir(dir);
  out->reset(new SessionWriter(dir, fd, header.size(), options));
  (*out)->created_utc_ = m.created_utc;
  return Status::Ok();
}

Status SessionWriter::Open(const std::string& dir, const SessionWriterOptions& options,
                           std::unique_ptr<SessionWriter>* out, FramesLoadReport* report) {
  std::string error;
  if (!options.IsValid(&error)) return Status::Error(dir + ": " + error);
  Session session;
  Status s = LoadSession(dir, FramesLoadOptions(), &session);
  if (!s.ok()) return s;
  const std::string frames = Join(dir, kSessionFramesFile);
  const int fd = ::open(frames.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(Errno(frames + ": cannot open for appending"));
  // Cut a torn tail so new records follow the last good one.
  const off_t end = static_cast<off_t>(session.frames.valid_bytes);
  if (::ftruncate(fd, end) != 0 || ::lseek(fd, end, SEEK_SET) != end || ::fsync(fd) != 0) {
    ::close(fd);
    return Status::Error(Errno(frames + ": cannot cut the torn tail"));
  }
  if (report != nullptr) *report = session.frames;
  out->reset(new SessionWriter(dir, fd, session.frames.valid_bytes, options));
  (*out)->created_utc_ = session.meta.created_utc;
  return Status::Ok();
}

std::vector<uint8_t> SessionFramesHeader() {
  std::vector<uint8_t> h(kSessionFramesMagic, kSessionFramesMagic + 8);
  PutU32(kSessionFormatVersion, &h);
  PutU32(0, &h);  // reserved
  return h;
}

void AppendSessionRecord(const uint8_t* bytes, size_t n, int64_t receive_time_ns,
                         std::vector<uint8_t>* out) {
  const size_t start = out->size();
  PutU32(static_cast<uint32_t>(n), out);
  PutI64(receive_time_ns, out);
  if (n > 0) out->insert(out->end(), bytes, bytes + n);
  PutU32(Crc32c(out->data() + start, 12 + n), out);
}

Status SessionWriter::Append(const uint8_t* bytes, size_t n, int64_t receive_time_ns) {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Error(dir_ + ": session is closed");
  if (n > kSessionMaxRecordBytes || (n > 0 && bytes == nullptr)) {
    return Status::Error(dir_ + ": record of " + std::to_string(n) + " bytes refused (limit " +
                         std::to_string(kSessionMaxRecordBytes) + ")");
  }
  AppendSessionRecord(bytes, n, receive_time_ns, &buffer_);
  ++records_appended_;
  dirty_ = true;
  if (buffer_.size() >= options_.max_buffered_bytes) return WriteBuffer();
  return Status::Ok();
}

Status SessionWriter::WriteBuffer() {
  if (buffer_.empty()) return Status::Ok();
  if (!WriteAll(fd_, buffer_.data(), buffer_.size())) {
    failed_ = Errno(Join(dir_, kSessionFramesFile) + ": write failed");
    // The recording ends here (disk full, a pulled disk): what was written
    // since the last sync goes to the disk now, as a flush would have taken
    // it, instead of waiting in the page cache for a power cut (Flush and
    // Close return the error from here on, and synced nothing).
    ::fdatasync(fd_);
    return Status::Error(failed_);
  }
  file_bytes_ += buffer_.size();
  buffer_.clear();
  return Status::Ok();
}

Status SessionWriter::Flush() {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Ok();
  Status s = WriteBuffer();
  if (!s.ok()) return s;
  if (::fdatasync(fd_) != 0) {
    failed_ = Errno(Join(dir_, kSessionFramesFile) + ": fsync failed");
    return Status::Error(failed_);
  }
  dirty_ = false;
  last_sync_ = std::chrono::steady_clock::now();
  return Status::Ok();
}

Status SessionWriter::FlushIfDue(std::chrono::steady_clock::time_point now) {
  if (!dirty_) {
    last_sync_ = now;  // Nothing to lose: restart the interval.
    return failed_.empty() ? Status::Ok() : Status::Error(failed_);
  }
  if (now - last_sync_ < options_.flush_interval) return Status::Ok();
  return Flush();
}

Status SessionWriter::Close() {
  if (fd_ < 0) return failed_.empty() ? Status::Ok() : Status::Error(failed_);
  Status s = Flush();
  if (::close(fd_) != 0 && s.ok()) s = Status::Error(Errno(dir_ + ": close failed"));
  fd_ = -1;
  return s;
}

Status SessionWriter::UpdateMeta(const SessionMeta& meta) {
  SessionMeta m = meta;
  m.format_version = kSessionFormatVersion;
  // When the recording began stays what Create() wrote: a caller that
  // rewrites the meta it started from (a reconnection naming the agent) had
  // it empty, and the LAS export's GPS time needs it.
  if (m.created_utc.empty()) m.created_utc = created_utc_;
  const Status s = WriteSessionMeta(Join(dir_, kSessionMetaFile), m);
  if (s.ok()) SyncDir(dir_);
  return s;
}

}  // namespace sweepscan
