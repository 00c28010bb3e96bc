#include "core/io/ros/tf_tree.h"

#include <deque>
#include <sstream>

namespace sweepscan::io {

std::string NormalizeFrame(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

Rigid3d RigidFromRos(const std::array<double, 3>& t, const std::array<double, 4>& q) {
  Eigen::Quaterniond r(q[3], q[0], q[1], q[2]);
  // A zero quaternion (an unset field) cannot be normalised: take identity.
  if (!(r.norm() > 1e-9)) r = Eigen::Quaterniond::Identity();
  return Rigid3d({t[0], t[1], t[2]}, r.normalized());
}

void TfTree::Add(const RosTfMessage& m, bool is_static) {
  for (const RosTransform& t : m.transforms) {
    const auto key = std::make_pair(NormalizeFrame(t.header.frame_id), NormalizeFrame(t.child_frame_id));
    if (key.first.empty() || key.second.empty() || key.first == key.second) continue;
    const Rigid3d x = RigidFromRos(t.translation, t.rotation);
    auto it = edges_.find(key);
    if (it == edges_.end()) {
      edges_[key] = Edge{x, is_static, false};
      continue;
    }
    Edge& e = it->second;
    // A static transform replaces a dynamic one: it is the mount as declared.
    if (is_static && !e.is_static) {
      e = Edge{x, true, false};
      continue;
    }
    const double dt = (x.translation() - e.parent_from_child.translation()).norm();
    const double da = x.rotation().angularDistance(e.parent_from_child.rotation());
    if (dt > 1e-3 || da > 1e-3) {
      if (is_static) {
        e.parent_from_child = x;  // a re-published static transform: the latest wins, as in tf2
      } else {
        e.moving = true;
      }
    }
  }
}

bool TfTree::HasFrame(const std::string& frame) const {
  const std::string f = NormalizeFrame(frame);
  for (const auto& [key, e] : edges_) {
    if (key.first == f || key.second == f) return true;
  }
  return false;
}

std::set<std::string> TfTree::Frames() const {
  std::set<std::string> frames;
  for (const auto& [key, e] : edges_) {
    frames.insert(key.first);
    frames.insert(key.second);
  }
  return frames;
}

std::vector<std::string> TfTree::EdgeNames() const {
  std::vector<std::string> names;
  for (const auto& [key, e] : edges_) {
    names.push_back(key.first + " -> " + key.second + (e.is_static ? " (static)" : "") +
                    (e.moving ? " (moving)" : ""));
  }
  return names;
}

Status TfTree::Resolve(const std::string& target_frame, const std::string& source_frame,
                       Rigid3d* target_from_source, std::string* path, bool* moving) const {
  const std::string target = NormalizeFrame(target_frame), source = NormalizeFrame(source_frame);
  if (target == source) {
    *target_from_source = Rigid3d::Identity();
    *path = target + " (the same frame)";
    *moving = false;
    return Status::Ok();
  }
  // Breadth-first from the target; each visited frame keeps target_from_frame.
  struct Visit {
    Rigid3d target_from_frame;
    std::string path;
    bool moving = false;
  };
  std::map<std::string, Visit> seen{{target, {Rigid3d::Identity(), target, false}}};
  std::deque<std::string> queue{target};
  while (!queue.empty()) {
    const std::string frame = queue.front();
    queue.pop_front();
    const Visit here = seen[frame];
    for (const auto& [key, e] : edges_) {
      std::string next;
      Rigid3d frame_from_next;
      if (key.first == frame) {
        next = key.second;
        frame_from_next = e.parent_from_child;
      } else if (key.second == frame) {
        next = key.first;
        frame_from_next = e.parent_from_child.inverse();
      } else {
        continue;
      }
      if (seen.count(next)) continue;
      Visit v{here.target_from_frame * frame_from_next, here.path + " -> " + next,
              here.moving || e.moving};
      if (next == source) {
        *target_from_source = v.target_from_frame;
        *path = v.path;
        *moving = v.moving;
        return Status::Ok();
      }
      seen[next] = v;
      queue.push_back(next);
    }
  }
  std::ostringstream known;
  for (const std::string& f : Frames()) known << (known.tellp() > 0 ? ", " : "") << f;
  return Status::Error("tf has no path from " + target + " to " + source + " (frames in tf: " +
                       (Frames().empty() ? std::string("none") : known.str()) + ")");
}

}  // namespace sweepscan::io
