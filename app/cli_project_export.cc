// sweepscan-cli project export: the placed, visible sessions' clouds in the
// project's frame, as one file.
//
// LAS (docs/las-format.md) is streamed: a first pass builds each session's
// cloud in turn for the extent (the scale and offset need the whole box
// before the first record), a second builds it again and appends it, so
// memory holds one session however many the project has; each session's
// records carry its own Point Source ID (its 1-based place in the project
// file) and GPS times from its own clock and start time. PLY and PCD are
// written whole (their writers take one array).
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "app/cli_common.h"
#include "app/cli_project.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/common/file_suffix.h"
#include "core/session/session.h"

namespace sweepscan::app {
namespace {

// The sessions to write: placed and visible, or those --sessions names.
// `purpose`: what they are for, as the refusal says it ("to export").
int SelectSessions(const Args& args, const Project& project, const std::string& purpose,
                   std::vector<size_t>* chosen) {
  std::set<std::string> named;
  if (args.Has("sessions")) {
    std::stringstream list(args.Get("sessions"));
    for (std::string id; std::getline(list, id, ',');) {
      if (project.Find(id) < 0) {
        PrintError("--sessions: no session '" + id + "' in the project");
        return kExitBadInput;
      }
      named.insert(id);
    }
  }
  for (size_t i = 0; i < project.sessions.size(); ++i) {
    const ProjectSession& ps = project.sessions[i];
    const bool wanted = named.empty() ? ps.visible : named.count(ps.id) > 0;
    if (!wanted) continue;
    if (!ps.project_from_session) {
      if (!named.empty()) {
        PrintError("'" + ps.id + "' is not placed yet (sweepscan-cli project align)");
        return kExitBadInput;
      }
      std::cerr << "sweepscan-cli: warning: '" << ps.id << "' is not placed yet and is left out\n";
      continue;
    }
    chosen->push_back(i);
  }
  if (chosen->empty()) {
    PrintError("no placed session " + purpose +
               " (sweepscan-cli project align places them; hidden ones count only with "
               "--sessions)");
    return kExitBadInput;
  }
  return kExitOk;
}

// One session's cloud in the project frame; the cache is not kept (one
// session in memory at a time).
int ProjectCloud(const std::string& file, const hardware::SessionCloudOptions& options, const ProjectSession& ps,
                 hardware::SessionCloud* cloud) {
  const Status s = hardware::LoadSessionCloud(file, ps, options, cloud);
  if (!s.ok()) {
    PrintError(s.message());
    return kExitBadInput;
  }
  if (!cloud->damage.empty()) std::cerr << "sweepscan-cli: warning: " << cloud->dir << ": " << cloud->damage << "\n";
  hardware::TransformPoints(*ps.project_from_session, &cloud->points);
  return kExitOk;
}

}  // namespace

void WarnPoseSource(const Project& project, const std::vector<size_t>& chosen, PoseSource source) {
  for (size_t i : chosen) {
    const RegistrationEvidence& e = project.sessions[i].registration;
    if (e.method == "anchor" || e.method == "manual" || e.pose_source == PoseSourceName(source)) {
      continue;
    }
    std::cerr << "sweepscan-cli: warning: '" << project.sessions[i].id << "' was placed with its "
              << e.pose_source << " cloud and is drawn with its " << PoseSourceName(source)
              << " cloud: the two differ, and the placement need not hold for it\n";
  }
}

int ProjectPositions(const Args& args, const std::string& file, std::vector<Eigen::Vector3f>* points) {
  Project project;
  const Status s = LoadProjectAndSay(file, &project);
  if (!s.ok()) return (PrintError(s.message()), kExitBadInput);
  hardware::SessionCloudOptions options;
  if (const int code = SessionCloudOptionsFromArgs(args, &options); code != kExitOk) return code;
  std::vector<size_t> chosen;
  if (const int code = SelectSessions(args, project, "to draw", &chosen); code != kExitOk)
    return code;
  WarnPoseSource(project, chosen, options.pose_source);
  for (size_t i : chosen) {
    hardware::SessionCloud cloud;
    if (const int code = ProjectCloud(file, options, project.sessions[i], &cloud); code != kExitOk) return code;
    points->reserve(points->size() + cloud.points.size());
    for (const CloudPoint& p : cloud.points) points->emplace_back(p.x, p.y, p.z);
  }
  return kExitOk;
}

int RunProjectExport(const Args& args) {
  const std::string file = args.positional()[0];
  const std::string out = args.Get("out");
  if (!HasFileSuffix(out, ".las") && !HasFileSuffix(out, ".ply") && !HasFileSuffix(out, ".pcd")) {
    PrintError("project export needs --out FILE.las|FILE.ply|FILE.pcd");
    return kExitBadInput;
  }
  Project project;
  Status s = LoadProjectAndSay(file, &project);
  if (!s.ok()) return (PrintError(s.message()), kExitBadInput);
  hardware::SessionCloudOptions options;
  if (const int code = SessionCloudOptionsFromArgs(args, &options); code != kExitOk) return code;
  std::vector<size_t> chosen;
  if (const int code = SelectSessions(args, project, "to export", &chosen); code != kExitOk)
    return code;
  WarnPoseSource(project, chosen, options.pose_source);
  // Before the clouds are built, not after (minutes on a building).
  s = CheckCanWrite(out);
  if (!s.ok()) return (PrintError(s.message()), kExitFailure);
  nlohmann::json report = {{"project", file}, {"out", out}, {"sessions", nlohmann::json::array()}};

  if (!HasFileSuffix(out, ".las")) {
    std::vector<CloudPoint> all;
    for (size_t i : chosen) {
      hardware::SessionCloud cloud;
      if (const int code = ProjectCloud(file, options, project.sessions[i], &cloud); code != kExitOk) return code;
      report["sessions"].push_back({{"id", cloud.id}, {"points", cloud.points.size()}});
      all.insert(all.end(), cloud.points.begin(), cloud.points.end());
    }
    s = SaveCloud(out, all);
    if (!s.ok()) return (PrintError(s.message()), kExitFailure);
    report["points"] = all.size();
  } else {
    // Pass 1: the extent and each session's clock.
    LasExtent extent;
    struct Clock {
      std::string created_utc;
      LasExtent extent;
    };
    std::vector<Clock> clocks;
    for (size_t i : chosen) {
      hardware::SessionCloud cloud;
      if (const int code = ProjectCloud(file, options, project.sessions[i], &cloud); code != kExitOk) return code;
      Clock c{cloud.meta.created_utc, {}};
      c.extent.Add(cloud.points.data(), cloud.points.size());
      extent.Add(c.extent);
      clocks.push_back(c);
    }
    LasWriterOptions o;
    o.extent = extent;
    o.wkt = kSweepscanProjectWkt;
    o.system_identifier = "sweepscan project";
    o.generating_software = "sweepscan 0.1.0";
    // GPS time needs every session's start time; one session without it
    // makes the whole file robot seconds (Global Encoding is per file).
    std::vector<LasWriterOptions> times(chosen.size());
    bool gps = true;
    for (size_t k = 0; k < chosen.size(); ++k) {
      const Status t = SetLasTimeFromSession(clocks[k].created_utc, clocks[k].extent, &times[k]);
      if (!t.ok()) {
        std::cerr << "sweepscan-cli: warning: '" << project.sessions[chosen[k]].id << "': " << t.message()
                  << "; the file's times are robot seconds\n";
        gps = false;
      }
    }
    o.adjusted_gps_time = gps;
    o.creation_year = times[0].creation_year;
    o.creation_day_of_year = times[0].creation_day_of_year;
    LasWriter writer;
    s = writer.Open(out, o);
    // Pass 2: the records.
    for (size_t k = 0; s.ok() && k < chosen.size(); ++k) {
      const ProjectSession& ps = project.sessions[chosen[k]];
      hardware::SessionCloud cloud;
      if (const int code = ProjectCloud(file, options, ps, &cloud); code != kExitOk) return code;
      const uint16_t source_id = static_cast<uint16_t>(chosen[k] + 1);
      if (gps) {
        writer.SetSource(source_id, times[k].time_origin_ns, times[k].gps_time_at_origin_s);
      } else {
        writer.SetSource(source_id, 0, 0.0);
      }
      const LasWriteStats before = writer.stats();
      s = writer.Append(cloud.points.data(), cloud.points.size());
      // What was written of the session (a point with a NaN or infinite
      // coordinate is skipped and counted, as the session export does).
      const uint64_t skipped = writer.stats().non_finite - before.non_finite;
      report["sessions"].push_back({{"id", ps.id},
                                    {"point_source_id", source_id},
                                    {"points", cloud.points.size() - skipped},
                                    {"non_finite_skipped", skipped}});
      if (skipped > 0) {
        std::cerr << "sweepscan-cli: warning: '" << ps.id << "': " << skipped
                  << " point(s) with a NaN or infinite coordinate left out\n";
      }
    }
    if (s.ok()) s = writer.Finish();
    if (!s.ok()) return (PrintError(s.message()), kExitFailure);
    const LasWriteStats& w = writer.stats();
    report["points"] = w.points;
    report["non_finite_skipped"] = w.non_finite;
    report["scale_m"] = w.quantisation.scale;
    report["offset_m"] = {w.quantisation.offset[0], w.quantisation.offset[1], w.quantisation.offset[2]};
    report["gps_time"] = gps ? "adjusted standard GPS time" : "robot seconds";
  }
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    std::cout << "wrote " << report["points"].get<uint64_t>() << " points of " << chosen.size()
              << " session(s) to " << out << "\n";
  }
  return kExitOk;
}

}  // namespace sweepscan::app
