#include "core/sfm/p3l_json.h"

#include <cmath>

#include "core/common/json_reader.h"

namespace sweepscan::sfm {
namespace {

Eigen::Vector3d Vec3(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) throw JsonError(path + ": expected 3 numbers");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!j[i].is_number()) throw JsonError(path + ": expected 3 numbers, got " + JsonTypeName(j[i]));
    v[i] = j[i].get<double>();
    if (!std::isfinite(v[i])) throw JsonError(path + ": not finite");
  }
  return v;
}

Eigen::Matrix3d Mat3(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) throw JsonError(path + ": expected 3 rows of 3 numbers");
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) m.row(r) = Vec3(j[r], path + "[" + std::to_string(r) + "]").transpose();
  return m;
}

}  // namespace

Status ParseP3lProblem(const nlohmann::json& doc, P3lProblem* problem) {
  try {
    const JsonObject root(doc, "");
    root.AllowOnly({"planes", "lines", "previous"});
    const nlohmann::json& planes = root.Array("planes");
    const nlohmann::json& lines = root.Array("lines");
    if (planes.size() < 3) throw JsonError("planes: expected at least 3 planes, got " + std::to_string(planes.size()));
    if (lines.size() != planes.size()) {
      throw JsonError("lines: expected one line per plane (" + std::to_string(planes.size()) + "), got " +
                      std::to_string(lines.size()));
    }
    problem->disambiguation = {};
    for (size_t i = 0; i < planes.size(); ++i) {
      const std::string pp = "planes[" + std::to_string(i) + "]";
      const JsonObject po(planes[i], pp);
      po.AllowOnly({"normal", "d"});
      WorldPlane plane;
      plane.normal = Vec3(po.Array("normal"), po.Path("normal"));
      plane.d = po.Number("d");
      if (!(plane.normal.norm() > 1e-9)) throw JsonError(pp + ".normal: the normal is zero");
      const double len = plane.normal.norm();
      plane.normal /= len;
      plane.d /= len;
      const std::string lp = "lines[" + std::to_string(i) + "]";
      if (!lines[i].is_array() || lines[i].size() < 2) throw JsonError(lp + ": expected two (or more) points");
      LineObservation obs;
      for (size_t k = 0; k < lines[i].size(); ++k) {
        obs.points.push_back(Vec3(lines[i][k], lp + "[" + std::to_string(k) + "]"));
      }
      RigLine line;
      const Status s = ToRigLine(obs, Rig{}, &line);
      if (!s.ok()) throw JsonError(lp + ": " + s.message());
      if (i < 3) {
        problem->planes[i] = plane;
        problem->lines[i] = line;
      } else {
        problem->disambiguation.extra_planes.push_back(plane);
        problem->disambiguation.extra_lines.push_back(line);
      }
    }
    if (root.Has("previous")) {
      const JsonObject prev = root.Object("previous");
      prev.AllowOnly({"R", "t"});
      const Eigen::Matrix3d R = Mat3(prev.Array("R"), prev.Path("R"));
      if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0) {
        throw JsonError("previous.R: not a rotation matrix");
      }
      problem->disambiguation.has_previous = true;
      problem->disambiguation.previous_R = R;
      problem->disambiguation.previous_t = Vec3(prev.Array("t"), prev.Path("t"));
    }
  } catch (const JsonError& e) {
    return Status::Error(e.what());
  }
  return Status::Ok();
}

nlohmann::json P3lSolutionsToJson(const std::vector<PoseCandidate>& candidates) {
  nlohmann::json solutions = nlohmann::json::array();
  for (const PoseCandidate& c : candidates) {
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) R.push_back({c.R(r, 0), c.R(r, 1), c.R(r, 2)});
    solutions.push_back({{"R", R}, {"t", {c.t.x(), c.t.y(), c.t.z()}}});
  }
  return {{"solutions", solutions}};
}

}  // namespace sweepscan::sfm
