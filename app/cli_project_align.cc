// sweepscan-cli project align: places a project's sessions by registration
// (core/registration/registration.h, docs/registration.md).
//
// Each unplaced session S is registered against every placed session R (or
// --to): coarse from the planes both see (or the operator's --pairs), then
// point-to-plane ICP. The pairing with the largest overlap wins and
// project_from_S = project_from_R * R_from_S. Passes repeat until no session
// can be placed, so a session that overlaps only one placed later still
// finds it. A simulated session knows where the robot was put down in the
// scenario's world; when both are simulated, the pose is compared with that
// truth and the difference printed (never used to place anything).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "app/cli_common.h"
#include "app/cli_project.h"
#include "core/common/checked_file.h"
#include "core/common/json_reader.h"
#include "core/pose/pose_estimator.h"
#include "core/registration/registration.h"
#include "core/session/session.h"
#include "hardware/station/project_align.h"

namespace sweepscan::app {

int SessionCloudOptionsFromArgs(const Args& args, hardware::SessionCloudOptions* options) {
  options->frames.skip_corrupt_records = !args.Flag("strict");
  if (args.Has("pose-source")) {
    if (!ParsePoseSource(args.Get("pose-source"), &options->pose_source) ||
        (options->pose_source != PoseSource::kEkf && options->pose_source != PoseSource::kOdometry)) {
      PrintError("--pose-source must be ekf or odometry, got '" + args.Get("pose-source") + "'");
      return kExitBadInput;
    }
  }
  return kExitOk;
}

const SessionClouds::Cloud* SessionClouds::Get(const ProjectSession& session, std::string* error) {
  auto it = clouds_.find(session.id);
  if (it != clouds_.end()) return &it->second;
  // A session that failed is not built again (align asks for each pair).
  if (auto f = failed_.find(session.id); f != failed_.end()) {
    *error = f->second;
    return nullptr;
  }
  Cloud cloud;
  std::cerr << "building the cloud of '" << session.id << "'...\n";
  const Status s =
      hardware::LoadSessionPositions(file_, session, options_, &cloud.info, &cloud.positions);
  if (!s.ok()) {
    *error = failed_[session.id] = s.message();
    return nullptr;
  }
  if (!cloud.info.damage.empty()) {
    std::cerr << "sweepscan-cli: warning: " << cloud.info.dir << ": " << cloud.info.damage << "\n";
  }
  return &clouds_.emplace(session.id, std::move(cloud)).first->second;
}

namespace {

std::string Mm(double m) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(1) << m * 1000.0 << " mm";
  return o.str();
}

std::string Deg(double rad, int digits = 3) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << rad * 180.0 / M_PI << " deg";
  return o.str();
}

Status LoadPairs(const std::string& path, std::vector<PointPair>* pairs) {
  nlohmann::json j;
  Status s = ReadJsonFile(path, &j);
  if (!s.ok()) return s;
  try {
    if (!j.is_object()) throw JsonError("expected a JSON object, got " + JsonTypeName(j));
    const JsonObject o(j, "");
    o.AllowOnly({"pairs"});
    const nlohmann::json& a = o.Array("pairs");
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string where = "pairs[" + std::to_string(i) + "]";
      if (!a[i].is_object()) throw JsonError(where + ": expected an object");
      const JsonObject p(a[i], where);
      p.AllowOnly({"source", "target"});
      PointPair pair;
      for (const char* key : {"source", "target"}) {
        const nlohmann::json& v = p.Array(key);
        if (v.size() != 3) p.Fail(key, "expected 3 numbers");
        Eigen::Vector3d x;
        for (int k = 0; k < 3; ++k) {
          if (!v[k].is_number()) p.Fail(key, "expected 3 numbers");
          x[k] = v[k].get<double>();
        }
        (std::string(key) == "source" ? pair.source : pair.target) = x;
      }
      pairs->push_back(pair);
    }
    // Fewer picks than a rigid pose needs; none at all fell back to the
    // planes without a word.
    if (pairs->size() < 3) {
      o.Fail("pairs", std::to_string(pairs->size()) +
                          " pair(s) given, at least 3 needed (points picked in both sessions)");
    }
  } catch (const JsonError& e) {
    return Status::Error(path + ": " + e.what());
  }
  return Status::Ok();
}

// The shared step (hardware/station/project_align.h) with the command's flags.
hardware::RegistrationAttempt Register(const Args& args, const std::vector<PointPair>& pairs,
                                       const std::string& reference,
                                       const std::vector<Eigen::Vector3f>& source,
                                       const std::vector<Eigen::Vector3f>& target) {
  hardware::SessionRegistrationOptions options;
  options.pairs = pairs;
  options.by_pairs = args.Has("pairs");
  options.hold_free = args.Flag("hold-free");
  options.icp = !args.Flag("no-icp");
  return hardware::RegisterSession(source, target, reference, options);
}

