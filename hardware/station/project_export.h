// A project's cloud as one file (docs/las-format.md): the
// chosen sessions' clouds (hardware/station/session_cloud.h) in the
// project's frame, one after another, written the one way `sweepscan-cli
// project export` and the desktop app's File > Export Project Cloud write it.
//
// LAS 1.4 (docs/las-format.md) is streamed twice over each session's
// frames.bin: a first pass for the extent (the scale and offset need the
// whole box before the first record) and each session's earliest time, a
// second that appends the records. Memory holds one chunk of points, not a
// session, however large the building. Each session's records carry its
// own Point Source ID (its 1-based place in the project file) and GPS
// times from its own clock (meta.json's created_utc); one session without
// a usable clock makes the whole file robot seconds, since LAS says which
// in one header bit (Global Encoding bit 0). PLY and PCD take one pass
// through the streamed cloud writer (CloudFileWriter): the same bounded
// memory.
//
// Pure, no Qt; any thread (the app runs it on a job thread).
#ifndef SWEEPSCAN_HARDWARE_STATION_PROJECT_EXPORT_H_
#define SWEEPSCAN_HARDWARE_STATION_PROJECT_EXPORT_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/cloud/las_writer.h"
#include "core/common/status.h"
#include "core/project/project.h"
#include "hardware/station/session_cloud.h"

namespace sweepscan::hardware {

// The sessions a project draws: placed and visible, by index. `unplaced`
// (may be null) gets the ids of the visible ones left out for want of a
// placement.
std::vector<size_t> PlacedVisibleSessions(const Project& project,
                                          std::vector<std::string>* unplaced);

struct ProjectExportSession {
  std::string id;
  uint16_t point_source_id = 0;  // LAS: its 1-based place in the project file
  uint64_t points = 0;           // written
  uint64_t non_finite_skipped = 0;
};

struct ProjectExportResult {
  std::vector<ProjectExportSession> sessions;  // in the order written
  uint64_t points = 0;
  uint64_t non_finite_skipped = 0;
  // LAS only: whether the times are Adjusted Standard GPS time (else
  // robot seconds), and the scale and offset chosen.
  bool gps_time = false;
  LasQuantisation quantisation;
  // What the operator should be told of a file that was written: a
  // session's damaged records, a session without a usable clock, points
  // left out for a NaN coordinate. One sentence each, "'ID': why".
  std::vector<std::string> warnings;
  // The export failed because a session could not be read (its folder,
  // meta.json or frames.bin), not for the file written.
  bool session_unreadable = false;
};

// The stage ("Reading 'a' for the extent (1 of 3)") and the fraction of the
// whole export done; returns false to cancel (the export then fails with
// "cancelled" and leaves `out` as it was).
using ProjectExportProgress = std::function<bool(const std::string& stage, double fraction)>;

// Writes the sessions `chosen` (indices into project.sessions, each placed)
// of `project` (read from, or to be saved as, `project_file`: relative
// session folders are found from it) to `out`, by its suffix: .las, .ply or
// .pcd. `options` says how each cloud is built (its progress is replaced).
// The file appears whole or not at all.
Status ExportProjectCloud(const std::string& project_file, const Project& project,
                          const std::vector<size_t>& chosen, const std::string& out,
                          const SessionCloudOptions& options, const ProjectExportProgress& progress,
                          ProjectExportResult* result);

}  // namespace sweepscan::hardware

#endif  // SWEEPSCAN_HARDWARE_STATION_PROJECT_EXPORT_H_
