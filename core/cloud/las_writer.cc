// LAS 1.4 R15 writer. Section numbers (§) are the specification's; the
// layout written here is documented field by field in docs/las-format.md.
#include "core/cloud/las_writer.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>

namespace sweepscan {

// LAS is little-endian (§2); records are packed by memcpy of host values.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "LAS writer assumes a little-endian host");

const char kSweepscanSessionWkt[] =
    "LOCAL_CS[\"sweepscan session frame (a recording's: x forward and y left at the start pose; a "
    "simulation's: its scenario's world; an imported bag's: its odometry frame; z up; metres)\","
    "LOCAL_DATUM[\"sweepscan session world\",32767],UNIT[\"metre\",1],"
    "AXIS[\"X\",EAST],AXIS[\"Y\",NORTH]]";
const char kSweepscanProjectWkt[] =
    "LOCAL_CS[\"sweepscan project frame (x forward and y left at the anchor session's start pose, z up; "
    "metres)\",LOCAL_DATUM[\"sweepscan project anchor\",32767],UNIT[\"metre\",1],"
    "AXIS[\"X\",EAST],AXIS[\"Y\",NORTH]]";

namespace {

// Points buffered between writes: about 1 MiB.
constexpr size_t kBufferRecords = 25600;
// |record| stays below this so that rounding can never reach INT32_MAX.
constexpr double kMaxRecordMagnitude = 2147483000.0;

// Sequential little-endian appends for the header and the VLRs.
class Bytes {
 public:
  template <typename T>
  void Put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s_.append(b, sizeof(T));
  }
  // A fixed-size char[n] field: the text, then NULs (§2.3: not NUL-terminated when full).
  void PutText(const std::string& text, size_t n) {
    s_.append(text, 0, std::min(text.size(), n));
    s_.append(n - std::min(text.size(), n), '\0');
  }
  void PutZeros(size_t n) { s_.append(n, '\0'); }
  void Append(const std::string& raw) { s_ += raw; }
  const std::string& str() const { return s_; }

