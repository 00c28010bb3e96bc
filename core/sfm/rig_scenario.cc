#include "core/sfm/rig_scenario.h"

#include <cmath>
#include <map>
#include <set>

namespace sweepscan::sfm {

std::vector<Scan> ScansFromRigRun(const sim::RigRun& run) {
  std::vector<Scan> scans;
  scans.reserve(run.scans.size());
  for (const sim::RigScan& s : run.scans) {
    Scan out;
    out.time_s = s.time_s;
    out.lidar = s.lidar;
    out.points = s.Points();
    scans.push_back(std::move(out));
  }
  return scans;
}

Rig RigFromRigRun(const sim::RigRun& run) {
  Rig rig;
  rig.rig_from_lidar = run.rig_from_lidar;
  return rig;
}

Status InitFromTruth(const sim::RigRun& run, const sim::Scene& scene, bool give_planes,
                     const LineExtractionOptions& options, SequenceInit* init, std::vector<std::string>* chosen) {
  // Lines of frame 0 by the face their samples hit.
  struct FaceLines {
    int primitive = -1, face = -1;
    std::vector<InitLineRef> refs;
    std::vector<Eigen::Vector3d> dirs;  // rig frame
  };
  std::map<int, FaceLines> by_face;
  for (const sim::RigScan& s : run.scans) {
    if (s.frame != 0) continue;
    const std::vector<ScanLine> lines = ExtractLines(s.Points(), options);
    for (size_t k = 0; k < lines.size(); ++k) {
      std::map<int, int> votes;
      for (int i : lines[k].indices) ++votes[s.primitive[i] * 6 + s.face[i]];
      for (const auto& [key, count] : votes) {
        if (key < 0 || count < 0.9 * static_cast<double>(lines[k].indices.size())) continue;
        FaceLines& f = by_face[key];
        f.primitive = key / 6;
        f.face = key % 6;
        InitLineRef ref;
        ref.lidar = s.lidar;
        ref.line = static_cast<int>(k);
        f.refs.push_back(ref);
        const Eigen::Vector2d d2 = lines[k].direction;
        f.dirs.push_back(run.rig_from_lidar[s.lidar].rotation() * Eigen::Vector3d(d2.x(), d2.y(), 0.0));
      }
    }
  }
  std::vector<const FaceLines*> usable;
  for (const auto& [key, f] : by_face) {
    bool ok = !f.refs.empty();
    if (!give_planes) {
      ok = false;
      for (size_t a = 1; a < f.dirs.size(); ++a) ok = ok || f.dirs[0].cross(f.dirs[a]).norm() > std::sin(M_PI / 18);
    }
    if (ok) usable.push_back(&f);
  }
  double best = 0.0;
  std::array<const FaceLines*, 3> pick{};
  for (size_t a = 0; a < usable.size(); ++a) {
    for (size_t b = a + 1; b < usable.size(); ++b) {
      for (size_t c = b + 1; c < usable.size(); ++c) {
        const Eigen::Vector3d na = sim::ScenePlane(scene, usable[a]->primitive, usable[a]->face).normal;
        const Eigen::Vector3d nb = sim::ScenePlane(scene, usable[b]->primitive, usable[b]->face).normal;
        const Eigen::Vector3d nc = sim::ScenePlane(scene, usable[c]->primitive, usable[c]->face).normal;
        const double det = std::abs(na.cross(nb).dot(nc)) +
                           1e-3 * (usable[a]->refs.size() + usable[b]->refs.size() + usable[c]->refs.size());
        if (det > best + 1e-9) {
          best = det;
          pick = {usable[a], usable[b], usable[c]};
        }
      }
    }
  }
  if (best < 0.5) return Status::Error("the first frame sees no three planes with independent normals");
  if (chosen != nullptr) chosen->clear();
  for (int j = 0; j < 3; ++j) {
    const sim::TruthPlane tp = sim::ScenePlane(scene, pick[j]->primitive, pick[j]->face);
    InitPlane& p = init->planes[j];
    p.known = give_planes;
    p.plane.normal = tp.normal;
    p.plane.d = tp.d;
    p.lines = pick[j]->refs;
    if (chosen != nullptr) chosen->push_back(tp.label);
  }
  return Status::Ok();
}

Status RigScenarioByName(const std::string& name, sim::RigSimConfig* config) {
  if (name == "room") {
    *config = sim::SmallRoomRigScenario();
  } else if (name == "stairwell") {
    *config = sim::StairwellRigScenario();
  } else {
    return Status::Error("unknown rig scenario '" + name + "' (room, stairwell)");
  }
  return Status::Ok();
}

SequenceErrors EvaluateSequence(const std::vector<Rigid3d>& poses, const std::vector<FoundPlane>& planes,
                                bool gauge_first_pose, const sim::RigRun& run, const sim::Scene& scene) {
  SequenceErrors e;
  // world_truth_from_world_est.
  const Rigid3d align = gauge_first_pose ? run.world_from_rig[0] * poses[0].inverse() : Rigid3d::Identity();
  const size_t n = std::min(poses.size(), run.world_from_rig.size());
  for (size_t k = 0; k < n; ++k) {
    const Rigid3d est = align * poses[k];
    const Rigid3d& truth = run.world_from_rig[k];
    const double rot = RotationAngle(est.rotation().toRotationMatrix(), truth.rotation().toRotationMatrix()) * 180.0 / M_PI;
    const double trans = (est.translation() - truth.translation()).norm();
    e.rot_mean_deg += rot;
    e.trans_mean_m += trans;
    e.rot_max_deg = std::max(e.rot_max_deg, rot);
    e.trans_max_m = std::max(e.trans_max_m, trans);
  }
  if (n > 0) {
    e.rot_mean_deg /= static_cast<double>(n);
    e.trans_mean_m /= static_cast<double>(n);
  }
  // Distinct true planes (coplanar faces count once).
  std::vector<sim::TruthPlane> truth;
  for (const sim::TruthPlane& tp : sim::ScenePlanes(scene)) {
    bool dup = false;
    for (const sim::TruthPlane& q : truth) dup = dup || (q.normal.dot(tp.normal) > 0.9999 && std::abs(q.d - tp.d) < 1e-6);
    if (!dup) truth.push_back(tp);
  }
  std::set<size_t> found;
  const Eigen::Matrix3d R = align.rotation().toRotationMatrix();
  for (const FoundPlane& fp : planes) {
    // The plane in the truth's world: n' = R n, d' = d - n' . t.
    const Eigen::Vector3d nn = R * fp.plane.normal;
    const double dd = fp.plane.d - nn.dot(align.translation());
    double best_angle = 1e9, best_offset = 1e9;
    size_t best_index = 0;
    for (size_t j = 0; j < truth.size(); ++j) {
      const double angle = std::acos(std::clamp(nn.dot(truth[j].normal), -1.0, 1.0)) * 180.0 / M_PI;
      const double offset = std::abs(dd - truth[j].d);
      if (angle < 2.0 && offset < 0.05 && offset < best_offset) {
        best_angle = angle;
        best_offset = offset;
        best_index = j;
      }
    }
    if (best_offset < 1e9) {
      ++e.planes_matched;
      e.plane_angle_mean_deg += best_angle;
      e.plane_offset_mean_m += best_offset;
      if (found.insert(best_index).second) e.matched_labels.push_back(truth[best_index].label);
    }
  }
  if (e.planes_matched > 0) {
    e.plane_angle_mean_deg /= e.planes_matched;
    e.plane_offset_mean_m /= e.planes_matched;
  }
  e.truth_planes_found = static_cast<int>(found.size());
  return e;
}

}  // namespace sweepscan::sfm
