#include "core/project/project.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "core/common/checked_file.h"
#include "core/common/json_reader.h"
#include "core/geometry/skew.h"

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
  // The project's frame is the building's own (its anchor's start pose), and
  // a cloud's positions are float: 1 mm steps hold to 8 192 m from the
  // origin, 0.5 m at 5 000 km. A pose beyond that (coordinates typed in a
  // map grid's, a stray digit) would be exported and drawn rounded, so it is
  // refused rather than kept to mislead.
  if (t.cwiseAbs().maxCoeff() > kMaxProjectOffsetM) {
    // As many decimals as it takes to read beyond the limit: 8000.4 m
    // printed as "8000 m, beyond 8000 m" contradicted itself.
    const double far = t.cwiseAbs().maxCoeff();
    char at[96];
    for (int digits = 0; digits <= 9; ++digits) {
      std::snprintf(at, sizeof(at), "lies %.*f m from the project's origin", digits, far);
      if (std::strtod(at + 5, nullptr) > kMaxProjectOffsetM) break;
    }
    o.Fail("translation_m",
           std::string(at) +
               ", beyond 8000 m: sessions are placed in the building's local frame "
               "(georeferenced coordinates are not supported)");
  }
  const Eigen::Vector4d q = Numbers<4>(o, "rotation_wxyz");
  // A hand-edited file keeps a few digits; anything further from unit
  // length is not a rotation someone meant.
  if (std::abs(q.norm() - 1.0) > 1e-6) {
    o.Fail("rotation_wxyz", "must be a unit quaternion, |q| = " + std::to_string(q.norm()));
  }
  return Rigid3d(t, Eigen::Quaterniond(q[0], q[1], q[2], q[3]));
}

// The covariance a registration reported: finite, symmetric and positive
// semi-definite, or it is not a covariance (a hand edit gone wrong) and its
// square roots, the sigmas shown, would mean nothing.
void CheckCovariance(const JsonObject& o, const std::array<double, 36>& c) {
  Eigen::Matrix<double, 6, 6> m;
  for (int i = 0; i < 36; ++i) {
    if (!std::isfinite(c[i])) o.Fail("covariance", "entry " + std::to_string(i) + " is not finite");
    m(i / 6, i % 6) = c[i];
  }
  // Symmetric to what a double inverse leaves (the writer symmetrises; a
  // file written before it may differ by ~1e-8 of the largest entry).
  const double scale = m.cwiseAbs().maxCoeff();
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > 1e-6 * scale) {
    o.Fail("covariance", "must be symmetric (row-major 6 x 6)");
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(m);
  if (es.eigenvalues().minCoeff() < -1e-9 * scale) {
    o.Fail("covariance", "must be positive semi-definite, smallest eigenvalue " +
                             std::to_string(es.eigenvalues().minCoeff()));
  }
}

// "2026-11-26T07:40:12Z", optionally with a fraction of a second: what
// the writers stamp (UtcNowIso8601), and a hand edit can keep.
bool IsIso8601Utc(const std::string& t) {
  const auto digits = [&](size_t at, size_t n, int lo, int hi) {
    if (at + n > t.size()) return false;
    int v = 0;
    for (size_t i = at; i < at + n; ++i) {
      if (!std::isdigit(static_cast<unsigned char>(t[i]))) return false;
      v = v * 10 + (t[i] - '0');
    }
    return v >= lo && v <= hi;
  };
  if (t.size() < 20 || !digits(0, 4, 0, 9999) || t[4] != '-' || !digits(5, 2, 1, 12) ||
      t[7] != '-' || !digits(8, 2, 1, 31) || t[10] != 'T' || !digits(11, 2, 0, 23) ||
      t[13] != ':' || !digits(14, 2, 0, 59) || t[16] != ':' || !digits(17, 2, 0, 60)) {
    return false;
  }
  size_t i = 19;
  if (t[i] == '.') {
    const size_t start = ++i;
    while (i < t.size() && std::isdigit(static_cast<unsigned char>(t[i]))) ++i;
    if (i == start) return false;
  }
  return i + 1 == t.size() && t[i] == 'Z';
}