 private:
  std::string s_;
};

// §2.5: the 54-byte VLR header.
void PutVlrHeader(Bytes* b, const char* user_id, uint16_t record_id, size_t length,
                  const char* description) {
  b->Put<uint16_t>(0);  // Reserved, must be 0.
  b->PutText(user_id, 16);
  b->Put<uint16_t>(record_id);
  b->Put<uint16_t>(static_cast<uint16_t>(length));
  b->PutText(description, 32);
}

// §4.3: one 192-byte EXTRA_BYTES descriptor without no_data/min/max/scale/offset
// (options 0: those fields are zero and to be disregarded).
void PutExtraBytesDescriptor(Bytes* b, uint8_t data_type, const char* name, const char* description) {
  b->PutZeros(2);  // reserved
  b->Put<uint8_t>(data_type);
  b->Put<uint8_t>(0);  // options
  b->PutText(name, 32);
  b->PutZeros(4);                // unused
  b->PutZeros(8 + 16);           // no_data, deprecated1
  b->PutZeros(8 + 16);           // min, deprecated2
  b->PutZeros(8 + 16);           // max, deprecated3
  b->PutZeros(8 + 16);           // scale, deprecated4
  b->PutZeros(8 + 16);           // offset, deprecated5
  b->PutText(description, 32);
}

// The VLRs, in file order: the WKT coordinate system (§3.2), the extra bytes (§4.3).
std::string Vlrs(const std::string& wkt) {
  Bytes b;
  PutVlrHeader(&b, "LASF_Projection", 2112, wkt.size() + 1, "OGC Coordinate System WKT");
  b.Append(wkt);
  b.Put<char>('\0');  // §3.2: a null-terminated string.
  PutVlrHeader(&b, "LASF_Spec", 4, kLasExtraBytesFields * kLasExtraBytesDescriptorSize,
               "sweepscan point attributes");
  PutExtraBytesDescriptor(&b, 9, "range", "lidar range (m)");
  PutExtraBytesDescriptor(&b, 5, "scan", "lidar revolution index");
  PutExtraBytesDescriptor(&b, 3, "beam", "sample index within its scan");
  PutExtraBytesDescriptor(&b, 1, "flags", "bit 0: placed without deskew");
  return b.str();
}

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
int64_t DaysFromCivil(int64_t y, int m, int d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int64_t yoe = y - era * 400;
  const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

int64_t YearFromDays(int64_t z) {
  z += 719468;
  const int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const int64_t doe = z - era * 146097;
  const int64_t yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const int64_t mp = (5 * doy + 2) / 153;
  const int64_t m = mp < 10 ? mp + 3 : mp - 9;
  return yoe + era * 400 + (m <= 2);
}

// GPS - UTC (s) at a UTC instant: the 18 leap seconds since the GPS epoch,
// each effective from 00:00 UTC of the month given (IERS Bulletin C). None
// has been announced after 2017-01-01; a new one must be added here.
int LeapSecondsSinceGpsEpoch(int64_t unix_seconds) {
  static const int kEffective[][2] = {{1981, 7}, {1982, 7}, {1983, 7}, {1985, 7}, {1988, 1}, {1990, 1},
                                      {1991, 1}, {1992, 7}, {1993, 7}, {1994, 7}, {1996, 1}, {1997, 7},
                                      {1999, 1}, {2006, 1}, {2009, 1}, {2012, 7}, {2015, 7}, {2017, 1}};
  int leap = 0;
  for (const auto& e : kEffective) {
    if (unix_seconds >= DaysFromCivil(e[0], e[1], 1) * 86400) ++leap;
  }
  return leap;
}

bool Digits(const std::string& s, size_t at, size_t n, int* out) {
  if (at + n > s.size()) return false;
  int v = 0;
  for (size_t i = at; i < at + n; ++i) {
    if (s[i] < '0' || s[i] > '9') return false;
    v = v * 10 + (s[i] - '0');
  }
  *out = v;
  return true;
}

void TodayUtc(int* year, int* day_of_year) {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  *year = tm.tm_year + 1900;
  *day_of_year = tm.tm_yday + 1;
}

}  // namespace

void LasExtent::Add(const CloudPoint* p, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    const CloudPoint& c = p[i];
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) {
      ++non_finite;
      continue;
    }
    const double v[3] = {c.x, c.y, c.z};
    for (int k = 0; k < 3; ++k) {
      min[k] = points == 0 ? v[k] : std::min(min[k], v[k]);
      max[k] = points == 0 ? v[k] : std::max(max[k], v[k]);
    }
    min_time_ns = points == 0 ? c.time_ns : std::min(min_time_ns, c.time_ns);
    ++points;
  }
}

void LasExtent::Add(const LasExtent& o) {
  non_finite += o.non_finite;
  if (o.points == 0) return;
  for (int k = 0; k < 3; ++k) {
    min[k] = points == 0 ? o.min[k] : std::min(min[k], o.min[k]);
    max[k] = points == 0 ? o.max[k] : std::max(max[k], o.max[k]);
  }
  min_time_ns = points == 0 ? o.min_time_ns : std::min(min_time_ns, o.min_time_ns);
  points += o.points;
}

Status ChooseLasQuantisation(const LasExtent& e, LasQuantisation* q) {
  *q = LasQuantisation();
  if (e.empty()) return Status::Ok();
  double deviation = 0.0;  // Largest |coordinate - offset| (m).
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(e.min[k]) || !std::isfinite(e.max[k]) || e.min[k] > e.max[k]) {
      return Status::Error("the cloud's extent is not a finite box");
    }
    // §2.4 "X, Y, and Z Offsets": the centre rounded to a whole metre keeps
    // the records small and the offset readable.
    q->offset[k] = std::round(0.5 * (e.min[k] + e.max[k])) + 0.0;  // + 0.0: never -0
    deviation = std::max({deviation, std::abs(e.max[k] - q->offset[k]), std::abs(e.min[k] - q->offset[k])});
  }
  // One scale for the three axes: 0.1 mm (any room or building: up to
  // ~214 km from the offset), else 1 mm.
  for (const double scale : {0.0001, 0.001}) {
    if (deviation / scale <= kMaxRecordMagnitude) {
      q->scale = scale;
      return Status::Ok();
    }
  }
  char buf[160];
  std::snprintf(buf, sizeof(buf),
                "the cloud's extent is too large for LAS: a point lies %.0f m from the centre, "
                "int32 coordinates at 1 mm reach %.0f m",
                deviation, kMaxRecordMagnitude * 0.001);
  return Status::Error(buf);
}

