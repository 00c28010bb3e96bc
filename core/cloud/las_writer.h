// LAS 1.4 export (ASPRS LAS Specification 1.4 R15), written by our own code:
// Point Data Record Format 6 plus an Extra Bytes VLR, a WKT coordinate
// system VLR stating the session frame, streamed chunk by chunk with memory
// bounded by one fixed buffer. The exact byte layout, and what each field
// holds for a sweepscan cloud, is in docs/las-format.md.
//
//   LasExtent extent;                       // 1st pass (or the chunks' bounds)
//   extent.Add(points.data(), points.size());
//   LasWriterOptions o;
//   o.extent = extent;
//   SetLasTimeFromSession(meta.created_utc, extent, &o);
//   LasWriter w;
//   Status s = w.Open("room.las", o);      // 2nd pass, any chunk sizes
//   if (s.ok()) s = w.Append(chunk.data(), chunk.size());
//   if (s.ok()) s = w.Finish();            // counts and bounds, then rename
//
// The file goes through the checked writer (core/common/checked_file.h): it
// exists under its name only when complete; any failure removes the
// temporary and names the file and the operating system's reason.
//
// Threading: a LasWriter is used from one thread; the free functions are pure
// (SetLasTimeFromSession reads the clock only when created_utc is unusable).
#ifndef SWEEPSCAN_CORE_CLOUD_LAS_WRITER_H_
#define SWEEPSCAN_CORE_CLOUD_LAS_WRITER_H_

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/common/checked_file.h"
#include "core/common/status.h"

namespace sweepscan {

// Sizes fixed by the specification and by our record layout (docs/las-format.md).
inline constexpr uint16_t kLasHeaderSize = 375;        // §2.4, LAS 1.4.
inline constexpr uint16_t kLasVlrHeaderSize = 54;      // §2.5.
inline constexpr uint16_t kLasExtraBytesDescriptorSize = 192;  // §4.3.
inline constexpr uint8_t kLasPointFormat = 6;           // §2.6.
inline constexpr uint16_t kLasCoreRecordSize = 30;      // PDRF 6 without extra bytes.
// range (float32) + scan (uint32) + beam (uint16) + flags (uint8).
inline constexpr uint16_t kLasExtraBytes = 4 + 4 + 2 + 1;
inline constexpr uint16_t kLasRecordSize = kLasCoreRecordSize + kLasExtraBytes;  // 41
inline constexpr int kLasExtraBytesFields = 4;
// GPS time (§2.4, Global Encoding bit 0 set) is "Adjusted Standard GPS Time":
// seconds since 1980-01-06T00:00:00 UTC (GPS epoch, no leap seconds) minus 1e9.
inline constexpr double kLasAdjustedGpsOffsetS = 1e9;
inline constexpr int64_t kUnixSecondsAtGpsEpoch = 315964800;  // 1980-01-06T00:00:00Z

// The OGC (2001, WKT1) coordinate system of a session's cloud, for the WKT VLR
// (§3.2). Two axes: a three-axis LOCAL_CS is valid WKT1 but PROJ before 9.3.1
// (Debian 12 has 9.1.1, and GDAL and PDAL parse through it) refuses it; the
// name states z (up, metres) instead.
extern const char kSweepscanSessionWkt[];
// The same for a project's cloud: the project's frame (its anchor session's
// start pose; docs/project-format.md).
extern const char kSweepscanProjectWkt[];

// The extent of a cloud (m) and what the writer needs from a first pass.
// Non-finite points are counted and left out, as the writer does.
struct LasExtent {
  double min[3] = {0.0, 0.0, 0.0};
  double max[3] = {0.0, 0.0, 0.0};
  uint64_t points = 0;      // Finite points added.
  uint64_t non_finite = 0;  // Points with a NaN or infinite coordinate.
  int64_t min_time_ns = 0;  // Earliest robot time of a finite point.

