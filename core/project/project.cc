#include "core/project/project.h"

#include <Eigen/Eigenvalues>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "core/common/json_reader.h"

namespace sweepscan {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "sweepscan-project";

// Largest eigenvalue's square root of a symmetric 3x3 block of the 6x6
// covariance starting at (k, k): the 1-sigma along the worst direction.
double WorstSigma(const std::array<double, 36>& c, int k) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) m(r, col) = c[(k + r) * 6 + k + col];
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (m + m.transpose()));
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

template <int N>
Eigen::Matrix<double, N, 1> Numbers(const JsonObject& o, const std::string& key) {
  const json& a = o.Array(key);
  if (a.size() != N) {
    o.Fail(key, "expected " + std::to_string(N) + " numbers, got " + std::to_string(a.size()));
  }
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i) {
    if (!a[i].is_number()) {
      o.Fail(key + "[" + std::to_string(i) + "]", "expected a number, got " + JsonTypeName(a[i]));
    }
    v[i] = a[i].get<double>();
  }
  return v;
}

json Numbers(const double* v, int n) {
  json a = json::array();
  for (int i = 0; i < n; ++i) a.push_back(v[i]);
  return a;
}

bool IsColor(const std::string& c) {
  if (c.size() != 7 || c[0] != '#') return false;
  for (size_t i = 1; i < 7; ++i) {
    if (!std::isxdigit(static_cast<unsigned char>(c[i]))) return false;
  }
  return true;
}

Rigid3d ReadPose(const JsonObject& o) {
  o.AllowOnly({"translation_m", "rotation_wxyz"});
  const Eigen::Vector3d t = Numbers<3>(o, "translation_m");
  const Eigen::Vector4d q = Numbers<4>(o, "rotation_wxyz");
  // A hand-edited file keeps a few digits; anything further from unit
  // length is not a rotation someone meant.
  if (std::abs(q.norm() - 1.0) > 1e-6) {
    o.Fail("rotation_wxyz", "must be a unit quaternion, |q| = " + std::to_string(q.norm()));
  }
  return Rigid3d(t, Eigen::Quaterniond(q[0], q[1], q[2], q[3]));
}

RegistrationEvidence ReadEvidence(const JsonObject& o) {
  o.AllowOnly({"method", "reference", "rms_m", "overlap", "correspondences", "iterations",
               "covariance", "free_direction", "pairs", "time_utc"});
  static const std::set<std::string> kMethods = {"anchor", "manual", "pairs", "planes",
                                                 "planes+icp", "pairs+icp", "icp"};
  RegistrationEvidence e;
  e.method = o.String("method");
  if (!kMethods.count(e.method)) {
    o.Fail("method", "unknown method '" + e.method +
                         "' (anchor, manual, pairs, planes, planes+icp, pairs+icp, icp)");
  }
  e.reference = o.String("reference", "");
  e.rms_m = o.NonNegative("rms_m", 0.0);
  e.overlap = o.InRange("overlap", 0.0, 1.0, 0.0);
  const int64_t correspondences = o.Has("correspondences") ? o.Integer("correspondences") : 0;
  if (correspondences < 0)
    o.Fail("correspondences", "must be >= 0, got " + std::to_string(correspondences));
  e.correspondences = static_cast<uint64_t>(correspondences);
  const int64_t iterations = o.Has("iterations") ? o.Integer("iterations") : 0;
  if (iterations < 0 || iterations > 1000000) {
    o.Fail("iterations", "must be within 0..1000000, got " + std::to_string(iterations));
  }
  e.iterations = static_cast<int>(iterations);
  if (o.Has("covariance")) {
    const Eigen::Matrix<double, 36, 1> c = Numbers<36>(o, "covariance");
    for (int i = 0; i < 36; ++i) e.covariance[i] = c[i];
  }
  if (o.Has("free_direction")) {
    e.free_direction = Numbers<3>(o, "free_direction");
    if (std::abs(e.free_direction.norm() - 1.0) > 1e-6) {
      o.Fail("free_direction",
             "must be a unit vector, |d| = " + std::to_string(e.free_direction.norm()));
    }
  }
  if (o.Has("pairs")) {
    const json& pairs = o.Array("pairs");
    for (size_t i = 0; i < pairs.size(); ++i) {
      const JsonObject p(pairs[i], o.Path("pairs") + "[" + std::to_string(i) + "]");
      p.AllowOnly({"source", "target"});
      e.pairs.push_back({Numbers<3>(p, "source"), Numbers<3>(p, "target")});
    }
  }
  e.time_utc = o.String("time_utc", "");
  return e;
}