Status AdjustedGpsTimeFromIso8601(const std::string& s, double* adjusted_gps_s, int* year,
                                  int* day_of_year) {
  const Status bad = Status::Error("'" + s + "' is not an ISO 8601 UTC time like 2026-11-22T10:15:00Z");
  int y, mo, d, h, mi, se;
  if (!Digits(s, 0, 4, &y) || s.size() < 19 || s[4] != '-' || !Digits(s, 5, 2, &mo) || s[7] != '-' ||
      !Digits(s, 8, 2, &d) || (s[10] != 'T' && s[10] != 't' && s[10] != ' ') || !Digits(s, 11, 2, &h) ||
      s[13] != ':' || !Digits(s, 14, 2, &mi) || s[16] != ':' || !Digits(s, 17, 2, &se)) {
    return bad;
  }
  static const int kMonthDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap_year = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  if (mo < 1 || mo > 12 || d < 1 || d > kMonthDays[mo - 1] + (mo == 2 && leap_year) || h > 23 || mi > 59 ||
      se > 59) {
    return bad;
  }
  size_t at = 19;
  double fraction = 0.0;
  if (at < s.size() && (s[at] == '.' || s[at] == ',')) {
    double unit = 0.1;
    for (++at; at < s.size() && s[at] >= '0' && s[at] <= '9'; ++at, unit *= 0.1) fraction += unit * (s[at] - '0');
  }
  int zone_minutes = 0;  // Local time = UTC + zone.
  if (at < s.size() && (s[at] == 'Z' || s[at] == 'z')) {
    ++at;
  } else if (at < s.size() && (s[at] == '+' || s[at] == '-')) {
    int zh, zm;
    const bool colon = at + 3 < s.size() && s[at + 3] == ':';
    if (!Digits(s, at + 1, 2, &zh) || !Digits(s, at + (colon ? 4 : 3), 2, &zm) || zh > 23 || zm > 59) return bad;
    zone_minutes = (s[at] == '-' ? -1 : 1) * (zh * 60 + zm);
    at += colon ? 6 : 5;
  } else {
    return Status::Error("'" + s + "' has no time zone (Z or +hh:mm): cannot tell UTC");
  }
  if (at != s.size()) return bad;
  const int64_t unix_seconds =
      DaysFromCivil(y, mo, d) * 86400 + h * 3600 + mi * 60 + se - int64_t{zone_minutes} * 60;
  if (unix_seconds < kUnixSecondsAtGpsEpoch) return Status::Error("'" + s + "' is before the GPS epoch (1980-01-06)");
  const int64_t gps_seconds = unix_seconds - kUnixSecondsAtGpsEpoch + LeapSecondsSinceGpsEpoch(unix_seconds);
  *adjusted_gps_s = static_cast<double>(gps_seconds) - kLasAdjustedGpsOffsetS + fraction;
  const int64_t days = unix_seconds / 86400;  // >= 0 after the epoch check.
  const int64_t utc_year = YearFromDays(days);
  *year = static_cast<int>(utc_year);
  *day_of_year = static_cast<int>(days - DaysFromCivil(utc_year, 1, 1) + 1);
  return Status::Ok();
}

Status SetLasTimeFromSession(const std::string& created_utc, const LasExtent& extent, LasWriterOptions* o) {
  double gps = 0.0;
  int year = 0, day = 0;
  const Status s = created_utc.empty() ? Status::Error("the session has no created_utc")
                                       : AdjustedGpsTimeFromIso8601(created_utc, &gps, &year, &day);
  if (s.ok()) {
    o->adjusted_gps_time = true;
    o->time_origin_ns = extent.empty() ? 0 : extent.min_time_ns;
    o->gps_time_at_origin_s = gps;
  } else {
    o->adjusted_gps_time = false;
    o->time_origin_ns = 0;
    o->gps_time_at_origin_s = 0.0;
    TodayUtc(&year, &day);
  }
  o->creation_year = static_cast<uint16_t>(year);
  o->creation_day_of_year = static_cast<uint16_t>(day);
  if (s.ok()) return s;
  return Status::Error(s.message() + "; GPS times are robot seconds (Global Encoding bit 0 clear)");
}