  void Add(const CloudPoint* points, size_t n);
  void Add(const LasExtent& other);  // Union (a project's sessions, a file's chunks).
  bool empty() const { return points == 0; }
};

struct LasWriterOptions {
  // Every point appended must lie inside (refused otherwise). It chooses the
  // scale (0.1 mm where the coordinates fit int32, else 1 mm) and the offset
  // (the box's centre rounded to a whole metre), §2.4 "Scale Factors".
  LasExtent extent;
  // GPS time of a point = gps_time_at_origin_s + (time_ns - time_origin_ns) * 1e-9.
  // adjusted_gps_time sets Global Encoding bit 0 (Adjusted Standard GPS Time);
  // without it the times are robot seconds (bit 0 clear), see SetLasTimeFromSession.
  bool adjusted_gps_time = false;
  int64_t time_origin_ns = 0;
  double gps_time_at_origin_s = 0.0;
  // §2.4 "File Creation Day of Year" (1 = 1 January, GMT) and "File Creation Year".
  uint16_t creation_day_of_year = 0;
  uint16_t creation_year = 0;
  uint16_t file_source_id = 0;   // §2.4: 0 = not assigned.
  uint16_t point_source_id = 1;  // Every record's Point Source ID: the session.
  std::string system_identifier = "OTHER";  // §2.4, at most 32 bytes.
  std::string generating_software = "sweepscan";  // §2.4, at most 32 bytes.
  std::string wkt = kSweepscanSessionWkt;
};

// Scale and offset chosen for an extent (§2.4): X_record = round((x - offset) / scale).
struct LasQuantisation {
  double scale = 0.0001;
  double offset[3] = {0.0, 0.0, 0.0};
};
// Refuses an extent whose coordinates do not fit int32 even at 1 mm
// (|x - offset| above about 2147 km) or that is not finite.
Status ChooseLasQuantisation(const LasExtent& extent, LasQuantisation* q);

// GPS time anchoring for a session (docs/las-format.md, "GPS time"):
// created_utc (ISO 8601 UTC, meta.json's) is taken as the GPS time of the
// extent's earliest point; the creation day and year come from it too. If it
// is missing or unparsable the times stay robot seconds (Global Encoding bit 0
// clear), the creation date is today's, and the reason is returned as an
// error Status (the options are usable either way: warn and go on).
Status SetLasTimeFromSession(const std::string& created_utc, const LasExtent& extent,
                             LasWriterOptions* options);
// "2026-11-22T10:15:00Z" (fraction of a second and +hh:mm / -hh:mm allowed)
// -> Adjusted Standard GPS time: UTC + leap seconds (18 since 2017, the table
// in las_writer.cc) - GPS epoch - 1e9. Also gives the UTC year and day of year.
Status AdjustedGpsTimeFromIso8601(const std::string& utc, double* adjusted_gps_s, int* year,
                                  int* day_of_year);

struct LasWriteStats {
  uint64_t points = 0;      // Point records written.
  uint64_t non_finite = 0;  // Points skipped for a NaN or infinite coordinate.
  uint64_t bytes = 0;       // File size.
  LasQuantisation quantisation;
  double min[3] = {0.0, 0.0, 0.0};  // The header's bounds: what the written integers decode to.
  double max[3] = {0.0, 0.0, 0.0};
};

class LasWriter {
 public:
  LasWriter();
  ~LasWriter();  // Abort() unless finished.
  LasWriter(const LasWriter&) = delete;
  LasWriter& operator=(const LasWriter&) = delete;

  // Creates PATH's temporary and writes the header (counts and bounds still
  // zero) and the VLRs. Refuses bad options before creating anything.
  Status Open(const std::string& path, const LasWriterOptions& options);
  // Any number of points, any number of calls. A point outside the options'
  // extent fails the export (sticky: later calls and Finish fail too).
  Status Append(const CloudPoint* points, size_t n);
  // Between Appends: the Point Source ID and the time mapping of the points
  // that follow (a project's sessions: each its own id and its own clock).
  void SetSource(uint16_t point_source_id, int64_t time_origin_ns, double gps_time_at_origin_s) {
    options_.point_source_id = point_source_id;
    options_.time_origin_ns = time_origin_ns;
    options_.gps_time_at_origin_s = gps_time_at_origin_s;
  }
  // Writes the remaining records, fills the header's counts and bounds,
  // fsyncs and renames the file into place.
  Status Finish();
  // Removes the temporary; PATH is left as it was.
  void Abort();

  const LasWriteStats& stats() const { return stats_; }

 private:
  Status Fail(const std::string& message);
  Status FlushBuffer();
  Status WriteAt(uint64_t offset, const char* data, size_t n);
  std::string Header() const;

  CheckedFileWriter file_;  // Temporary, fsync, rename and cleanup.
  int fd_ = -1;             // Our own descriptor on the temporary (positioned writes).
  LasWriterOptions options_;
  LasQuantisation q_;
  double inverse_scale_ = 10000.0;
  uint32_t point_data_offset_ = 0;
  uint64_t write_offset_ = 0;
  std::vector<char> buffer_;
  size_t buffered_ = 0;
  int64_t min_record_[3];
  int64_t max_record_[3];
  LasWriteStats stats_;
  std::string failed_;
};

// A cloud snapshot (the app's cloud) as a LAS file, in two passes over its
// chunks, one chunk decoded at a time: the extent and earliest time, then the
// records. `options.extent` and its time fields are set here from the cloud
// and `created_utc` (SetLasTimeFromSession); when the time cannot be anchored
// the file is still written, its times robot seconds, and the reason is put in
// *time_note. Stops (no file) when `cancel` becomes true, with "cancelled".
Status SaveLas(const std::string& path, const CloudSnapshotRef& cloud,
               const std::string& created_utc, LasWriterOptions options,
               const std::atomic<bool>* cancel = nullptr, LasWriteStats* stats = nullptr,
               std::string* time_note = nullptr);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_LAS_WRITER_H_
