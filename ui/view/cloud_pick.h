// The search behind a Shift + click (CloudView's picking layer), apart
// from the view: what the pick needs is taken on the GUI thread (the
// viewing ray, the sealed chunks' shared packed chunks, the pass filter's
// values, a snapshot of the layers), and the search runs on any thread.
// CloudView runs it on its pick thread for a click, so that a pick on a
// 100 M-point cloud (tens of ms, more when its chunks are read back from
// the cache file) never holds the GUI thread, and on the caller's thread
// for CloudView::PickPoint.
//
// The pick is the point nearest the camera among those within a tolerance
// of the ray (a cone: tolerance_per_t * t at distance t along it), tested
// against every point, not only those drawn: the operator clicks what is on
// screen and gets the true sample under the cursor, whatever the level of
// detail. Points the clip hides or the pass filter leaves out are not
// pickable.
#ifndef SWEEPSCAN_UI_VIEW_CLOUD_PICK_H_
#define SWEEPSCAN_UI_VIEW_CLOUD_PICK_H_

#include <Eigen/Core>
#include <QString>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "core/cloud/packed_chunk.h"

namespace sweepscan::ui {

// What a Shift + click found: the point in the view's frame, and which
// layer it belongs to with the point in that layer's own frame (a project
// session's: what pairs for registration are made of).
struct PickHit {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();
  QString layer;  // "" for the view's own cloud, else the layer's id
  Eigen::Vector3d local = Eigen::Vector3d::Zero();  // == world for the view's own cloud
};

// A click's viewing ray in the view's frame, from the eye: a point at
// distance t along it (t = (p - origin) . direction) is under the cursor
// within tolerance_per_t * t of the ray; points above clip_z are hidden.
struct PickRay {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // unit
  double tolerance_per_t = 0.0;
  double clip_z = std::numeric_limits<double>::infinity();
};

// What a pick tested of the sealed chunks: blocks in entry order (the
// nearest first), then blocks a chunk at a time, in that many chunks.
struct PickCounts {
  size_t blocks_in_order = 0, blocks_by_chunk = 0, chunks = 0;
};

// A layer's owner finds its point under the ray nearer than *best_t (then
// updates *best_t and *hit, and returns true). Called on the pick's thread:
// it must read only what it holds (a snapshot), never its owner.
using LayerPick = std::function<bool(const PickRay& ray, double* best_t, PickHit* hit)>;

// The pass filter (CloudView::SetPassFilter) as a pick applies it: a point
// passes if its pass value, lo + q * step (kNone: none), is `pass`; every
// point passes when `pass` is negative.
struct PassTest {
  static constexpr uint16_t kNone = 0xFFFF;
  int pass = -1;
  double lo = 0.0, step = 1.0;
  bool Passes(const std::vector<uint16_t>& q, size_t i) const {
    if (pass < 0) return true;
    if (i >= q.size() || q[i] == kNone) return false;
    return std::abs(static_cast<float>(lo + q[i] * step) - pass) < 0.5f;
  }
};

struct PickResult {
  bool found = false;
  PickHit hit;
  PickCounts counts;
};

// One pick's search, self-contained: copyable to another thread.
struct PickSearch {
  struct Sealed {
    std::shared_ptr<const PackedChunk> packed;
    std::array<double, 6> bounds{};  // x min, x max, y min, y max, z min, z max
    size_t size = 0;
    // The points' pass values while the filter is on (null: none), shared
    // with the view, which replaces rather than changes them.
    std::shared_ptr<const std::vector<uint16_t>> pass;
  };
  PickRay ray;
  std::vector<Sealed> sealed;
  PassTest filter;
  // At most this many blocks are tested in entry order before the rest are
  // tested a chunk at a time (CloudView::SetPickBlocksInOrder).
  size_t blocks_in_order = std::numeric_limits<size_t>::max();
  // What was found before (the growing chunk's points, tested on the GUI
  // thread): only a nearer point replaces it.
  double best_t = std::numeric_limits<double>::infinity();
  bool found = false;
  PickHit hit;
  LayerPick layers;  // null: no layers

  PickResult Run() const;
};

// A box is met if the ray comes within the tolerance at the box's far
// side: every point p of the box has t <= |p - o| <= |centre - o| + half
// its diagonal, so tol(t) is at most that times tolerance_per_t.
double PickMargin(const PickRay& ray, const double box[6]);

// Whether the point v (relative to the ray's origin) lies under the cursor
// nearer than *best (then its distance along the ray goes to *best).
// Written so that NaN fails every test: a point with a NaN coordinate (a
// chunk may hold one) is never under the cursor.
inline bool NearerOnRay(const PickRay& ray, double vx, double vy, double vz, double* best) {
  const Eigen::Vector3d& d = ray.direction;
  const double t = vx * d.x() + vy * d.y() + vz * d.z();
  if (!(t > 0 && t < *best)) return false;
  const double tol = ray.tolerance_per_t * t;
  if (!(vx * vx + vy * vy + vz * vz - t * t <= tol * tol)) return false;
  *best = t;
  return true;
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_VIEW_CLOUD_PICK_H_