// ---------------------------------------------------------------------------

LasWriter::LasWriter() = default;

LasWriter::~LasWriter() { Abort(); }

void LasWriter::Abort() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  file_.Abort();
}

Status LasWriter::Fail(const std::string& message) {
  failed_ = message;
  Abort();
  return Status::Error(failed_);
}

Status LasWriter::Open(const std::string& path, const LasWriterOptions& options) {
  Abort();
  failed_.clear();
  options_ = options;
  stats_ = LasWriteStats();
  buffered_ = 0;
  for (int k = 0; k < 3; ++k) {
    min_record_[k] = std::numeric_limits<int64_t>::max();
    max_record_[k] = std::numeric_limits<int64_t>::min();
  }
  auto refuse = [&](const std::string& why) {
    failed_ = path + ": " + why;
    return Status::Error(failed_);
  };
  Status s = ChooseLasQuantisation(options.extent, &q_);
  if (!s.ok()) return refuse(s.message());
  inverse_scale_ = q_.scale == 0.0001 ? 10000.0 : 1000.0;  // Exact, unlike 1 / scale.
  stats_.quantisation = q_;
  if (options.system_identifier.size() > 32 || options.generating_software.size() > 32) {
    return refuse("LAS system identifier and generating software are at most 32 bytes");
  }
  if (options.wkt.empty() || options.wkt.find('\0') != std::string::npos ||
      options.wkt.size() + 1 > 65535) {
    return refuse("the coordinate system WKT must be non-empty text of at most 65534 bytes");
  }
  const std::string vlrs = Vlrs(options.wkt);
  point_data_offset_ = static_cast<uint32_t>(kLasHeaderSize + vlrs.size());
  if (!(s = file_.Open(path)).ok()) return Fail(s.message());
  // The checked writer appends only; the header needs a positioned write at
  // the end, so the bytes go through our own descriptor on its temporary
  // (the writer's Commit fsyncs the same file, then renames it).
  fd_ = ::open(file_.temporary_path().c_str(), O_WRONLY | O_CLOEXEC);
  if (fd_ < 0) return Fail(path + ": cannot open its temporary file: " + std::strerror(errno));
  buffer_.resize(kBufferRecords * kLasRecordSize);
  if (!(s = WriteAt(0, Header().data(), kLasHeaderSize)).ok()) return s;
  if (!(s = WriteAt(kLasHeaderSize, vlrs.data(), vlrs.size())).ok()) return s;
  write_offset_ = point_data_offset_;
  return Status::Ok();
}

Status LasWriter::WriteAt(uint64_t offset, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t k = ::pwrite(fd_, data, n, static_cast<off_t>(offset));
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return Fail(file_.path() + ": write failed: " + std::strerror(k < 0 ? errno : ENOSPC));
    data += k;
    n -= static_cast<size_t>(k);
    offset += static_cast<uint64_t>(k);
  }
  return Status::Ok();
}

Status LasWriter::FlushBuffer() {
  const Status s = WriteAt(write_offset_, buffer_.data(), buffered_);
  write_offset_ += buffered_;
  buffered_ = 0;
  return s;
}

