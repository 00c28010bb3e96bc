#include "hardware/station/project_export.h"

#include <algorithm>

#include "core/cloud/cloud_io.h"
#include "core/common/checked_file.h"
#include "core/common/file_suffix.h"

namespace sweepscan::hardware {
namespace {

// p <- project_from_session * p for a chunk, into `out`.
void ToProject(const Rigid3d& t, const CloudPoint* p, size_t n, std::vector<CloudPoint>* out) {
  out->assign(p, p + n);
  TransformPoints(t, out->data(), n);
}

// One pass over the chosen sessions: each streamed in the project's frame
// to `sink`, with the progress of the whole export (`pass` of `passes`).
class Passes {
 public:
  Passes(const std::string& project_file, const Project& project, const std::vector<size_t>& chosen,
         const SessionCloudOptions& options, const ProjectExportProgress& progress, int passes)
      : file_(project_file),
        project_(project),
        chosen_(chosen),
        options_(options),
        progress_(progress),
        passes_(passes) {}

  // `what`: the pass's stage after the session's name ("for the extent").
  // `each(k, cloud)` runs after session k's pass with what it was built from.
  Status Run(int pass, const std::string& what,
             const std::function<Status(size_t k, const CloudPoint*, size_t)>& sink,
             const std::function<void(size_t k, const SessionCloud&)>& each) {
    const size_t n = chosen_.size();
    for (size_t k = 0; k < n; ++k) {
      const ProjectSession& ps = project_.sessions[chosen_[k]];
      const std::string stage = "Reading '" + ps.id + "'" + (what.empty() ? "" : " " + what) +
                                " (" + std::to_string(k + 1) + " of " + std::to_string(n) + ")";
      SessionCloudOptions o = options_;
      o.progress = [this, stage, pass, k, n](double f) {
        if (!progress_) return true;
        cancelled_ = !progress_(stage, (pass + (k + f) / n) / passes_);
        return !cancelled_;
      };
      std::vector<CloudPoint> buffer;
      SessionCloud cloud;
      bool written = true;
      const Status s =
          StreamSessionCloud(file_, ps, o, &cloud, [&](const CloudPoint* p, size_t count) {
            ToProject(*ps.project_from_session, p, count, &buffer);
            const Status w = sink(k, buffer.data(), buffer.size());
            written = w.ok();
            return w;
          });
      if (cancelled_) return Status::Error("cancelled");
      if (!s.ok()) {
        unreadable_ = written;  // Not the file's fault: the session's.
        return s;
      }
      each(k, cloud);
    }
    return Status::Ok();
  }
  // The last Run failed reading a session (not in its sink).
  bool unreadable() const { return unreadable_; }