RegistrationEvidence ReadEvidence(const JsonObject& o) {
  static const std::set<std::string> kMethods = {"anchor", "manual", "pairs", "planes",
                                                 "planes+icp", "pairs+icp", "icp"};
  RegistrationEvidence e;
  e.method = o.String("method");
  if (!kMethods.count(e.method)) {
    o.Fail("method", "unknown method '" + e.method +
                         "' (anchor, manual, pairs, planes, planes+icp, pairs+icp, icp)");
  }
  // The anchor was measured against nothing: any evidence beside its method
  // would be dropped on the next save without a word.
  if (e.method == "anchor") {
    o.AllowOnly({"method", "reference"});
    // Even empty: the docs forbid the key, and a reader that tests for its
    // presence would take the anchor as placed against something.
    if (o.Has("reference")) o.Fail("reference", "the anchor is aligned to nothing");
    return e;
  }
  o.AllowOnly({"method", "reference", "rms_m", "overlap", "correspondences", "iterations",
               "covariance", "free_direction", "pairs", "time_utc", "pose_source"});
  e.reference = o.String("reference", "");
  // A measured pose was measured against a session; only one typed in
  // (manual) rests on none.
  if (e.method != "manual" && e.reference.empty()) {
    o.Fail("reference", o.Has("reference") ? "must not be empty"
                                           : "missing: a " + e.method +
                                                 " placement names the session it was aligned to");
  }
  if (o.Has("reference") && e.reference.empty()) o.Fail("reference", "must not be empty");
  e.pose_source = o.String("pose_source", "ekf");
  if (e.pose_source != "ekf" && e.pose_source != "odometry") {
    o.Fail("pose_source", "must be \"ekf\" or \"odometry\", got \"" + e.pose_source + "\"");
  }
  e.rms_m = o.NonNegative("rms_m", 0.0);
  e.overlap = o.InRange("overlap", 0.0, 1.0, 0.0);
  e.correspondences = o.Has("correspondences") ? o.Count("correspondences") : 0;
  const int64_t iterations = o.Has("iterations") ? o.Integer("iterations") : 0;
  if (iterations < 0 || iterations > 1000000) {
    o.Fail("iterations", "must be within 0..1000000, got " + std::to_string(iterations));
  }
  e.iterations = static_cast<int>(iterations);
  if (o.Has("covariance")) {
    const Eigen::Matrix<double, 36, 1> c = Numbers<36>(o, "covariance");
    for (int i = 0; i < 36; ++i) e.covariance[i] = c[i];
    CheckCovariance(o, e.covariance);
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
  if (o.Has("time_utc") && !IsIso8601Utc(e.time_utc)) {
    o.Fail("time_utc",
           "expected ISO 8601 UTC such as \"2026-11-26T07:40:12Z\", got \"" + e.time_utc + "\"");
  }
  return e;
}

ProjectSession ReadSession(const JsonObject& o) {
  o.AllowOnly({"id", "path", "calibration", "project_from_session", "registration", "visible",
               "color", "recorded_utc"});
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
  }
  s.visible = o.Bool("visible", true);
  s.color = o.String("color", s.color);
  if (!IsColor(s.color)) o.Fail("color", "expected #rrggbb, got '" + s.color + "'");
  s.recorded_utc = o.String("recorded_utc", "");
  if (!s.recorded_utc.empty() && !IsIso8601Utc(s.recorded_utc)) {
    o.Fail("recorded_utc", "expected ISO 8601 UTC such as \"2026-11-26T07:40:12Z\", got \"" +
                               s.recorded_utc + "\"");
  }
  return s;
}

// The path as the file compares it: normal form, no trailing separator
// ("room.sweepscan/" is "room.sweepscan", what tab completion gives).
fs::path PathKey(const std::string& path) {
  fs::path p = fs::path(path).lexically_normal();
  if (p.filename().empty() && p.has_parent_path()) p = p.parent_path();
  return p;
}