ProjectSession ReadSession(const JsonObject& o) {
  o.AllowOnly({"id", "path", "calibration", "project_from_session", "registration", "visible",
               "color"});
  ProjectSession s;
  s.id = o.String("id");
  if (s.id.empty()) o.Fail("id", "must not be empty");
  s.path = o.String("path");
  if (s.path.empty()) o.Fail("path", "must not be empty");
  if (o.Has("calibration")) {
    const JsonObject c = o.Object("calibration");
    c.AllowOnly({"alpha_rad", "beta_rad", "gamma_rad"});
    MountingError m;
    m.alpha = c.InRange("alpha_rad", -0.5, 0.5, 0.0);
    m.beta = c.InRange("beta_rad", -0.5, 0.5, 0.0);
    m.gamma = c.InRange("gamma_rad", -0.5, 0.5, 0.0);
    s.calibration = m;
  }
  if (o.Has("project_from_session")) s.project_from_session = ReadPose(o.Object("project_from_session"));
  if (o.Has("registration")) s.registration = ReadEvidence(o.Object("registration"));
  if (s.project_from_session && s.registration.method.empty()) {
    o.Fail("registration", "missing: a placed session says how it was placed");
  }
  if (!s.project_from_session && !s.registration.method.empty()) {
    o.Fail("project_from_session", "missing: the registration has no pose");
  }
  if (s.registration.method == "anchor") {
    // The anchor's frame is the project's: its pose is the identity, and it
    // was aligned to nothing.
    const Rigid3d& t = *s.project_from_session;
    if (t.translation().norm() > 1e-9 ||
        t.rotation().angularDistance(Eigen::Quaterniond::Identity()) > 1e-9) {
      o.Fail("project_from_session",
             "the anchor defines the project's frame: its pose must be the identity");
    }
    if (!s.registration.reference.empty())
      o.Fail("registration.reference", "the anchor is aligned to nothing");
  }
  s.visible = o.Bool("visible", true);
  s.color = o.String("color", s.color);
  if (!IsColor(s.color)) o.Fail("color", "expected #rrggbb, got '" + s.color + "'");
  return s;
}

json EvidenceJson(const RegistrationEvidence& e) {
  json j = {{"method", e.method}};
  if (!e.reference.empty()) j["reference"] = e.reference;
  if (e.method == "anchor") return j;
  j["rms_m"] = e.rms_m;
  j["overlap"] = e.overlap;
  j["correspondences"] = e.correspondences;
  j["iterations"] = e.iterations;
  j["covariance"] = Numbers(e.covariance.data(), 36);
  if (!e.free_direction.isZero()) j["free_direction"] = Numbers(e.free_direction.data(), 3);
  if (!e.pairs.empty()) {
    json pairs = json::array();
    for (const PickedPair& p : e.pairs) {
      pairs.push_back({{"source", Numbers(p.source.data(), 3)}, {"target", Numbers(p.target.data(), 3)}});
    }
    j["pairs"] = pairs;
  }
  if (!e.time_utc.empty()) j["time_utc"] = e.time_utc;
  return j;
}

}  // namespace

double RegistrationEvidence::SigmaRotation() const { return WorstSigma(covariance, 0); }
double RegistrationEvidence::SigmaTranslation() const { return WorstSigma(covariance, 3); }