Status LasWriter::Append(const CloudPoint* points, size_t n) {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Error("LAS writer: Append before Open");
  // The loop works on locals: the records are written through char*, which
  // may alias any member, so members would be reloaded for every point.
  const LasExtent& e = options_.extent;
  const double inf = std::numeric_limits<double>::infinity();
  const double lo[3] = {e.empty() ? inf : e.min[0], e.empty() ? inf : e.min[1], e.empty() ? inf : e.min[2]};
  const double hi[3] = {e.max[0], e.max[1], e.max[2]};
  const double offset[3] = {q_.offset[0], q_.offset[1], q_.offset[2]};
  const double inverse_scale = inverse_scale_;
  const double gps0 = options_.gps_time_at_origin_s;
  const int64_t t0 = options_.time_origin_ns;
  const uint16_t source_id = options_.point_source_id;
  int64_t rmin0 = min_record_[0], rmin1 = min_record_[1], rmin2 = min_record_[2];
  int64_t rmax0 = max_record_[0], rmax1 = max_record_[1], rmax2 = max_record_[2];
  uint64_t written = stats_.points, skipped = stats_.non_finite;
  char* const begin = buffer_.data();
  char* const end = begin + buffer_.size();
  char* out = begin + buffered_;
  auto save = [&] {
    buffered_ = static_cast<size_t>(out - begin);
    stats_.points = written;
    stats_.non_finite = skipped;
    min_record_[0] = rmin0, min_record_[1] = rmin1, min_record_[2] = rmin2;
    max_record_[0] = rmax0, max_record_[1] = rmax1, max_record_[2] = rmax2;
  };
  for (size_t i = 0; i < n; ++i) {
    const CloudPoint& p = points[i];
    const double v[3] = {p.x, p.y, p.z};
    // One test for both rare cases: NaN compares false too.
    if (!((v[0] >= lo[0]) & (v[0] <= hi[0]) & (v[1] >= lo[1]) & (v[1] <= hi[1]) & (v[2] >= lo[2]) &
          (v[2] <= hi[2]))) {
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
        ++skipped;  // Documented: skipped and counted, like LasExtent.
        continue;
      }
      save();
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    ": point %llu (%.4f, %.4f, %.4f) lies outside the extent given to the LAS writer",
                    static_cast<unsigned long long>(written + skipped), p.x, p.y, p.z);
      return Fail(file_.path() + buf);
    }
    // §2.4: X_record = (X - offset) / scale, rounded to the nearest integer
    // (half away from zero); in range by ChooseLasQuantisation.
    const auto quantise = [inverse_scale](double v, double offset, int64_t* lo_record, int64_t* hi_record) {
      const double r = (v - offset) * inverse_scale;
      const int64_t ri = static_cast<int64_t>(r + std::copysign(0.5, r));
      *lo_record = std::min(*lo_record, ri);
      *hi_record = std::max(*hi_record, ri);
      return static_cast<int32_t>(ri);
    };
    const int32_t record[3] = {quantise(v[0], offset[0], &rmin0, &rmax0), quantise(v[1], offset[1], &rmin1, &rmax1),
                               quantise(v[2], offset[2], &rmin2, &rmax2)};
    // §2.6, Point Data Record Format 6, then our extra bytes (§4.3).
    const uint16_t intensity = 0;                    // CloudPoint has none (the X4 reports none).
    const uint8_t returns = 0x11;                    // Return number 1 (bits 0-3) of 1 (bits 4-7).
    const uint8_t flags = 0;                         // Classification flags, channel 0, scan direction, edge.
    const uint8_t classification = 0;                // Created, never classified.
    const int16_t scan_angle = 0;                    // Not in CloudPoint (docs/las-format.md).
    const double gps = gps0 + static_cast<double>(p.time_ns - t0) * 1e-9;
    std::memcpy(out, record, 12);
    std::memcpy(out + 12, &intensity, 2);
    std::memcpy(out + 14, &returns, 1);
    std::memcpy(out + 15, &flags, 1);
    std::memcpy(out + 16, &classification, 1);
    std::memcpy(out + 17, &p.pose_source, 1);        // User Data.
    std::memcpy(out + 18, &scan_angle, 2);
    std::memcpy(out + 20, &source_id, 2);
    std::memcpy(out + 22, &gps, 8);
    std::memcpy(out + 30, &p.range_m, 4);
    std::memcpy(out + 34, &p.scan, 4);
    std::memcpy(out + 38, &p.beam, 2);
    std::memcpy(out + 40, &p.flags, 1);
    ++written;
    out += kLasRecordSize;
    if (out == end) {
      save();
      const Status s = FlushBuffer();
      if (!s.ok()) return s;
      out = begin;
    }
  }
  save();
  return Status::Ok();
}