// The folder `path` names, however written (relative or absolute, a
// trailing separator, through ".." or a symbolic link), resolved against
// `project_file`'s folder.
fs::path FolderKey(const std::string& project_file, const std::string& path) {
  ProjectSession probe;
  probe.path = path;
  std::error_code error;
  const fs::path resolved = PathKey(ResolveSessionPath(project_file, probe));
  const fs::path canonical = fs::weakly_canonical(resolved, error);
  return error ? resolved : PathKey(canonical.string());
}

// JSON strings are UTF-8 (RFC 8259 section 8.1); a folder name in another
// encoding could not be saved.
bool IsUtf8(const std::string& s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    int n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xe0) == 0xc0) {
      n = 1, cp = c & 0x1f;
    } else if ((c & 0xf0) == 0xe0) {
      n = 2, cp = c & 0x0f;
    } else if ((c & 0xf8) == 0xf0) {
      n = 3, cp = c & 0x07;
    } else {
      return false;
    }
    for (int k = 1; k <= n; ++k) {
      if (i + k >= s.size()) return false;
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3f);
    }
    // Overlong forms, surrogates and beyond U+10FFFF are not UTF-8.
    static const uint32_t kMin[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || (cp >= 0xd800 && cp <= 0xdfff) || cp > 0x10ffff) return false;
    i += n + 1;
  }
  return true;
}

json EvidenceJson(const RegistrationEvidence& e) {
  json j = {{"method", e.method}};
  if (!e.reference.empty()) j["reference"] = e.reference;
  if (e.method == "anchor") return j;
  j["rms_m"] = e.rms_m;
  j["overlap"] = e.overlap;
  j["correspondences"] = e.correspondences;
  j["iterations"] = e.iterations;
  // Symmetrised: a registration's (J^T J)^-1 is symmetric only to rounding.
  std::array<double, 36> c;
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k)
      c[r * 6 + k] = 0.5 * (e.covariance[r * 6 + k] + e.covariance[k * 6 + r]);
  }
  j["covariance"] = Numbers(c.data(), 36);
  if (!e.free_direction.isZero()) j["free_direction"] = Numbers(e.free_direction.data(), 3);
  if (!e.pairs.empty()) {
    json pairs = json::array();
    for (const PickedPair& p : e.pairs) {
      pairs.push_back({{"source", Numbers(p.source.data(), 3)}, {"target", Numbers(p.target.data(), 3)}});
    }
    j["pairs"] = pairs;
  }
  if (!e.time_utc.empty()) j["time_utc"] = e.time_utc;
  // Said for what was measured; a pose typed in was measured with no cloud.
  if (e.method != "manual") j["pose_source"] = e.pose_source;
  return j;
}

}  // namespace

void MakeAnchor(ProjectSession* session) {
  session->project_from_session = Rigid3d::Identity();
  session->registration = RegistrationEvidence();
  session->registration.method = "anchor";
}

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