// What may differ between the session as this run started from it and as
// the file holds it now without invalidating the run's registration: its
// visibility and colour. Anything else (its folder, calibration, pose or
// evidence) and the registration was of other clouds or from another pose.
std::string ChangedSince(const ProjectSession& was, const ProjectSession& now) {
  if (was.path != now.path) return "its path is now '" + now.path + "'";
  const auto as_saved = [](const ProjectSession& s) {
    Project one;
    one.sessions = {s};
    one.sessions[0].visible = true;
    one.sessions[0].color.clear();
    return ProjectToJson(one);
  };
  ProjectSession a = was, b = now;
  a.project_from_session.reset(), b.project_from_session.reset();
  if (as_saved(a) != as_saved(b)) return "its calibration changed";
  if (as_saved(was) != as_saved(now)) {
    return now.project_from_session ? "it was placed again (" + now.registration.method + ")"
                                    : "its placement was removed";
  }
  return "";
}

// Puts this run's placements (`placed`, in the order made, from `ours`)
// onto `base`, the file as it is now: each only if its session and the one
// it was placed against are there as the run started from them (or that
// one's placement was applied too). `realigned`, placed again from
// `previous`, moves the sessions `base` has placed against it. Returns
// those moved; `unmerged` gets "ID\n  why" for each placement not applied.
std::vector<std::string> ApplyPlacements(const Project& started, const Project& ours,
                                         const std::vector<std::string>& placed,
                                         const std::string& realigned,
                                         const std::optional<Rigid3d>& previous, Project* base,
                                         std::vector<std::string>* unmerged) {
  std::vector<std::string> applied, moved;
  for (const std::string& id : placed) {
    const ProjectSession& mine = ours.sessions[ours.Find(id)];
    const std::string& reference = mine.registration.reference;
    const auto unchanged = [&](const std::string& which) -> std::string {
      const int now = base->Find(which);
      if (now < 0) return "'" + which + "' was removed from the project meanwhile";
      const std::string what =
          ChangedSince(started.sessions[started.Find(which)], base->sessions[now]);
      return what.empty() ? "" : "'" + which + "' was changed meanwhile: " + what;
    };
    std::string why = unchanged(id);
    if (why.empty() && std::find(applied.begin(), applied.end(), reference) == applied.end()) {
      why = std::find(placed.begin(), placed.end(), reference) != placed.end()
                ? "'" + reference + "', placed against in this run, was not saved either"
                : unchanged(reference);
    }
    if (!why.empty()) {
      unmerged->push_back(id + "\n  placed against '" + reference + "', not saved: " + why);
      continue;
    }
    ProjectSession& target = base->sessions[base->Find(id)];
    target.project_from_session = mine.project_from_session;
    target.registration = mine.registration;
    applied.push_back(id);
    if (id == realigned && previous) {
      moved = base->MoveDependants(id, *mine.project_from_session * previous->inverse());
    }
  }
  return moved;
}

}  // namespace