int Project::Find(const std::string& id) const {
  for (size_t i = 0; i < sessions.size(); ++i) {
    if (sessions[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

int Project::Anchor() const {
  for (size_t i = 0; i < sessions.size(); ++i) {
    if (sessions[i].registration.method == "anchor") return static_cast<int>(i);
  }
  return -1;
}

std::string SessionColor(size_t index) {
  static const char* const kTableau10[] = {"#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f",
                                           "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#bab0ac"};
  return kTableau10[index % 10];
}

Status Project::AddSession(const std::string& path, ProjectSession** added) {
  const auto normal = [](const std::string& p) {
    return fs::path(p).lexically_normal().string();
  };
  for (const ProjectSession& s : sessions) {
    if (normal(s.path) == normal(path)) {
      return Status::Error(path + ": already in the project as '" + s.id + "'");
    }
  }
  fs::path p = fs::path(path).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // "room.sweepscan/"
  std::string base = p.filename().string();
  const std::string suffix = ".sweepscan";
  if (base.size() > suffix.size() && base.compare(base.size() - suffix.size(), suffix.size(), suffix) == 0) {
    base.resize(base.size() - suffix.size());
  }
  if (base.empty()) base = "session";
  std::string id = base;
  for (int n = 2; Find(id) >= 0; ++n) id = base + "-" + std::to_string(n);
  ProjectSession s;
  s.id = id;
  s.path = path;
  s.color = SessionColor(sessions.size());
  if (Anchor() < 0) {
    s.project_from_session = Rigid3d::Identity();
    s.registration.method = "anchor";
  }
  sessions.push_back(s);
  if (added != nullptr) *added = &sessions.back();
  return Status::Ok();
}

Status Project::RemoveSession(const std::string& id) {
  const int i = Find(id);
  if (i < 0) return Status::Error("no session '" + id + "' in the project");
  if (sessions[i].registration.method == "anchor") {
    for (size_t k = 0; k < sessions.size(); ++k) {
      if (static_cast<int>(k) != i && sessions[k].project_from_session) {
        return Status::Error("'" + id + "' is the anchor other sessions are placed against; remove them first");
      }
    }
  }
  // A session placed against this one names it as its reference (the
  // evidence of its pose); the file would then refer to a session it no
  // longer holds, which the loader refuses.
  std::string dependants;
  for (const ProjectSession& s : sessions) {
    if (s.id != id && s.registration.reference == id) {
      dependants += (dependants.empty() ? "'" : ", '") + s.id + "'";
    }
  }
  if (!dependants.empty()) {
    return Status::Error(dependants + " placed against '" + id +
                         "': align them to another session (or remove them) first");
  }
  sessions.erase(sessions.begin() + i);
  return Status::Ok();
}

std::vector<std::string> Project::MoveDependants(const std::string& id, const Rigid3d& delta) {
  std::vector<std::string> moved;
  std::vector<std::string> frontier = {id};
  std::set<std::string> seen = {id};
  while (!frontier.empty()) {
    const std::string reference = frontier.back();
    frontier.pop_back();
    for (ProjectSession& s : sessions) {
      if (s.registration.reference != reference || !s.project_from_session ||
          !seen.insert(s.id).second) {
        continue;
      }
      s.project_from_session = delta * *s.project_from_session;
      moved.push_back(s.id);
      frontier.push_back(s.id);
    }
  }
  return moved;
}

std::string ProjectDirectory(const std::string& project_file) {
  const fs::path dir = fs::path(project_file).parent_path();
  return dir.empty() ? "." : dir.string();
}

std::string ResolveSessionPath(const std::string& project_file, const ProjectSession& session) {
  const fs::path p(session.path);
  if (p.is_absolute()) return p.string();
  return (fs::path(ProjectDirectory(project_file)) / p).lexically_normal().string();
}

Status ProjectFromJson(const std::string& text, const std::string& source, Project* project) {
  json j;
  Status s = ParseJson(text, source, &j);
  if (!s.ok()) return s;
  try {
    if (!j.is_object()) throw JsonError("expected a JSON object, got " + JsonTypeName(j));
    const JsonObject o(j, "");
    o.AllowOnly({"format", "version", "name", "description", "sessions"});
    if (o.String("format") != kFormat) {
      o.Fail("format", std::string("must be \"") + kFormat + "\", got \"" + o.String("format") + "\"");
    }
    const int64_t version = o.Integer("version");
    if (version != kProjectFormatVersion) {
      o.Fail("version", "this sweepscan reads version " + std::to_string(kProjectFormatVersion) +
                            ", the file is version " + std::to_string(version));
    }
    Project p;
    p.name = o.String("name", "");
    p.description = o.String("description", "");
    const json& sessions = o.Array("sessions");
    for (size_t i = 0; i < sessions.size(); ++i) {
      const std::string path = "sessions[" + std::to_string(i) + "]";
      ProjectSession ps = ReadSession(JsonObject(sessions[i], path));
      if (p.Find(ps.id) >= 0) throw JsonError(path + ".id: '" + ps.id + "' appears twice");
      for (const ProjectSession& other : p.sessions) {
        if (fs::path(other.path).lexically_normal() == fs::path(ps.path).lexically_normal()) {
          throw JsonError(path + ".path: '" + ps.path + "' is also session '" + other.id + "'");
        }
      }
      p.sessions.push_back(std::move(ps));
    }
    int anchors = 0;
    for (const ProjectSession& ps : p.sessions) anchors += ps.registration.method == "anchor";
    if (anchors > 1) throw JsonError("sessions: more than one anchor");
    for (const ProjectSession& ps : p.sessions) {
      if (!ps.registration.reference.empty() && p.Find(ps.registration.reference) < 0) {
        throw JsonError("sessions: '" + ps.id + "' refers to an unknown session '" +
                        ps.registration.reference + "'");
      }
    }
    *project = std::move(p);
  } catch (const JsonError& e) {
    return Status::Error(source + ": " + e.what());
  }
  return Status::Ok();
}

std::string ProjectToJson(const Project& project) {
  json sessions = json::array();
  for (const ProjectSession& s : project.sessions) {
    json j = {{"id", s.id}, {"path", s.path}};
    if (s.calibration) {
      j["calibration"] = {{"alpha_rad", s.calibration->alpha},
                          {"beta_rad", s.calibration->beta},
                          {"gamma_rad", s.calibration->gamma}};
    }
    if (s.project_from_session) {
      const Eigen::Quaterniond& q = s.project_from_session->rotation();
      const double wxyz[4] = {q.w(), q.x(), q.y(), q.z()};
      j["project_from_session"] = {{"translation_m", Numbers(s.project_from_session->translation().data(), 3)},
                                   {"rotation_wxyz", Numbers(wxyz, 4)}};
      j["registration"] = EvidenceJson(s.registration);
    }
    j["visible"] = s.visible;
    j["color"] = s.color;
    sessions.push_back(j);
  }
  json root = {{"format", kFormat}, {"version", kProjectFormatVersion}, {"name", project.name}};
  if (!project.description.empty()) root["description"] = project.description;
  root["sessions"] = sessions;
  return root.dump(2) + "\n";
}

Status LoadProject(const std::string& path, Project* project) {
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::Error(path + ": cannot open: " + std::strerror(errno));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return ProjectFromJson(text, path, project);
}

Status SaveProject(const std::string& path, const Project& project) {
  return WriteFileAtomically(path, ProjectToJson(project));
}

}  // namespace sweepscan
