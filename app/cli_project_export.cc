// sweepscan-cli project export: the placed, visible sessions' clouds in the
// project's frame, as one file (hardware/station/project_export.h, which
// the app's File > Export Project Cloud writes through too).
#include <cctype>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "app/cli_common.h"
#include "app/cli_project.h"
#include "app/terminal_progress.h"
#include "core/cloud/cloud_io.h"
#include "core/cloud/las_writer.h"
#include "core/common/file_suffix.h"
#include "core/session/session.h"
#include "hardware/station/project_export.h"

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
    // An empty list is not "all" (a script's empty variable).
    if (named.empty()) {
      PrintError("--sessions: no session ID given (IDS: comma-separated session IDs)");
      return kExitBadInput;
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
    // Streamed (12 bytes a point, the session never held decoded), then
    // moved into the project's frame as TransformPoints moves points.
    const ProjectSession& ps = project.sessions[i];
    hardware::SessionCloud cloud;
    std::vector<Eigen::Vector3f> positions;
    const Status built = hardware::LoadSessionPositions(file, ps, options, &cloud, &positions);
    if (!built.ok()) return (PrintError(built.message()), kExitBadInput);
    if (!cloud.damage.empty())
      std::cerr << "sweepscan-cli: warning: " << cloud.dir << ": " << cloud.damage << "\n";
    const Eigen::Matrix3d r = ps.project_from_session->rotation().toRotationMatrix();
    const Eigen::Vector3d o = ps.project_from_session->translation();
    points->reserve(points->size() + positions.size());
    for (const Eigen::Vector3f& p : positions)
      points->push_back((r * p.cast<double>() + o).cast<float>());
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
  hardware::ProjectExportResult result;
  TerminalProgress progress(TerminalProgress::Wanted(args.Flag("json")), "project export " + out);
  hardware::ProjectExportProgress show;
  if (progress.on()) {
    show = [&progress](std::string stage, double f) {
      // "Reading 'a' (1 of 2)" (the app's panel) mid-line: "reading".
      if (!stage.empty()) stage[0] = static_cast<char>(std::tolower(stage[0]));
      progress.Show(stage, f);
      return true;
    };
  }
  s = hardware::ExportProjectCloud(file, project, chosen, out, options, show, &result);
  progress.Clear();
  for (const std::string& w : result.warnings) std::cerr << "sweepscan-cli: warning: " << w << "\n";
  if (!s.ok())
    return (PrintError(s.message()), result.session_unreadable ? kExitBadInput : kExitFailure);
  nlohmann::json report = {{"project", file}, {"out", out}, {"sessions", nlohmann::json::array()}};
  const bool las = HasFileSuffix(out, ".las");
  for (const hardware::ProjectExportSession& e : result.sessions) {
    nlohmann::json j = {{"id", e.id}, {"points", e.points}};
    if (las) {
      j["point_source_id"] = e.point_source_id;
      j["non_finite_skipped"] = e.non_finite_skipped;
    }
    report["sessions"].push_back(j);
  }
  report["points"] = result.points;
  if (las) {
    const LasQuantisation& q = result.quantisation;
    report["non_finite_skipped"] = result.non_finite_skipped;
    report["scale_m"] = q.scale;
    report["offset_m"] = {q.offset[0], q.offset[1], q.offset[2]};
    report["gps_time"] = result.gps_time ? "adjusted standard GPS time" : "robot seconds";
  }
  if (args.Flag("json")) {
    std::cout << report.dump(2) << "\n";
  } else {
    std::cout << "wrote " << result.points << " points of " << chosen.size() << " session(s) to "
              << out << "\n";
  }
  return kExitOk;
}

}  // namespace sweepscan::app