std::string LasWriter::Header() const {
  const uint64_t n = stats_.points;
  Bytes b;
  b.PutText("LASF", 4);
  b.Put<uint16_t>(options_.file_source_id);
  // Bit 0: Adjusted Standard GPS time; bit 4: the CRS is WKT (required for PDRF 6-10, §2.2).
  b.Put<uint16_t>(static_cast<uint16_t>((options_.adjusted_gps_time ? 1u : 0u) | (1u << 4)));
  b.PutZeros(16);  // Project ID (GUID): not used.
  b.Put<uint8_t>(1);
  b.Put<uint8_t>(4);
  b.PutText(options_.system_identifier, 32);
  b.PutText(options_.generating_software, 32);
  b.Put<uint16_t>(options_.creation_day_of_year);
  b.Put<uint16_t>(options_.creation_year);
  b.Put<uint16_t>(kLasHeaderSize);
  b.Put<uint32_t>(point_data_offset_);
  b.Put<uint32_t>(2);  // VLRs: WKT, Extra Bytes.
  b.Put<uint8_t>(kLasPointFormat);
  b.Put<uint16_t>(kLasRecordSize);
  b.PutZeros(4 + 5 * 4);  // Legacy counts: must be 0 for PDRF 6-10 (§2.4).
  for (int k = 0; k < 3; ++k) b.Put<double>(q_.scale);
  for (int k = 0; k < 3; ++k) b.Put<double>(q_.offset[k]);
  for (int k = 0; k < 3; ++k) {
    b.Put<double>(stats_.max[k]);
    b.Put<double>(stats_.min[k]);
  }
  b.Put<uint64_t>(0);  // Start of waveform data: none.
  b.Put<uint64_t>(0);  // Start of first EVLR: none.
  b.Put<uint32_t>(0);  // Number of EVLRs.
  b.Put<uint64_t>(n);
  b.Put<uint64_t>(n);  // By return: every point is return 1 of 1.
  b.PutZeros(14 * 8);
  return b.str();
}

Status LasWriter::Finish() {
  if (!failed_.empty()) return Status::Error(failed_);
  if (fd_ < 0) return Status::Error("LAS writer: Finish before Open");
  Status s = FlushBuffer();
  if (!s.ok()) return s;
  // §2.4 "Max and Min X, Y, Z": the extent of the data as a reader decodes
  // it, X_record * scale + offset, from the records actually written.
  for (int k = 0; k < 3 && stats_.points > 0; ++k) {
    stats_.min[k] = static_cast<double>(min_record_[k]) * q_.scale + q_.offset[k];
    stats_.max[k] = static_cast<double>(max_record_[k]) * q_.scale + q_.offset[k];
  }
  const std::string header = Header();
  if (!(s = WriteAt(0, header.data(), header.size())).ok()) return s;
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) return Fail(file_.path() + ": close failed: " + std::strerror(errno));
  if (!(s = file_.Commit()).ok()) return Fail(s.message());
  stats_.bytes = write_offset_;
  return Status::Ok();
}

// ---------------------------------------------------------------------------

Status SaveLas(const std::string& path, const CloudSnapshotRef& cloud,
               const std::string& created_utc, LasWriterOptions options,
               const std::atomic<bool>* cancel, LasWriteStats* stats, std::string* time_note) {
  const auto cancelled = [cancel] { return cancel != nullptr && cancel->load(); };
  const Status stopped = Status::Error(path + ": cancelled");
  // Pass 1: the box that sets the scale and offset, and the earliest time
  // that anchors the GPS clock (the header needs both before any record).
  LasExtent extent;
  if (!cloud.ForEachChunk([&](const CloudPoint* p, size_t n) {
        extent.Add(p, n);
        return !cancelled();
      })) {
    return stopped;
  }
  options.extent = extent;
  const Status time = SetLasTimeFromSession(created_utc, extent, &options);
  if (time_note != nullptr) *time_note = time.ok() ? std::string() : time.message();
  // Pass 2: the records.
  LasWriter writer;
  Status s = writer.Open(path, options);
  const bool all = s.ok() && cloud.ForEachChunk([&](const CloudPoint* p, size_t n) {
    s = writer.Append(p, n);
    return s.ok() && !cancelled();
  });
  if (!s.ok()) return s;  // The writer removes its temporary.
  if (!all) return stopped;
  s = writer.Finish();
  if (s.ok() && stats != nullptr) *stats = writer.stats();
  return s;
}

}  // namespace sweepscan