int RunProjectAlign(const Args& args) {
  const std::string file = args.positional()[0];
  Project project;
  std::string text_read;  // to tell at the end whether another program saved the file
  Status s = LoadProjectAndSay(file, &project, &text_read);
  if (!s.ok()) return (PrintError(s.message()), kExitBadInput);
  const Project started = project;
  hardware::SessionCloudOptions cloud_options;
  if (const int code = SessionCloudOptionsFromArgs(args, &cloud_options); code != kExitOk) return code;
  // Wheel slip warps each odometry cloud differently (a room turned by tens
  // of degrees), and ICP then fits one warped room into a look-alike one
  // with a sigma of a millimetre: a confident wrong placement.
  if (cloud_options.pose_source != PoseSource::kEkf) {
    PrintError(std::string("--pose-source ") + PoseSourceName(cloud_options.pose_source) +
               ": sessions are aligned with the EKF poses only, the default (odometry: the "
               "wheels alone bend a building's rooms, and a bent room fits a look-alike one)");
    return kExitBadInput;
  }
  if (project.Anchor() < 0) return (PrintError(file + ": no anchor session (add a session first)"), kExitBadInput);

  // Which sessions to place and against which.
  std::vector<std::string> unplaced;
  std::string realigned;  // --session
  std::optional<Rigid3d> previous_pose;
  RegistrationEvidence previous_evidence;
  if (args.Has("session")) {
    const int i = project.Find(args.Get("session"));
    if (i < 0) return (PrintError("no session '" + args.Get("session") + "' in " + file), kExitBadInput);
    if (i == project.Anchor()) return (PrintError("'" + args.Get("session") + "' is the anchor: it defines the frame"), kExitBadInput);
    // Placed again; if every attempt is refused it keeps what it had.
    realigned = args.Get("session");
    previous_pose = project.sessions[i].project_from_session;
    previous_evidence = project.sessions[i].registration;
    project.sessions[i].project_from_session.reset();
    unplaced.push_back(realigned);
  } else {
    for (const ProjectSession& ps : project.sessions) {
      if (!ps.project_from_session) unplaced.push_back(ps.id);
    }
  }
  if (args.Has("to") && project.Find(args.Get("to")) < 0) {
    return (PrintError("no session '" + args.Get("to") + "' in " + file), kExitBadInput);
  }
  if (args.Has("to") && !realigned.empty() && project.PlacedThrough(args.Get("to"), realigned)) {
    return (PrintError("'" + args.Get("to") + "' is placed against '" + realigned +
                       "' (or against a session placed against it): placing '" + realigned +
                       "' against it would move it along; align '" + args.Get("to") +
                       "' to another session first"),
            kExitBadInput);
  }
  std::vector<PointPair> pairs;
  if (args.Has("pairs")) {
    if (!args.Has("to") || unplaced.size() != 1) {
      PrintError("--pairs needs --session ID and --to ID: the picks belong to one pair of sessions");
      return kExitBadInput;
    }
    s = LoadPairs(args.Get("pairs"), &pairs);
    if (!s.ok()) return (PrintError(s.message()), kExitBadInput);
  }

  // Before the clouds are built and registered (minutes on a building),
  // not after: a read-only folder or a full disk fails now.
  if (s = CheckCanWrite(file); !s.ok()) return (PrintError(s.message()), kExitFailure);

  SessionClouds clouds(file, cloud_options);
  std::ostream& text = args.Flag("json") ? std::cerr : std::cout;  // stdout is the JSON's
  nlohmann::json report = nlohmann::json::array();
  std::map<std::string, std::string> refusals;
  // Registrations that failed, by (session, reference): a later pass, run
  // because another session was placed meanwhile, would only repeat them
  // (a registration is between the two clouds in their own frames, which
  // placing others does not change), each possibly minutes long.
  std::map<std::pair<std::string, std::string>, std::string> failed;
  std::vector<std::string> placed_here;  // in the order placed
  bool progress = true;
  while (progress && !unplaced.empty()) {
    progress = false;
    for (auto it = unplaced.begin(); it != unplaced.end();) {
      ProjectSession& ps = project.sessions[project.Find(*it)];
      std::string error;
      const SessionClouds::Cloud* src = clouds.Get(ps, &error);
      if (src == nullptr) {
        // One unreadable session costs its own placement, not the others'
        // (each of which may have taken minutes).
        refusals[ps.id] = "\n  its cloud cannot be built: " + error;
        ++it;
        continue;
      }
      const std::vector<Eigen::Vector3f>& source = src->positions;
      std::optional<hardware::RegistrationAttempt> best;
      std::string reasons;
      for (const ProjectSession& ref : project.sessions) {
        if (!ref.project_from_session || ref.id == ps.id) continue;
        if (args.Has("to") && ref.id != args.Get("to")) continue;
        // A session placed against this one would move with it
        // (MoveDependants) and the two would refer to each other.
        if (project.PlacedThrough(ref.id, ps.id)) continue;
        const SessionClouds::Cloud* tgt = clouds.Get(ref, &error);
        if (tgt == nullptr) {
          reasons += "\n  against '" + ref.id + "': its cloud cannot be built: " + error;
          continue;
        }
        const auto pair = std::make_pair(ps.id, ref.id);
        if (const auto f = failed.find(pair); f != failed.end()) {
          reasons += "\n  against '" + ref.id + "': " + f->second;
          continue;
        }
        std::cerr << "aligning '" << ps.id << "' to '" << ref.id << "'...\n";
        hardware::RegistrationAttempt a = Register(args, pairs, ref.id, source, tgt->positions);
        if (!a.status.ok()) {
          failed[pair] = a.status.message();
          reasons += "\n  against '" + ref.id + "': " + a.status.message();
          continue;
        }
        if (!best || a.fine.overlap > best->fine.overlap) best = std::move(a);
      }
      if (!best) {
        refusals[ps.id] = reasons.empty() ? "\n  no placed session to align it to" : reasons;
        ++it;
        continue;
      }
      const ProjectSession& ref = project.sessions[project.Find(best->reference)];
      ps.project_from_session = *ref.project_from_session * best->fine.target_from_source;
      ps.registration = hardware::EvidenceOf(*best, pairs);
      ps.registration.pose_source = PoseSourceName(cloud_options.pose_source);
      placed_here.push_back(ps.id);
      refusals.erase(ps.id);  // a pass before could not place it yet
      const RegistrationResult& r = best->fine;
      nlohmann::json j = {{"session", ps.id}, {"reference", ref.id}, {"method", best->method},
                          {"rms_m", r.rms_m}, {"overlap", r.overlap}, {"iterations", r.iterations},
                          {"sigma_translation_m", r.TranslationSigmaM()},
                          {"sigma_rotation_deg", r.RotationSigmaDeg()},
                          {"eigenvalues", {r.eigenvalues[0], r.eigenvalues[1], r.eigenvalues[2], r.eigenvalues[3],
                                           r.eigenvalues[4], r.eigenvalues[5]}}};
      text << "placed '" << ps.id << "' against '" << ref.id << "' (" << best->method << "): rms "
                << Mm(r.rms_m) << ", overlap " << std::lround(r.overlap * 100) << " %, 1-sigma "
                << Mm(r.TranslationSigmaM()) << " / " << std::setprecision(3) << r.RotationSigmaDeg() << " deg\n";
      if (r.degenerate) {
        text << "  free direction (" << r.free_direction.transpose()
                  << "): held at the coarse pose, not measured\n";
        j["free_direction"] = {r.free_direction.x(), r.free_direction.y(), r.free_direction.z()};
      }
      const SessionClouds::Cloud* tgt = clouds.Get(ref, &error);
      if (src->info.has_true_start && tgt != nullptr && tgt->info.has_true_start) {
        const Rigid3d truth =
            tgt->info.world_from_session_truth.inverse() * src->info.world_from_session_truth;
        const Rigid3d diff = truth.inverse() * r.target_from_source;
        const double dt = diff.translation().norm();
        const double dr = Eigen::AngleAxisd(diff.rotation()).angle();
        text << "  against the simulation's truth: " << Mm(dt) << ", " << Deg(dr) << "\n";
        j["truth_error_m"] = dt;
        j["truth_error_deg"] = dr * 180.0 / M_PI;
      }
      report.push_back(j);
      it = unplaced.erase(it);
      progress = true;
    }
  }
  if (!realigned.empty()) {
    ProjectSession& ps = project.sessions[project.Find(realigned)];
    if (!ps.project_from_session) {
      ps.project_from_session = previous_pose;
      ps.registration = previous_evidence;
      if (previous_pose) text << "'" << realigned << "' keeps its placement\n";
    }
  }
  // Another program may have saved the file meanwhile (`project add`, the
  // app): this run's placements go onto what is there now.
  std::string text_now;
  Project base;
  std::vector<std::string> unmerged;
  if (!ReadProjectFile(file, &text_now) || text_now != text_read) {
    std::vector<std::string> repairs;  // said when it was read first
    s = ProjectFromJson(text_now, file, &base, &repairs);
    if (!s.ok()) {
      PrintError(file + " was changed by another program while aligning and cannot be read now (" +
                 s.message() + "); this run's placements are not saved");
      return kExitFailure;
    }
    text << file << " was changed by another program while aligning: its changes are kept\n";
  } else {
    base = started;
  }
  const std::vector<std::string> moved =
      ApplyPlacements(started, project, placed_here, realigned, previous_pose, &base, &unmerged);
  for (const std::string& id : moved) {
    text << "moved '" << id << "' with '" << realigned << "' (placed against it)\n";
  }
  s = SaveProject(file, base);
  if (!s.ok()) return (PrintError(s.message()), kExitFailure);
  for (const std::string& why : unmerged) {
    const std::string id = why.substr(0, why.find('\n'));
    refusals[id] = why.substr(id.size());
    if (std::find(unplaced.begin(), unplaced.end(), id) == unplaced.end()) unplaced.push_back(id);
  }
  if (args.Flag("json")) {
    nlohmann::json refused = nlohmann::json::object();
    for (const auto& [id, why] : refusals) refused[id] = why.substr(1);
    nlohmann::json saved = nlohmann::json::array();
    for (const nlohmann::json& j : report) {
      if (refusals.count(j["session"].get<std::string>()) == 0) saved.push_back(j);
    }
    report = saved;
    std::cout << nlohmann::json{{"placed", report}, {"refused", refused}, {"moved", moved}}.dump(2)
              << "\n";
  }
  if (!unplaced.empty()) {
    std::string message = "could not place:";
    for (const auto& [id, why] : refusals) message += "\n'" + id + "':" + why;
    PrintError(message);
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace sweepscan::app
