// A pick's search over the sealed chunks (cloud_pick.h), on any thread.
#include "ui/view/cloud_pick.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/cloud/payload_codec.h"
#include "core/geometry/ray_box.h"

namespace sweepscan::ui {

double PickMargin(const PickRay& ray, const double b[6]) {
  const Eigen::Vector3d lo(b[0], b[2], b[4]), hi(b[1], b[3], b[5]);
  return ray.tolerance_per_t * ((0.5 * (lo + hi) - ray.origin).norm() + 0.5 * (hi - lo).norm());
}

PickResult PickSearch::Run() const {
  PickResult out;
  out.found = found;
  out.hit = hit;
  double best_t = this->best_t;
  const Eigen::Vector3d& o = ray.origin;
  const float clip_z = static_cast<float>(ray.clip_z);
  // The clip as a whole grid step: the highest k whose float is at or below it.
  int64_t clip_k = std::numeric_limits<int64_t>::max();
  if (std::isfinite(clip_z)) {
    clip_k = GridIndex(clip_z);
    while (GridPosition(clip_k) > clip_z) --clip_k;
    while (GridPosition(clip_k + 1) <= clip_z) ++clip_k;
  }
  auto margin = [&](const double b[6]) { return PickMargin(ray, b); };
  auto nearer = [&](double vx, double vy, double vz, double* best) {
    return NearerOnRay(ray, vx, vy, vz, best);
  };
  auto take = [&](const float xyz[3]) {
    out.hit.world = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
    out.hit.local = out.hit.world;
    out.hit.layer.clear();
    out.found = true;
  };
  const RaySlabs slabs(o, ray.direction);
  // Sealed chunks: only the blocks the ray passes near
  // (PackedChunk::block_bounds(); a ray through a room revisited for hours
  // meets nearly every chunk's box, and a block, a third of a scan line, is
  // a tall slab that many rays cross), nearest entry first, until a block's
  // entry lies beyond the best point so far. A point within the tolerance
  // of the ray at t lies within margin(box) of the ray's point at t, so the ray
  // is inside the grown box there: no point of a block entered beyond the
  // best can be nearer. A compressed chunk has only the blocks it tests
  // decoded (PackedChunk::PinBlockPositions).
  //
  // Within a block met, only its pieces the ray passes near
  // (PackedChunk::PieceBox: a block is a slab across the room, a piece a
  // few decimetres of a scan line): the block's entry is its nearest met
  // piece's, and only those pieces' points are tested.
  struct Candidate {
    double enter;
    const Sealed* chunk;
    uint32_t block;
    uint32_t pieces;  // Bit p: the block's piece p is met.
  };
  // The chunk's margin serves its blocks and pieces: they lie inside its
  // box, so no point of theirs is farther from the eye than its far side.
  // Chunks are gathered on every core, their candidates joined in the
  // chunks' order (the sort's ties then fall as on one thread).
  static_assert(PackedChunk::kPiecesPerBlock <= 32, "a piece a bit");
  const double bound = best_t;  // The growing chunk's point, if it has one.
  std::vector<std::vector<Candidate>> met(sealed.size());
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, sealed.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t ci = r.begin(); ci != r.end(); ++ci) {
          const Sealed& c = sealed[ci];
          double enter = 0.0;
          const double chunk_margin = margin(c.bounds.data());
          if (c.size == 0 || !slabs.Hits(c.bounds.data(), chunk_margin, bound, &enter) ||
              enter >= bound) {
            continue;
          }
          const PackedChunk& packed = *c.packed;
          const auto& blocks = packed.block_bounds();
          for (size_t k = 0; k < blocks.size(); ++k) {
            const double box[6] = {blocks[k][0], blocks[k][1], blocks[k][2],
                                   blocks[k][3], blocks[k][4], blocks[k][5]};
            if (box[4] > clip_z || !slabs.Hits(box, chunk_margin, bound, &enter) || enter >= bound)
              continue;
            Candidate candidate{std::numeric_limits<double>::infinity(), &c,
                                static_cast<uint32_t>(k), 0};
            const size_t first_piece = k * PackedChunk::kPiecesPerBlock;
            const size_t end_piece =
                std::min(packed.piece_count(), first_piece + PackedChunk::kPiecesPerBlock);
            for (size_t p = first_piece; p < end_piece; ++p) {
              double piece[6];
              if (!packed.PieceBox(p, piece) || piece[4] > clip_z ||
                  !slabs.Hits(piece, chunk_margin, bound, &enter) || enter >= bound) {
                continue;
              }
              candidate.pieces |= uint32_t{1} << (p - first_piece);
              candidate.enter = std::min(candidate.enter, enter);
            }
            if (candidate.pieces != 0) met[ci].push_back(candidate);
          }
        }
      });
  std::vector<Candidate> candidates;
  size_t count = 0;
  for (const std::vector<Candidate>& m : met) count += m.size();
  candidates.reserve(count);
  for (const std::vector<Candidate>& m : met)
    candidates.insert(candidates.end(), m.begin(), m.end());
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.enter < b.enter; });
  // A block's point nearest the camera under the cursor and before
  // `bound`, the first such in the block's order; t infinite if none.
  struct BlockHit {
    double t = std::numeric_limits<double>::infinity();
    size_t candidate = 0;  // Ties between blocks go to the earlier entry.
    float xyz[3] = {};
  };
  auto test_block = [&](const Candidate& candidate, const PackedChunk::PositionsPin& pin,
                        double bound, BlockHit* out) {
    const Sealed& c = *candidate.chunk;
    static const std::vector<uint16_t> kNoValues;
    const std::vector<uint16_t>& pass = c.pass ? *c.pass : kNoValues;
    const PackedChunk& packed = *c.packed;
    const size_t begin = candidate.block * PackedChunk::kBlockPoints;
    const size_t end = std::min(c.size, begin + PackedChunk::kBlockPoints);
    size_t first = 0;  // The chunk's point i is the payload's i - first.
    // Compressed, the block is decoded up to its last met piece only.
    const std::shared_ptr<const ChunkPayload> payload =
        packed.BlockPositions(pin, candidate.block, &first,
                              (32 - __builtin_clz(candidate.pieces)) * PackedChunk::kPiecePoints);
    double best = bound;
    size_t best_i = c.size;
    // The met pieces' points, in the block's order (a tie goes to the first).
    auto for_pieces = [&](auto&& test) {
      for (uint32_t m = candidate.pieces; m != 0; m &= m - 1) {
        const size_t from =
            begin + static_cast<size_t>(__builtin_ctz(m)) * PackedChunk::kPiecePoints;
        test(from, std::min(end, from + PackedChunk::kPiecePoints));
      }
    };
    if (packed.positions_on_grid()) {
      // Whole millimetres after the chunk's origin (docs/cloud-store.md):
      // the ray's origin and the clip moved there, the points are not decoded.
      const std::array<int64_t, 3>& origin = packed.origin_mm();
      const double ox = o.x() - origin[0] * kGridStepM, oy = o.y() - origin[1] * kGridStepM,
                   oz = o.z() - origin[2] * kGridStepM;
      const int64_t top = std::isfinite(clip_z) ? clip_k - origin[2] : clip_k;
      for_pieces([&](size_t from, size_t to) {
        const int16_t* q = payload->xyz_mm.data() + 3 * (from - first);
        for (size_t i = from; i < to; ++i, q += 3) {
          if (q[2] > top || !filter.Passes(pass, i))
            continue;  // Clipped or not drawn: not pickable.
          if (nearer(q[0] * kGridStepM - ox, q[1] * kGridStepM - oy, q[2] * kGridStepM - oz, &best))
            best_i = i;
        }
      });
    } else {
      for_pieces([&](size_t from, size_t to) {
        const float* p = payload->xyz.data() + 3 * (from - first);
        for (size_t i = from; i < to; ++i, p += 3) {
          if (p[2] > clip_z || !filter.Passes(pass, i)) continue;
          if (nearer(p[0] - o.x(), p[1] - o.y(), p[2] - o.z(), &best)) best_i = i;
        }
      });
    }
    if (best_i == c.size) return;
    out->t = best;
    out->candidate = static_cast<size_t>(&candidate - candidates.data());
    packed.PositionOf(*payload, best_i - first, out->xyz);
  };
  // The pick is the one a single thread finds testing the blocks in entry
  // order and taking a point only if strictly nearer: the least (t, the
  // block's place in that order), whatever the threads.
  auto before = [](const BlockHit& a, const BlockHit& b) {
    return a.t < b.t || (a.t == b.t && a.candidate < b.candidate);
  };
  auto take_hit = [&](const BlockHit& h) {
    best_t = h.t;
    take(h.xyz);
  };
  // First the nearest blocks, in entry order, in waves (32, 64 then 128
  // blocks, each tested on every core, then taken in order): the best is
  // usually found there, and the next wave starts only if its first block's
  // entry lies before it.
  std::vector<BlockHit> hits;
  size_t w1 = 0;
  const size_t in_order = std::min(candidates.size(), blocks_in_order);
  for (size_t w0 = 0, wave = 32; wave <= 128 && w0 < in_order && candidates[w0].enter < best_t;
       w0 = w1, wave *= 2) {
    w1 = std::min(in_order, w0 + wave);
    hits.assign(w1 - w0, BlockHit());
    const double bound = best_t;
    tbb::parallel_for(tbb::blocked_range<size_t>(w0, w1, 8),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t k = r.begin(); k != r.end(); ++k) {
                          if (candidates[k].enter < bound) {
                            test_block(candidates[k], candidates[k].chunk->packed->PinPositions(),
                                       bound, &hits[k - w0]);
                          }
                        }
                      });
    for (const BlockHit& h : hits) {
      if (h.t < best_t) take_hit(h);  // a block without a hit keeps t = inf
    }
    out.counts.blocks_in_order += w1 - w0;
  }
  // Then the rest that enter before the best, a chunk at a time (a ray
  // along a floor driven a hundred times meets tens of thousands of blocks
  // in a thousand chunks): each chunk's positions pinned once, not once a
  // block (under a small memory budget the chunks' compressed bytes were
  // read back from the cache file thousands of times a pick, 0.3-1.2 s on
  // 100 M points under --memory-budget 64). Blocks entered beyond the best
  // any thread has found so far are skipped; each chunk's tasks keep the
  // least (t, place) of their own, and the least of those is the pick.
  std::vector<uint32_t> rest;
  for (size_t k = w1; k < candidates.size(); ++k) {
    if (candidates[k].enter < best_t) rest.push_back(static_cast<uint32_t>(k));
  }
  if (!rest.empty()) {
    std::stable_sort(rest.begin(), rest.end(), [&](uint32_t a, uint32_t b) {
      return std::less<const Sealed*>()(candidates[a].chunk, candidates[b].chunk);
    });
    std::vector<size_t> groups;  // Where each chunk's run of `rest` starts.
    for (size_t i = 0; i < rest.size(); ++i) {
      if (i == 0 || candidates[rest[i]].chunk != candidates[rest[i - 1]].chunk) groups.push_back(i);
    }
    out.counts.blocks_by_chunk = rest.size();
    out.counts.chunks = groups.size();
    groups.push_back(rest.size());
    std::atomic<double> shared_best{best_t};
    tbb::enumerable_thread_specific<BlockHit> thread_best;
    tbb::parallel_for(size_t{0}, groups.size() - 1, [&](size_t g) {
      BlockHit& mine = thread_best.local();
      const PackedChunk::PositionsPin pin =
          candidates[rest[groups[g]]].chunk->packed->PinPositions();
      for (size_t i = groups[g]; i < groups[g + 1]; ++i) {
        const Candidate& candidate = candidates[rest[i]];
        const double shared = shared_best.load(std::memory_order_relaxed);
        if (candidate.enter > shared) continue;  // Its points all lie beyond the best found.
        // Points at the best found so far, this thread's or any's, are kept
        // too: `before` gives a tie to the earlier block, and this thread
        // meets the blocks in chunk order, not entry order.
        BlockHit h;
        test_block(candidate, pin, std::nextafter(std::min(mine.t, shared), HUGE_VAL), &h);
        if (!(h.t < std::numeric_limits<double>::infinity())) continue;
        if (before(h, mine)) mine = h;
        double seen = shared;
        while (h.t < seen &&
               !shared_best.compare_exchange_weak(seen, h.t, std::memory_order_relaxed)) {
        }
      }
    });
    BlockHit best_rest;
    for (const BlockHit& h : thread_best) {
      if (before(h, best_rest)) best_rest = h;
    }
    if (best_rest.t < best_t) take_hit(best_rest);
  }
  // The layers' points compete with the cloud's: the nearest to the camera wins.
  if (layers && layers(ray, &best_t, &out.hit)) out.found = true;
  return out;
}

}  // namespace sweepscan::ui