 private:
  const std::string& file_;
  const Project& project_;
  const std::vector<size_t>& chosen_;
  const SessionCloudOptions& options_;
  const ProjectExportProgress& progress_;
  const int passes_;
  bool cancelled_ = false;
  bool unreadable_ = false;
};

std::string Quoted(const std::string& id) { return "'" + id + "'"; }

// PLY or PCD in one pass through the streamed writer: memory is a chunk,
// not the building (32 bytes a point held whole was 3.2 GB at 100 M).
Status ExportStreamed(const std::string& out, Passes* passes, const std::vector<size_t>& chosen,
                      ProjectExportResult* result) {
  CloudFileWriter writer;
  Status s = writer.Open(out);
  if (!s.ok()) return s;
  s = passes->Run(
      0, "", [&writer](size_t, const CloudPoint* p, size_t n) { return writer.Append(p, n); },
      [&](size_t k, const SessionCloud& cloud) {
        const uint64_t before = result->points;
        result->points = writer.points();
        result->sessions.push_back(
            {cloud.id, static_cast<uint16_t>(chosen[k] + 1), result->points - before, 0});
        if (!cloud.damage.empty())
          result->warnings.push_back(Quoted(cloud.id) + ": " + cloud.damage);
      });
  if (!s.ok()) return s;
  return writer.Finish();
}

Status ExportLas(const std::string& out, Passes* passes, const Project& project,
                 const std::vector<size_t>& chosen, ProjectExportResult* result) {
  // Pass 1: the extent, and each session's for its clock.
  std::vector<LasExtent> extents(chosen.size());
  std::vector<std::string> created(chosen.size());
  Status s = passes->Run(
      0, "for the extent",
      [&extents](size_t k, const CloudPoint* p, size_t n) {
        extents[k].Add(p, n);
        return Status::Ok();
      },
      [&](size_t k, const SessionCloud& cloud) {
        created[k] = cloud.meta.created_utc;
        if (!cloud.damage.empty())
          result->warnings.push_back(Quoted(cloud.id) + ": " + cloud.damage);
      });
  if (!s.ok()) return s;
  LasWriterOptions o;
  for (const LasExtent& e : extents) o.extent.Add(e);
  o.wkt = kSweepscanProjectWkt;
  o.system_identifier = "sweepscan project";
  o.generating_software = "sweepscan 0.1.0";
  // GPS time needs every session's start time; one session without it
  // makes the whole file robot seconds (Global Encoding is per file).
  std::vector<LasWriterOptions> times(chosen.size());
  bool gps = true;
  for (size_t k = 0; k < chosen.size(); ++k) {
    const Status t = SetLasTimeFromSession(created[k], extents[k], &times[k]);
    if (!t.ok()) {
      result->warnings.push_back(Quoted(project.sessions[chosen[k]].id) + ": " + t.message() +
                                 "; the file's times are robot seconds");
      gps = false;
    }
  }
  o.adjusted_gps_time = gps;
  o.creation_year = times[0].creation_year;
  o.creation_day_of_year = times[0].creation_day_of_year;
  LasWriter writer;
  s = writer.Open(out, o);
  if (!s.ok()) return s;
  // Pass 2: the records, each session with its own id and clock.
  size_t current = chosen.size();
  s = passes->Run(
      1, "",
      [&](size_t k, const CloudPoint* p, size_t n) {
        if (k != current) {
          current = k;
          const uint16_t id = static_cast<uint16_t>(chosen[k] + 1);
          if (gps) {
            writer.SetSource(id, times[k].time_origin_ns, times[k].gps_time_at_origin_s);
          } else {
            writer.SetSource(id, 0, 0.0);
          }
        }
        return writer.Append(p, n);
      },
      [&](size_t k, const SessionCloud& cloud) {
        // What was written of the session (a point with a NaN or infinite
        // coordinate is skipped and counted, as the session export does).
        const uint64_t skipped = extents[k].non_finite;
        result->sessions.push_back(
            {cloud.id, static_cast<uint16_t>(chosen[k] + 1), extents[k].points, skipped});
        if (skipped > 0) {
          result->warnings.push_back(Quoted(cloud.id) + ": " + std::to_string(skipped) +
                                     " point(s) with a NaN or infinite coordinate left out");
        }
      });
  if (s.ok()) s = writer.Finish();
  if (!s.ok()) return s;
  const LasWriteStats& w = writer.stats();
  result->points = w.points;
  result->non_finite_skipped = w.non_finite;
  result->gps_time = gps;
  result->quantisation = w.quantisation;
  return Status::Ok();
}

}  // namespace

std::vector<size_t> PlacedVisibleSessions(const Project& project,
                                          std::vector<std::string>* unplaced) {
  std::vector<size_t> chosen;
  for (size_t i = 0; i < project.sessions.size(); ++i) {
    const ProjectSession& ps = project.sessions[i];
    if (!ps.visible) continue;
    if (ps.project_from_session) {
      chosen.push_back(i);
    } else if (unplaced != nullptr) {
      unplaced->push_back(ps.id);
    }
  }
  return chosen;
}

Status ExportProjectCloud(const std::string& project_file, const Project& project,
                          const std::vector<size_t>& chosen, const std::string& out,
                          const SessionCloudOptions& options, const ProjectExportProgress& progress,
                          ProjectExportResult* result) {
  *result = ProjectExportResult();
  const bool las = HasFileSuffix(out, ".las");
  if (!las && !HasFileSuffix(out, ".ply") && !HasFileSuffix(out, ".pcd")) {
    return Status::Error(out + ": not a cloud file name (.las, .ply or .pcd)");
  }
  if (chosen.empty()) return Status::Error("no placed session to export");
  for (size_t i : chosen) {
    if (i >= project.sessions.size()) return Status::Error("no such session in the project");
    if (!project.sessions[i].project_from_session) {
      return Status::Error(Quoted(project.sessions[i].id) + " is not placed yet");
    }
  }
  // Before the clouds are built, not after (minutes on a building).
  const Status s = CheckCanWrite(out);
  if (!s.ok()) return s;
  Passes passes(project_file, project, chosen, options, progress, las ? 2 : 1);
  const Status done = las ? ExportLas(out, &passes, project, chosen, result)
                          : ExportStreamed(out, &passes, chosen, result);
  result->session_unreadable = passes.unreadable();
  return done;
}

}  // namespace sweepscan::hardware
