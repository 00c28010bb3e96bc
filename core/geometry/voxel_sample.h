// A spatially even sample of a growing cloud within a point budget: one
// representative point per cell of a grid, for the view's level of detail
// while the camera moves.
//
// Why: a scan is dense where the robot drove and thin far from it (an X4's
// beams spread with range, and a lane driven a hundred times holds a hundred
// times the points). Every s-th point in time keeps that density: at 100 M
// points the floor along the lane got most of a 30 000-point budget and the
// far walls the least. One point per cell spends the budget per volume, as
// Potree's and CloudCompare's octree levels do (one sample per node cell).
//
// The scheme: cells are boxes of h_x x h_y x h_z on a grid anchored at the
// origin, h_a = first_cell * 2^e_a. A point offered takes its cell if the cell
// has no representative; a representative is never replaced. When the sample
// holds more than its budget, the cells double along one axis (the axes in
// turn, so cells stay within a factor two of cubes): two neighbouring cells
// become one, and of their representatives the one offered first (smallest
// (source, index)) stays. Because the grids are nested (a coarse cell is the
// union of two fine ones), every coarse cell that holds a point of the cloud
// offered holds a fine cell that held one, so it keeps a representative:
// * the sample covers: every cell with an offered point has exactly one
//   representative, and it lies in that cell;
// * the samples are nested: after merging, the sample is a subset of the one
//   before, and offering more only adds; the view's rest level can therefore
//   always draw a superset of what the motion level drew
//   (docs/cloud-store.md, "Progressive passes");
// * its size is the number of occupied cells: about area / h^2 for surfaces,
//   so one doubling takes it to between half (a surface along the axis
//   doubled: its cells pair up) and all of it (a surface across that axis,
//   one cell thick in it), never down to a quarter as doubling all three at
//   once would.
//
// Cost: one hash lookup a point offered; a merge visits every representative
// once. Positions are floats (the view's), cells indexed in 21 bits an axis
// (+-2^20 cells; coordinates beyond are clamped to the outermost cell).
#ifndef SWEEPSCAN_CORE_GEOMETRY_VOXEL_SAMPLE_H_
#define SWEEPSCAN_CORE_GEOMETRY_VOXEL_SAMPLE_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace sweepscan {

class VoxelSample {
 public:
  // budget: the most representatives kept (at least 1). first_cell: the
  // finest cell's side (m).
  explicit VoxelSample(size_t budget, double first_cell = 0.01);

  // Forgets every representative; the cells return to first_cell.
  void Clear();
  // A smaller budget merges cells at once; a larger one only applies to what
  // is offered next (the sample cannot split a cell without the points it
  // was not given: the caller offers them again after Clear()).
  void SetBudget(size_t budget);
  size_t budget() const { return budget_; }

  // Offers n points of `source` (xyz[3 k ..]: point k, index[k] its index
  // there; offer each source's points in increasing index). Appends to
  // *taken the k of each point that became a representative. Does not
  // merge: call Fit() once the batch is in, so that the caller learns the
  // new representatives before some of them are merged away.
  void Offer(uint32_t source, const float* xyz, const uint32_t* index, size_t n,
             std::vector<uint32_t>* taken);
  // Merges cells until the sample is within its budget. True if it merged
  // (then representatives may have gone: ask Holds()).
  bool Fit();
  // Whether point `index` of `source`, at xyz, is still a representative.
  bool Holds(uint32_t source, uint32_t index, const float* xyz) const;

  size_t size() const { return reps_.size(); }
  const std::array<double, 3>& cell() const { return cell_; }
  // Bumped by every merge and by Clear().
  uint64_t generation() const { return generation_; }

 private:
  struct Rep {
    uint32_t source;
    uint32_t index;
    float xyz[3];
  };
  uint64_t Key(const float* xyz) const;
  // The slot of `key` in the open-addressed table: its own, or the empty
  // one where it would go (linear probing; the table at most half full).
  size_t Slot(uint64_t key) const;
  void Rehash(size_t capacity);  // The table for reps_ as they are.
  void Merge();                  // Doubles the cells along the next axis.

  static constexpr uint64_t kEmpty = ~uint64_t{0};
  size_t budget_;
  double first_cell_;
  std::array<double, 3> cell_;
  std::array<double, 3> inv_cell_;
  int next_axis_ = 0;
  uint64_t generation_ = 0;
  // The representatives in the order they were taken, and a hash table of
  // their cells' keys (slot -> key, and the representative's position in
  // reps_): a lookup is a probe or two in one array, where a node-based map
  // missed the cache on every candidate (the GUI thread offers every new
  // chunk's candidates: docs/cloud-store.md).
  std::vector<Rep> reps_;
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> slots_;
  size_t mask_ = 0;
  int shift_ = 54;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_GEOMETRY_VOXEL_SAMPLE_H_
