// The transforms of a bag's /tf_static and /tf, enough to find a sensor's
// mount on the robot: parent_from_child edges between frames, searched both
// ways (an edge read backwards is its inverse).
//
// A mount is a rigid part of the robot, normally on /tf_static. Transforms
// on /tf that join the two frames are accepted too (robot_state_publisher
// puts fixed joints there in older setups); the first one seen is kept, and
// a later one that differs by more than 1 mm or 1 mrad marks the edge as
// moving, which Resolve() reports (a lidar on a moving joint is not a
// fixed mount: the cloud would smear).
//
// Not thread-safe; one thread at a time.
#ifndef SWEEPSCAN_CORE_IO_ROS_TF_TREE_H_
#define SWEEPSCAN_CORE_IO_ROS_TF_TREE_H_

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

class TfTree {
 public:
  // Adds every transform of a TFMessage; `is_static` for /tf_static.
  void Add(const RosTfMessage& m, bool is_static);

  // target_from_source through the tree, e.g. Resolve("base_link", "laser")
  // = base_link_from_laser. Fails with the frames known and what is
  // missing ("no path from base_link to laser: known frames: ...").
  // *path describes the chain ("base_link -> laser_mount -> laser (static)");
  // *moving is true if an edge on it moved during the bag.
  Status Resolve(const std::string& target, const std::string& source, Rigid3d* target_from_source,
                 std::string* path, bool* moving) const;

  bool HasFrame(const std::string& frame) const;
  std::set<std::string> Frames() const;
  // "parent -> child" of every edge, for `info`.
  std::vector<std::string> EdgeNames() const;
  bool empty() const { return edges_.empty(); }

 private:
  struct Edge {
    Rigid3d parent_from_child;
    bool is_static = false;
    bool moving = false;
  };
  // Key: (parent, child) with tf's leading '/' stripped.
  std::map<std::pair<std::string, std::string>, Edge> edges_;
};

// tf frame ids may carry a leading '/' (ROS 1 tf); tf2 compares them without.
std::string NormalizeFrame(const std::string& frame);

Rigid3d RigidFromRos(const std::array<double, 3>& translation,
                     const std::array<double, 4>& rotation_xyzw);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS_TF_TREE_H_
