#include "core/sfm/sequence_json.h"

#include <cmath>

#include "core/common/json_reader.h"

namespace sweepscan::sfm {
namespace {

template <int N>
Eigen::Matrix<double, N, 1> Vec(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.size() != N) throw JsonError(path + ": expected " + std::to_string(N) + " numbers");
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i) {
    if (!j[i].is_number()) throw JsonError(path + ": expected numbers, got " + JsonTypeName(j[i]));
    v[i] = j[i].get<double>();
    if (!std::isfinite(v[i])) throw JsonError(path + ": not finite");
  }
  return v;
}

}  // namespace

Status ParseSequenceInit(const nlohmann::json& doc, SequenceInit* init) {
  try {
    const JsonObject root(doc, "");
    root.AllowOnly({"planes"});
    const nlohmann::json& planes = root.Array("planes");
    if (planes.size() != 3) throw JsonError("planes: expected 3 planes, got " + std::to_string(planes.size()));
    for (int j = 0; j < 3; ++j) {
      const std::string path = "planes[" + std::to_string(j) + "]";
      const JsonObject p(planes[j], path);
      p.AllowOnly({"normal", "d", "lines"});
      InitPlane& ip = init->planes[j];
      ip = InitPlane();
      if (p.Has("normal") != p.Has("d")) throw JsonError(path + ": give both \"normal\" and \"d\", or neither");
      ip.known = p.Has("normal");
      if (ip.known) {
        const Eigen::Vector3d n = Vec<3>(planes[j].at("normal"), p.Path("normal"));
        const double s = n.norm();
        if (!(s > 1e-9)) throw JsonError(p.Path("normal") + ": zero normal");
        ip.plane.normal = n / s;
        ip.plane.d = p.Number("d") / s;
      }
      const nlohmann::json& lines = p.Array("lines");
      for (size_t k = 0; k < lines.size(); ++k) {
        const JsonObject l(lines[k], p.Path("lines") + "[" + std::to_string(k) + "]");
        l.AllowOnly({"lidar", "line", "near"});
        InitLineRef ref;
        ref.lidar = static_cast<int>(l.Integer("lidar"));
        if (ref.lidar < 0) throw JsonError(l.Path("lidar") + ": must be >= 0");
        if (l.Has("line") == l.Has("near")) throw JsonError(l.path() + ": give \"line\" or \"near\"");
        if (l.Has("line")) {
          ref.line = static_cast<int>(l.Integer("line"));
          if (ref.line < 0) throw JsonError(l.Path("line") + ": must be >= 0");
        } else {
          ref.near = Vec<2>(lines[k].at("near"), l.Path("near"));
        }
        ip.lines.push_back(ref);
      }
      if (ip.lines.empty()) throw JsonError(p.Path("lines") + ": at least one line");
    }
    const bool known = init->planes[0].known;
    for (const InitPlane& ip : init->planes) {
      if (ip.known != known) throw JsonError("planes: give normal and d for all three planes or for none");
    }
  } catch (const JsonError& e) {
    return Status::Error(e.what());
  }
  return Status::Ok();
}

nlohmann::json SequenceInitToJson(const SequenceInit& init) {
  nlohmann::json planes = nlohmann::json::array();
  for (const InitPlane& ip : init.planes) {
    nlohmann::json p;
    if (ip.known) {
      p["normal"] = {ip.plane.normal.x(), ip.plane.normal.y(), ip.plane.normal.z()};
      p["d"] = ip.plane.d;
    }
    nlohmann::json lines = nlohmann::json::array();
    for (const InitLineRef& l : ip.lines) {
      nlohmann::json lj;
      lj["lidar"] = l.lidar;
      if (l.line >= 0) {
        lj["line"] = l.line;
      } else {
        lj["near"] = {l.near.x(), l.near.y()};
      }
      lines.push_back(lj);
    }
    p["lines"] = lines;
    planes.push_back(p);
  }
  return {{"planes", planes}};
}

}  // namespace sweepscan::sfm
