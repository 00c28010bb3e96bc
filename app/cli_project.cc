// sweepscan-cli project: a building as many sessions in one frame
// (core/project/project.h, docs/project-format.md). This file parses the
// subcommands and edits the project file; cli_project_align.cc registers
// sessions and cli_project_export.cc writes the project's cloud.
#include "app/cli_project.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "app/cli_args.h"
#include "app/cli_common.h"
#include "core/calibration/calibration_file.h"
#include "core/common/checked_file.h"
#include "core/project/project.h"
#include "core/session/session.h"

namespace sweepscan::app {

namespace fs = std::filesystem;

const char* const kProjectUsage =
    "usage: sweepscan-cli project <subcommand> PROJECT.sweepscan-project [options]\n"
    "\n"
    "A project is a building scanned in several sessions (drives), each placed in\n"
    "one frame by registration (docs/project-format.md, docs/registration.md). The\n"
    "first session added is the anchor: the project's frame is its start pose\n"
    "(`project anchor` makes another session the anchor).\n"
    "\n"
    "Subcommands:\n"
    "  new PROJECT [SESSION...] [--name N] [--description D] [--calibration FILE]\n"
    "                     create a project file (refuses to overwrite one)\n"
    "  add PROJECT SESSION... [--calibration FILE]\n"
    "                     add session folders (unplaced until aligned)\n"
    "  remove PROJECT ID  take a session out (its folder is left alone)\n"
    "  anchor PROJECT ID  make a placed session the anchor: the project's frame\n"
    "                     becomes its start pose, every placement is re-expressed\n"
    "                     in it (the building stays as it is), and the placements\n"
    "                     between it and the old anchor are turned round, each\n"
    "                     with its measurement (covariance, pairs) inverted\n"
    "  info PROJECT       the sessions, their poses and how each was found\n"
    "  align PROJECT [--session ID] [--to ID] [--pairs FILE] [--no-icp] [--hold-free]\n"
    "                     place unplaced sessions (or --session ID again) against\n"
    "                     placed ones: planes (or the picked --pairs) then\n"
    "                     point-to-plane ICP. Overlap that leaves a direction free\n"
    "                     (a bare corridor) is refused; pick pairs across it and\n"
    "                     add --hold-free: ICP then keeps the pairs' position along\n"
    "                     that direction and the project records it as free.\n"
    "                     A session whose cloud cannot be built is reported and the\n"
    "                     others are still placed and saved (exit 1); a session is\n"
    "                     never placed against one placed against it. Clouds are\n"
    "                     built with the EKF poses (wheels alone bend a building's\n"
    "                     rooms). What another program saved to PROJECT meanwhile\n"
    "                     is kept: the placements are applied onto it, and one\n"
    "                     whose session changed there is refused (exit 1)\n"
    "  export PROJECT --out FILE.las|FILE.ply|FILE.pcd [--sessions ID,ID] [--pose-source S]\n"
    "                     the placed, visible sessions' clouds in the project frame;\n"
    "                     every format is streamed one session at a time; LAS\n"
    "                     gives each its own Point Source ID. On a terminal\n"
    "                     (and without --json) the progress is shown on stderr\n"
    "\n"
    "Options:\n"
    "  --json             machine-readable output on stdout\n"
    "  --strict           refuse sessions with damaged records (default: skip them)\n"
    "\n"
    "--pairs FILE: {\"pairs\": [{\"source\": [x, y, z], \"target\": [x, y, z]}, ...]},\n"
    "three or more points picked in the session (source) and in --to (target),\n"
    "each in its own session's frame (metres).\n";

Status LoadProjectAndSay(const std::string& file, Project* project, std::string* text) {
  std::string bytes;
  if (!ReadProjectFile(file, &bytes)) return LoadProject(file, project);  // says why
  std::vector<std::string> repairs;
  const Status s = ProjectFromJson(bytes, file, project, &repairs);
  for (const std::string& r : repairs)
    std::cerr << "sweepscan-cli: warning: " << file << ": " << r << "\n";
  if (text != nullptr) *text = std::move(bytes);
  return s;
}

bool ReadProjectFile(const std::string& file, std::string* text) {
  // A folder opens as a stream and throws on its first read; LoadProject
  // then says what it is.
  if (!CheckRegularFile(file).ok()) return false;
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  text->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

Status CheckSessionFolder(const std::string& project_file, const std::string& path,
                          std::string* recorded_utc) {
  ProjectSession probe;
  probe.path = path;
  const std::string dir = ResolveSessionPath(project_file, probe);
  // Without exceptions: a folder that cannot be looked at (no permission
  // on the way, a name too long) is said, not "an unexpected failure".
  std::error_code error;
  const bool folder = fs::is_directory(dir, error);
  if (error && error != std::errc::no_such_file_or_directory &&
      error != std::errc::not_a_directory)
    return Status::Error(path + ": cannot be looked at: " + error.message());
  if (!folder) {
    return Status::Error(path +
                         ": not a session folder (paths are relative to the project's folder)");
  }
  // The app's words (ProjectController::AddSession): any folder is not a
  // session, and an empty one would only fail later, at align or export.
  if (!fs::exists(fs::path(dir) / kSessionMetaFile, error)) {
    return Status::Error(path + ": not a session folder (no " + kSessionMetaFile + ")");
  }
  // A meta.json that does not read would fail only later, at align or
  // export, with the project already written around it.
  SessionMeta meta;
  const Status s = ReadSessionMeta((fs::path(dir) / kSessionMetaFile).string(), &meta);
  if (recorded_utc != nullptr) *recorded_utc = meta.created_utc;
  return s;
}

namespace {

// How a session's path is kept, as the app keeps it
// (ProjectDocument::StoredPath): relative to the project's folder, so that
// the project and its sessions move together. A path typed relative is
// that already; one typed absolute is made so.
std::string StoredSessionPath(const std::string& project_file, const std::string& typed) {
  const fs::path path(typed);
  if (!path.is_absolute()) return typed;
  std::error_code error;
  fs::path folder = fs::absolute(ProjectDirectory(project_file), error).lexically_normal();
  if (error) return typed;
  if (!folder.has_filename()) folder = folder.parent_path();  // "/site/." is "/site/"
  const fs::path relative = path.lexically_normal().lexically_relative(folder);
  return relative.empty() ? typed : relative.string();
}

int Fail(int code, const std::string& message) {
  PrintError(message);
  return code;
}

std::string Fixed(double v, int digits) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

int RunNew(const Args& args) {
  const std::vector<std::string>& pos = args.positional();
  const std::string file = pos[0];
  std::error_code error;
  if (fs::exists(file, error))
    return Fail(kExitBadInput, file + ": exists already (use `project add` to extend it)");
  if (error && error != std::errc::no_such_file_or_directory &&
      error != std::errc::not_a_directory)
    return Fail(kExitFailure, file + ": cannot be looked at: " + error.message());
  Project project;
  project.name = args.Get("name", fs::path(file).stem().string());
  project.description = args.Get("description");
  for (const char* key : {"name", "description"}) {
    if (!IsUtf8Text(args.Get(key)))
      return Fail(kExitBadInput, std::string("--") + key +
                                     ": not UTF-8 text, which a project file (JSON) holds");
  }
  // As `add`: the sessions must be there, and take --calibration.
  std::optional<MountingError> calibration;
  if (args.Has("calibration")) {
    MountingError m;
    const Status c = LoadCalibrationFile(args.Get("calibration"), &m);
    if (!c.ok()) return Fail(kExitBadInput, c.message());
    calibration = m;
  }
  for (size_t i = 1; i < pos.size(); ++i) {
    std::string recorded;
    if (const Status folder = CheckSessionFolder(file, pos[i], &recorded); !folder.ok())
      return Fail(kExitBadInput, folder.message());
    ProjectSession* added = nullptr;
    const Status s = project.AddSession(StoredSessionPath(file, pos[i]), &added, file);
    if (!s.ok()) return Fail(kExitBadInput, s.message());
    added->recorded_utc = recorded;
    added->calibration = calibration;
  }
  const Status s = SaveProject(file, project);
  if (!s.ok()) return Fail(kExitFailure, s.message());
  if (args.Flag("json")) {
    std::cout << nlohmann::json{{"project", file}, {"sessions", project.sessions.size()}}.dump(2) << "\n";
  } else {
    std::cout << "created " << file << " with " << project.sessions.size() << " session(s)\n";
  }
  return kExitOk;
}

// Loads `file`, applies `edit` and saves, unless another program saved the
// file in between (`project align` in another terminal, the app): the edit
// is then made again on what that program wrote, so that neither loses the
// other's work. `edit` returns an exit code after its message.
int EditProject(const std::string& file, const std::function<int(Project*)>& edit) {
  for (int attempt = 0;; ++attempt) {
    Project project;
    std::string text;
    Status s = LoadProjectAndSay(file, &project, &text);
    if (!s.ok()) return Fail(kExitBadInput, s.message());
    std::ostringstream said;
    std::streambuf* const cerr = std::cerr.rdbuf(said.rdbuf());
    const std::string before = ProjectToJson(project);
    const int code = edit(&project);
    std::cerr.rdbuf(cerr);
    std::string now;
    if (code == kExitOk && attempt < 5 && ReadProjectFile(file, &now) && now != text) continue;
    std::cerr << said.str();
    if (code != kExitOk) return code;
    // Nothing changed (the anchor made the anchor): the file, perhaps
    // written by hand, is left as it is.
    if (ProjectToJson(project) == before) return kExitOk;
    s = SaveProject(file, project);
    if (!s.ok()) return Fail(kExitFailure, s.message());
    return kExitOk;
  }
}

int RunAdd(const Args& args) {
  const std::vector<std::string>& pos = args.positional();
  if (pos.size() < 2)
    return Fail(kExitBadInput, "project add needs PROJECT and at least one SESSION");
  std::optional<MountingError> calibration;
  if (args.Has("calibration")) {
    MountingError m;
    const Status s = LoadCalibrationFile(args.Get("calibration"), &m);
    if (!s.ok()) return Fail(kExitBadInput, s.message());
    calibration = m;
  }
  return EditProject(pos[0], [&](Project* project) {
    for (size_t i = 1; i < pos.size(); ++i) {
      std::string recorded;
      if (const Status folder = CheckSessionFolder(pos[0], pos[i], &recorded); !folder.ok())
        return Fail(kExitBadInput, folder.message());
      ProjectSession* added = nullptr;
      const Status s = project->AddSession(StoredSessionPath(pos[0], pos[i]), &added, pos[0]);
      if (!s.ok()) return Fail(kExitBadInput, s.message());
      added->recorded_utc = recorded;
      added->calibration = calibration;
      std::cerr << "added '" << added->id << "'"
                << (added->project_from_session ? " as the anchor" : ", not placed yet") << "\n";
    }
    return kExitOk;
  });
}

int RunRemove(const Args& args) {
  const std::vector<std::string>& pos = args.positional();
  if (pos.size() != 2) return Fail(kExitBadInput, "project remove needs PROJECT and one session ID");
  return EditProject(pos[0], [&](Project* project) {
    std::string anchor;
    const Status s = project->RemoveSession(pos[1], &anchor);
    if (!s.ok()) return Fail(kExitBadInput, s.message());
    if (!anchor.empty()) {
      std::cerr << "'" << anchor << "' is the anchor now: the project's frame is its start pose\n";
    }
    return kExitOk;
  });
}

int RunAnchor(const Args& args) {
  const std::vector<std::string>& pos = args.positional();
  if (pos.size() != 2)
    return Fail(kExitBadInput, "project anchor needs PROJECT and one session ID");
  // Said before anything is changed, as `align` does.
  if (const Status w = CheckCanWrite(pos[0]); !w.ok()) return Fail(kExitFailure, w.message());
  nlohmann::json out;
  const int code = EditProject(pos[0], [&](Project* project) {
    Project::AnchorChange change;
    const int was = project->Anchor();
    const Status s = project->ChangeAnchor(pos[1], &change);
    if (!s.ok()) return Fail(kExitBadInput, s.message());
    const std::string& id = pos[1];
    out = {{"project", pos[0]},
           {"anchor", id},
           {"changed", was != project->Find(id)},
           {"old_anchor", change.old_anchor},
           {"old_anchor_placed", nullptr},
           {"reversed", change.reversed}};
    if (was == project->Find(id)) {
      std::cerr << "'" << id << "' is the anchor already; nothing changed\n";
      return kExitOk;
    }
    size_t placed = 0;
    for (const ProjectSession& ps : project->sessions) placed += ps.project_from_session ? 1 : 0;
    std::cerr << "'" << id << "' is the anchor now: the project's frame is its start pose";
    if (placed > 1) std::cerr << "; " << placed - 1 << " placement(s) re-expressed in it";
    std::cerr << "\n";
    std::string from = id;
    for (const std::string& r : change.reversed) {
      std::cerr << "turned round: '" << r << "' is placed against '" << from
                << "' by the same measurement, inverted\n";
      from = r;
    }
    if (!change.old_anchor.empty()) {
      const ProjectSession& old = project->sessions[project->Find(change.old_anchor)];
      out["old_anchor_placed"] = old.project_from_session.has_value();
      if (change.old_anchor_unplaced) {
        std::cerr << "'" << old.id << "', the old anchor, is not placed now (nothing else was)\n";
      } else if (old.registration.method == "manual") {
        std::cerr << "'" << old.id << "', the old anchor, is held where it is by hand (manual): '"
                  << id << "' rests on a placement by hand, not on it\n";
      }
    }
    return kExitOk;
  });
  if (code == kExitOk && args.Flag("json")) std::cout << out.dump(2) << "\n";
  return code;
}

int RunProjectInfo(const Args& args) {
  const std::string file = args.positional()[0];
  Project project;
  const Status s = LoadProjectAndSay(file, &project);
  if (!s.ok()) return Fail(kExitBadInput, s.message());
  nlohmann::json sessions = nlohmann::json::array();
  std::ostringstream text;
  text << "project '" << project.name << "' (" << file << "): " << project.sessions.size() << " session(s)\n";
  if (!project.description.empty()) text << "  " << project.description << "\n";
  for (const ProjectSession& ps : project.sessions) {
    const std::string dir = ResolveSessionPath(file, ps);
    std::error_code error;  // cannot be looked at: shown as missing
    const bool present = fs::is_directory(dir, error);
    nlohmann::json j = {{"id", ps.id}, {"path", ps.path}, {"present", present}, {"visible", ps.visible},
                        {"placed", ps.project_from_session.has_value()}};
    text << "  " << ps.id << "  " << ps.path << (present ? "" : "  [MISSING]") << (ps.visible ? "" : "  [hidden]");
    if (!ps.project_from_session) {
      text << "\n      not placed (sweepscan-cli project align)\n";
      sessions.push_back(j);
      continue;
    }
    const RegistrationEvidence& e = ps.registration;
    const Rigid3d& t = *ps.project_from_session;
    // Eigen's eulerAngles keeps its first angle in [0, pi]: -90 deg came out as 90.
    const double yaw_deg = YawFromQuaternion(t.rotation()) * 180.0 / M_PI;
    text << "\n      at x " << Fixed(t.translation().x(), 3) << " y " << Fixed(t.translation().y(), 3) << " z "
         << Fixed(t.translation().z(), 3) << " m, yaw " << Fixed(yaw_deg, 2) << " deg; " << e.method;
    if (!e.reference.empty()) text << " against '" << e.reference << "'";
    j["translation_m"] = {t.translation().x(), t.translation().y(), t.translation().z()};
    j["yaw_deg"] = yaw_deg;
    j["method"] = e.method;
    j["reference"] = e.reference;
    if (e.method == "manual") {
      // Typed in (or a reference dropped): its zero covariance means
      // unknown, not a perfect fit.
      text << ": not measured";
      j["pose_source"] = nullptr;
    } else if (e.method != "anchor") {
      text << ": rms " << Fixed(e.rms_m * 1000, 1) << " mm, overlap " << Fixed(e.overlap * 100, 0)
           << " %, 1-sigma " << Fixed(e.SigmaTranslation() * 1000, 2) << " mm / "
           << Fixed(e.SigmaRotation() * 180 / M_PI, 4) << " deg, " << e.pose_source << " poses";
      j["pose_source"] = e.pose_source;
      if (!e.free_direction.isZero()) {
        // Stored in the reference's frame; shown in the project's.
        const int r = project.Find(e.reference);
        const Eigen::Vector3d d =
            r >= 0 && project.sessions[r].project_from_session
                ? Eigen::Vector3d(project.sessions[r].project_from_session->rotation() *
                                  e.free_direction)
                : e.free_direction;
        text << "; FREE along (" << Fixed(d.x(), 2) << ", " << Fixed(d.y(), 2) << ", "
             << Fixed(d.z(), 2) << ") in the project's frame";
        j["free_direction"] = {d.x(), d.y(), d.z()};
      }
      j["rms_m"] = e.rms_m;
      j["overlap"] = e.overlap;
      j["sigma_translation_m"] = e.SigmaTranslation();
      j["sigma_rotation_deg"] = e.SigmaRotation() * 180 / M_PI;
      j["pairs"] = e.pairs.size();
    }
    text << "\n";
    sessions.push_back(j);
  }
  if (args.Flag("json")) {
    std::cout << nlohmann::json{{"project", file}, {"name", project.name}, {"sessions", sessions}}.dump(2) << "\n";
  } else {
    std::cout << text.str();
  }
  return kExitOk;
}

}  // namespace

int RunProject(int argc, char** argv) {
  if (argc < 3) {
    // A usage error says so on stderr, as every other one does.
    return Fail(kExitBadInput, SeeHelp("project needs a subcommand", "project"));
  }
  if (std::string(argv[2]) == "--help" || std::string(argv[2]) == "-h") {
    std::cout << kProjectUsage;
    return kExitOk;
  }
  const std::string sub = argv[2];
  Args args({"json", "strict", "no-icp", "hold-free", "help"},
            {"name", "description", "calibration", "session", "to", "pairs", "pose-source", "out", "sessions"});
  std::string error;
  if (!args.Parse(argc, argv, 3, &error)) return Fail(kExitBadInput, SeeHelp(error, "project"));
  if (args.Flag("help")) {
    std::cout << kProjectUsage;
    return kExitOk;
  }
  if (args.positional().empty()) return Fail(kExitBadInput, "project " + sub + " needs a PROJECT file");
  // The subcommands share one parser; an option another subcommand takes is
  // refused, not ignored (`project new ... --out x.las` did nothing).
  static const std::map<std::string, std::set<std::string>> kTakes = {
      {"new", {"name", "description", "calibration", "json"}},
      {"add", {"calibration", "json"}},
      {"remove", {"json"}},
      {"anchor", {"json"}},
      {"info", {"json"}},
      {"align", {"session", "to", "pairs", "no-icp", "hold-free", "pose-source", "strict", "json"}},
      {"export", {"out", "sessions", "pose-source", "strict", "json"}},
  };
  if (const auto takes = kTakes.find(sub); takes != kTakes.end()) {
    std::set<std::string> others;
    for (const std::string& key : args.given()) {
      if (takes->second.count(key) == 0) others.insert(key);
    }
    if (const int code = RefuseOptions(args, others, "`project " + sub + "`"); code != kExitOk)
      return code;
  }
  // Those that take one PROJECT: a second word was ignored (`project align
  // P building_c` aligned every session, not building_c).
  static const std::map<std::string, std::string> kOneFile = {
      {"info", ""},
      {"align", " (one session: --session ID)"},
      {"export", " (some sessions: --sessions ID,ID)"},
  };
  if (const auto one = kOneFile.find(sub); one != kOneFile.end() && args.positional().size() > 1) {
    return Fail(kExitBadInput,
                "unexpected argument '" + args.positional()[1] + "': project " + sub +
                    " takes one PROJECT file" + one->second);
  }
  if (sub == "new") return RunNew(args);
  if (sub == "add") return RunAdd(args);
  if (sub == "remove") return RunRemove(args);
  if (sub == "anchor") return RunAnchor(args);
  if (sub == "info") return RunProjectInfo(args);
  if (sub == "align") return RunProjectAlign(args);
  if (sub == "export") return RunProjectExport(args);
  return Fail(kExitBadInput, SeeHelp("unknown project subcommand '" + sub + "'", "project"));
}

}  // namespace sweepscan::app