Status Project::AddSession(const std::string& path, ProjectSession** added,
                           const std::string& project_file) {
  if (!IsUtf8(path)) {
    return Status::Error(json(path).dump(-1, ' ', true, json::error_handler_t::replace) +
                         ": the folder's name is not UTF-8, which a project file (JSON) cannot "
                         "hold; rename the folder");
  }
  const fs::path key = FolderKey(project_file, path);
  for (const ProjectSession& s : sessions) {
    if (PathKey(s.path) == PathKey(path) || FolderKey(project_file, s.path) == key) {
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
  sessions.push_back(s);
  // A project without an anchor (one an older sweepscan saved after its
  // anchor was removed) gets its first session as the anchor, not the one
  // just added: the order of the file is the operator's.
  const bool placed = std::any_of(sessions.begin(), sessions.end(),
                                  [](const ProjectSession& p) { return p.project_from_session; });
  if (Anchor() < 0 && !placed) MakeAnchor(&sessions.front());
  if (added != nullptr) *added = &sessions.back();
  return Status::Ok();
}

Status Project::RemoveSession(const std::string& id, std::string* new_anchor) {
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
  const bool was_anchor = sessions[i].registration.method == "anchor";
  sessions.erase(sessions.begin() + i);
  // The others are unplaced (else the anchor stays, above): the project's
  // frame becomes the first one's, as if it had been added first.
  if (was_anchor && !sessions.empty()) {
    MakeAnchor(&sessions.front());
    if (new_anchor != nullptr) *new_anchor = sessions.front().id;
  }
  return Status::Ok();
}

bool Project::PlacedThrough(const std::string& id, const std::string& on) const {
  std::set<std::string> seen;
  for (int i = Find(id); i >= 0 && seen.insert(sessions[i].id).second;) {
    const std::string& reference = sessions[i].registration.reference;
    if (reference.empty()) return false;
    if (reference == on) return true;
    i = Find(reference);
  }
  return false;
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

namespace {

// The measurement `e` of reference_from_session = `measured`, turned round:
// the reference placed against the session (`session`), by the inverse.
// A left perturbation in the reference's frame, measured = Exp(xi) * M,
// is one in the session's frame for the inverse, M^-1 * Exp(-xi) =
// Exp(-Ad(M^-1) xi) * M^-1, so the covariance becomes Ad C Ad^T with
// Ad(R, t) = [R 0; [t]x R  R] in (rotation, translation) order.
RegistrationEvidence Reversed(const RegistrationEvidence& e, const std::string& session,
                              const Rigid3d& measured) {
  RegistrationEvidence r = e;
  r.reference = session;
  const Rigid3d inverse = measured.inverse();
  const Eigen::Matrix3d rot = inverse.rotation().toRotationMatrix();
  Eigen::Matrix<double, 6, 6> ad = Eigen::Matrix<double, 6, 6>::Zero();
  ad.block<3, 3>(0, 0) = rot;
  ad.block<3, 3>(3, 0) = Skew(inverse.translation()) * rot;
  ad.block<3, 3>(3, 3) = rot;
  Eigen::Matrix<double, 6, 6> c;
  for (int i = 0; i < 36; ++i) c(i / 6, i % 6) = e.covariance[i];
  const Eigen::Matrix<double, 6, 6> turned = ad * c * ad.transpose();
  for (int i = 0; i < 36; ++i) r.covariance[i] = turned(i / 6, i % 6);
  // A translation free along d in the reference's frame is one along R d
  // in the session's (the adjoint's translation block, no rotation part).
  if (!e.free_direction.isZero()) r.free_direction = (rot * e.free_direction).normalized();
  for (PickedPair& p : r.pairs) std::swap(p.source, p.target);
  return r;
}

}  // namespace

Status Project::ChangeAnchor(const std::string& id, AnchorChange* change) {
  AnchorChange said;
  const int s = Find(id);
  if (s < 0) return Status::Error("no session '" + id + "' in the project");
  const int a = Anchor();
  if (s == a) {
    if (change != nullptr) *change = said;
    return Status::Ok();
  }
  if (a >= 0) said.old_anchor = sessions[a].id;
  if (!sessions[s].project_from_session) {
    for (size_t k = 0; k < sessions.size(); ++k) {
      if (static_cast<int>(k) != a && sessions[k].project_from_session) {
        return Status::Error("'" + id +
                             "' is not placed: align it first (the anchor's frame must be known "
                             "relative to the placed sessions')");
      }
    }
    // Nothing placed but the anchor: no placement to re-express, and the
    // old anchor, measured against nothing, is not placed in the new frame.
    if (a >= 0) {
      sessions[a].project_from_session.reset();
      sessions[a].registration = RegistrationEvidence();
      said.old_anchor_unplaced = true;
    }
    MakeAnchor(&sessions[s]);
    if (change != nullptr) *change = said;
    return Status::Ok();
  }
  const Rigid3d new_from_old = sessions[s].project_from_session->inverse();
  for (const ProjectSession& other : sessions) {
    if (other.project_from_session &&
        (new_from_old * *other.project_from_session).translation().cwiseAbs().maxCoeff() >
            kMaxProjectOffsetM) {
      return Status::Error("'" + other.id + "' would lie beyond 8000 m of '" + id +
                           "''s start pose (a cloud's float positions would be rounded); '" + id +
                           "' cannot be the anchor");
    }
  }
  // The chain of references from `id` to its root: the anchor, or a
  // session held by hand without a reference.
  std::vector<int> chain = {s};
  std::set<int> seen = {s};
  for (int k = Find(sessions[s].registration.reference);
       k >= 0 && sessions[k].project_from_session && seen.insert(k).second;
       k = Find(sessions[k].registration.reference)) {
    chain.push_back(k);
  }
  std::vector<RegistrationEvidence> turned;
  for (size_t k = 0; k + 1 < chain.size(); ++k) {
    const ProjectSession& from = sessions[chain[k]];
    const ProjectSession& to = sessions[chain[k + 1]];
    turned.push_back(Reversed(from.registration, from.id,
                              to.project_from_session->inverse() * *from.project_from_session));
  }
  for (size_t k = 0; k < turned.size(); ++k) {
    sessions[chain[k + 1]].registration = turned[k];
    said.reversed.push_back(sessions[chain[k + 1]].id);
  }
  // The old anchor off the chain (`id` rests on a session held by hand):
  // held where it is, by hand too.
  if (a >= 0 && chain.back() != a) {
    sessions[a].registration = RegistrationEvidence();
    sessions[a].registration.method = "manual";
  }
  for (ProjectSession& other : sessions) {
    if (other.project_from_session)
      other.project_from_session = new_from_old * *other.project_from_session;
  }
  MakeAnchor(&sessions[s]);
  if (change != nullptr) *change = said;
  return Status::Ok();
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

Status ProjectFromJson(const std::string& text, const std::string& source, Project* project,
                       std::vector<std::string>* repairs) {
  json j;
  Status s = ParseJson(text, source, &j);
  if (!s.ok()) return s;
  try {
    if (!j.is_object()) throw JsonError("expected a JSON object, got " + JsonTypeName(j));
    const JsonObject o(j, "");
    // What the file is, first: a newer version's keys are its version's,
    // and "unknown key" would hide that this sweepscan is the older one.
    if (o.String("format") != kFormat) {
      o.Fail("format", std::string("must be \"") + kFormat + "\", got \"" + o.String("format") + "\"");
    }
    const int64_t version = o.Integer("version");
    if (version != kProjectFormatVersion) {
      o.Fail("version", "this sweepscan reads version " + std::to_string(kProjectFormatVersion) +
                            ", the file is version " + std::to_string(version));
    }
    o.AllowOnly({"format", "version", "name", "description", "sessions"});
    Project p;
    p.name = o.String("name", "");
    p.description = o.String("description", "");
    const json& sessions = o.Array("sessions");
    for (size_t i = 0; i < sessions.size(); ++i) {
      const std::string path = "sessions[" + std::to_string(i) + "]";
      ProjectSession ps = ReadSession(JsonObject(sessions[i], path));
      if (p.Find(ps.id) >= 0) throw JsonError(path + ".id: '" + ps.id + "' appears twice");
      // The same folder twice (a hand-edited absolute path beside the
      // relative one) would be exported twice.
      const fs::path key = FolderKey(source, ps.path);
      for (const ProjectSession& other : p.sessions) {
        if (PathKey(other.path) == PathKey(ps.path) || FolderKey(source, other.path) == key) {
          throw JsonError(path + ".path: '" + ps.path + "' is also session '" + other.id + "'");
        }
      }
      p.sessions.push_back(std::move(ps));
    }
    int anchors = 0;
    bool placed = false;
    for (const ProjectSession& ps : p.sessions) {
      anchors += ps.registration.method == "anchor";
      placed = placed || ps.project_from_session;
    }
    if (anchors > 1) throw JsonError("sessions: more than one anchor");
    // What sweepscan before 2026-12 saved when the anchor was removed: no
    // frame at all, and `align` had nothing to place against.
    if (anchors == 0 && !placed && !p.sessions.empty() && repairs != nullptr) {
      MakeAnchor(&p.sessions.front());
      repairs->push_back("no session is the anchor: '" + p.sessions.front().id +
                         "', the first, now is (the project's frame is its start pose)");
    }
    for (ProjectSession& ps : p.sessions) {
      const std::string& reference = ps.registration.reference;
      if (reference.empty()) continue;
      const int r = p.Find(reference);
      if (r < 0) {
        throw JsonError("sessions: '" + ps.id + "' refers to an unknown session '" + reference +
                        "'");
      }
      std::string wrong;
      if (reference == ps.id) {
        wrong = "'" + ps.id + "' is placed against itself";
      } else if (!p.sessions[r].project_from_session) {
        wrong = "'" + ps.id + "' is placed against '" + reference + "', which is not placed";
      } else if (p.PlacedThrough(reference, ps.id)) {
        // A loop of references places its sessions against each other and
        // nothing else: none of them can be removed, and placing one again
        // would move the others with it.
        std::string chain = ps.id;
        for (int i = r; i >= 0 && p.sessions[i].id != ps.id;
             i = p.Find(p.sessions[i].registration.reference)) {
          chain += " -> " + p.sessions[i].id;
        }
        wrong = "the references form a loop: " + chain + " -> " + ps.id;
      }
      if (wrong.empty()) continue;
      if (repairs == nullptr) throw JsonError("sessions: " + wrong);
      repairs->push_back(wrong + ": '" + ps.id +
                         "' keeps its pose, now held as placed by hand (manual); " +
                         "align it again to measure it");
      // The numbers measured its pose against that reference; held by
      // hand, nothing measured it (a manual placement's zero covariance
      // means unknown).
      ps.registration = RegistrationEvidence();
      ps.registration.method = "manual";
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
    if (!s.recorded_utc.empty()) j["recorded_utc"] = s.recorded_utc;
    sessions.push_back(j);
  }
  json root = {{"format", kFormat}, {"version", kProjectFormatVersion}, {"name", project.name}};
  if (!project.description.empty()) root["description"] = project.description;
  root["sessions"] = sessions;
  return root.dump(2) + "\n";
}

Status LoadProject(const std::string& path, Project* project, std::vector<std::string>* repairs) {
  // A folder opens as a stream and throws on its first read.
  if (const Status file = CheckRegularFile(path); !file.ok()) return file;
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::Error(path + ": cannot open: " + std::strerror(errno));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return ProjectFromJson(text, path, project, repairs);
}

bool IsUtf8Text(const std::string& s) { return IsUtf8(s); }

Status SaveProject(const std::string& path, const Project& project) {
  // JSON holds UTF-8 only (its writer throws on anything else): a name or
  // description typed in another encoding (`project new --name` in a
  // Latin-1 terminal) is refused by name, not "an unexpected failure".
  if (!IsUtf8(project.name))
    return Status::Error(path + ": the project's name is not UTF-8 text; not saved");
  if (!IsUtf8(project.description))
    return Status::Error(path + ": the project's description is not UTF-8 text; not saved");
  // Nothing the loader would refuse (ReadPose): a session beyond 8 000 m.
  for (const ProjectSession& s : project.sessions) {
    if (s.project_from_session &&
        s.project_from_session->translation().cwiseAbs().maxCoeff() > kMaxProjectOffsetM) {
      return Status::Error(path + ": session '" + s.id +
                           "' is placed beyond 8000 m of the project's origin; not saved");
    }
  }
  return WriteFileAtomically(path, ProjectToJson(project));
}

}  // namespace sweepscan
