// The compact cloud store: packed chunks give back every point they were
// given, bit for bit (positions on the 1 mm grid in 16 bits, others as
// floats), in memory and after being paged out to the cache file
// and read back; compressed above the unpacked budget and unpacked again;
// the pager keeps the resident bytes within its budget and leaves no file
// behind; the census counts every point in its 0.5 m cube.
#include "core/cloud/packed_chunk.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>

#include "core/cloud/cloud_pager.h"

namespace sweepscan {
namespace {

// A fresh empty folder, removed with the object.
struct ScratchDir {
  ScratchDir() {
    std::string t = ::testing::TempDir() + "/sweepscan_pager_XXXXXX";
    path = mkdtemp(&t[0]);
  }
  ~ScratchDir() { std::filesystem::remove_all(path); }
  bool empty() const { return std::filesystem::is_empty(path); }
  std::string path;
};

// Points as the assembler makes them from an X4 (positions on the cloud's
// 1 mm grid, ranges in the X4's quarter millimetres) or, with `any_range`,
// from a lidar with float ranges, or with `off_grid` from elsewhere; scans
// of ~700 samples, 0.2 ms apart, with the odd long gap (a paused drive),
// a pose source change and a time that goes back (a new recording).
std::vector<CloudPoint> MakePoints(size_t n, uint32_t seed, bool any_range, bool off_grid = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-30.0f, 30.0f);
  std::uniform_int_distribution<int> raw(480, 40000);  // 0.12 .. 10 m in quarter mm
  std::uniform_real_distribution<float> any(0.1f, 80.0f);
  std::vector<CloudPoint> points(n);
  int64_t t = 1'700'000'000'000'000'000;
  uint32_t scan = 7;
  uint16_t beam = 0;
  for (size_t i = 0; i < n; ++i) {
    CloudPoint& p = points[i];
    p.x = coord(rng);
    p.y = coord(rng);
    p.z = coord(rng) * 0.1f;
    if (!off_grid) {
      p.x = SnapToGrid(p.x);
      p.y = SnapToGrid(p.y);
      p.z = SnapToGrid(p.z);
    }
    p.range_m = any_range ? any(rng) : static_cast<float>(raw(rng) * PackedChunk::kRangeStepM);
    t += 200'000 + (rng() % 1000);
    if (i % 5000 == 4999) t += 9'000'000'000;  // A 9 s gap: beyond 32 bits of ns.
    if (i == n / 2) t -= 50'000'000'000;        // Time goes back.
    p.time_ns = t;
    if (++beam == 700) {
      beam = 0;
      ++scan;
    }
    p.scan = scan;
    p.beam = beam;
    p.pose_source = i < n / 3 ? 0 : 2;
    p.flags = (i / 900) % 2;
  }
  return points;
}

::testing::AssertionResult SamePoints(const std::vector<CloudPoint>& a,
                                      const std::vector<CloudPoint>& b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << a.size() << " vs " << b.size();
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(&a[i], &b[i], sizeof(CloudPoint)) != 0) {
      return ::testing::AssertionFailure()
             << "point " << i << ": time " << a[i].time_ns << " vs " << b[i].time_ns << ", range "
             << a[i].range_m << " vs " << b[i].range_m << ", scan " << a[i].scan << " vs "
             << b[i].scan;
    }
  }
  return ::testing::AssertionSuccess();
}

TEST(PackedChunkTest, GivesBackEveryPointBitForBitInFourteenBytes) {
  const auto points = MakePoints(65536, 1, false);
  const auto chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  std::vector<CloudPoint> back;
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
  // Positions as 16-bit millimetres after the chunk's origin (the points
  // span 60 m: up to +-30 000 steps), ranges as 16-bit quarter millimetres.
  EXPECT_TRUE(chunk->positions_on_grid());
  EXPECT_TRUE(chunk->ranges_quantised());
  EXPECT_EQ(chunk->payload_bytes(), 14u * points.size());
  // The runs: a scan lasts 0.14 s, so ~1 run per 700 points (plus the gaps,
  // the source and flag changes); 24 bytes each are well under a byte a point.
  EXPECT_LT(chunk->runs().size() * sizeof(ScanRun), points.size() / 8);
  EXPECT_EQ(chunk->first_time_ns(), points.front().time_ns);
  // Bounds hold every point.
  for (const CloudPoint& p : points) {
    EXPECT_GE(p.x, chunk->bounds()[0]);
    EXPECT_LE(p.x, chunk->bounds()[1]);
    EXPECT_GE(p.z, chunk->bounds()[4]);
    EXPECT_LE(p.z, chunk->bounds()[5]);
  }
  // PositionOf() decodes them as the view reads them.
  const auto payload = chunk->Pin();
  for (size_t i = 0; i < points.size(); i += 997) {
    float xyz[3];
    chunk->PositionOf(*payload, i, xyz);
    EXPECT_EQ(xyz[0], points[i].x);
    EXPECT_EQ(xyz[1], points[i].y);
    EXPECT_EQ(xyz[2], points[i].z);
  }
}

TEST(PackedChunkTest, BlockBoundsHoldTheirPointsAndAreAttained) {
  // A last block of 100 points; one chunk on the grid, one off it.
  for (const bool off_grid : {false, true}) {
    const auto points = MakePoints(3 * PackedChunk::kBlockPoints + 100, 5, false, off_grid);
    const auto chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
    const auto& blocks = chunk->block_bounds();
    ASSERT_EQ(blocks.size(), 4u);
    for (size_t k = 0; k < blocks.size(); ++k) {
      std::array<bool, 6> attained{};
      for (size_t i = k * PackedChunk::kBlockPoints;
           i < std::min(points.size(), (k + 1) * PackedChunk::kBlockPoints); ++i) {
        const float v[3] = {points[i].x, points[i].y, points[i].z};
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(v[a], blocks[k][2 * a]) << "block " << k << " point " << i;
          EXPECT_LE(v[a], blocks[k][2 * a + 1]) << "block " << k << " point " << i;
          attained[2 * a] = attained[2 * a] || v[a] == blocks[k][2 * a];
          attained[2 * a + 1] = attained[2 * a + 1] || v[a] == blocks[k][2 * a + 1];
        }
      }
      for (int a = 0; a < 6; ++a) EXPECT_TRUE(attained[a]) << "block " << k << " side " << a;
    }
  }
}

// A scan line's pieces: every point inside its piece's box, each side
// within one step (a 255th of the block's box) of the point that attains
// it, so a ray passing a block's slab away from the points misses the
// pieces; a piece without a finite coordinate has no box.
TEST(PackedChunkTest, PieceBoxesHoldTheirPointsWithinAStepOfTheirBlocks) {
  std::vector<CloudPoint> points;
  for (size_t i = 0; i < 3 * PackedChunk::kBlockPoints + 40; ++i) {  // a short last piece
    const double a = 2.0 * M_PI * static_cast<double>(i) / 700.0;    // an X4's turn
    CloudPoint p;
    p.x = GridPosition(GridIndex(static_cast<float>(0.0002 * i)));
    p.y = GridPosition(GridIndex(static_cast<float>(2.5 * std::cos(a))));
    p.z = GridPosition(GridIndex(static_cast<float>(1.2 + 1.2 * std::sin(a))));
    p.range_m = 2.5f;
    points.push_back(p);
  }
  // Then with NaNs (off the grid: positions kept as floats), and an
  // infinite coordinate (its block's pieces keep the block's side there).
  for (const bool with_nan : {false, true}) {
    if (with_nan) {
      const float nan = std::numeric_limits<float>::quiet_NaN();
      for (size_t i = 2 * PackedChunk::kPiecePoints; i < 3 * PackedChunk::kPiecePoints; ++i) {
        points[i].x = points[i].y = points[i].z = nan;  // piece 2: no point at all
      }
      points[5 * PackedChunk::kPiecePoints + 3].y = nan;  // piece 5: one coordinate missing
      points[PackedChunk::kBlockPoints + 7].z = std::numeric_limits<float>::infinity();
    }
    const auto chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
    ASSERT_EQ(chunk->positions_on_grid(), !with_nan);
    ASSERT_EQ(chunk->piece_count(),
              (points.size() + PackedChunk::kPiecePoints - 1) / PackedChunk::kPiecePoints);
    for (size_t p = 0; p < chunk->piece_count(); ++p) {
      double box[6];
      if (with_nan && p == 2) {
        EXPECT_FALSE(chunk->PieceBox(p, box));
        continue;
      }
      ASSERT_TRUE(chunk->PieceBox(p, box)) << p;
      const std::array<float, 6>& block = chunk->block_bounds()[p / PackedChunk::kPiecesPerBlock];
      double attained[6] = {HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
      for (size_t i = p * PackedChunk::kPiecePoints;
           i < std::min(points.size(), (p + 1) * PackedChunk::kPiecePoints); ++i) {
        const float v[3] = {points[i].x, points[i].y, points[i].z};
        for (int a = 0; a < 3; ++a) {
          if (std::isnan(v[a])) continue;
          EXPECT_GE(v[a], box[2 * a]) << "piece " << p << " point " << i;
          EXPECT_LE(v[a], box[2 * a + 1]) << "piece " << p << " point " << i;
          attained[2 * a] = std::min<double>(attained[2 * a], v[a]);
          attained[2 * a + 1] = std::max<double>(attained[2 * a + 1], v[a]);
        }
      }
      for (int a = 0; a < 3; ++a) {
        const double step = (static_cast<double>(block[2 * a + 1]) - block[2 * a]) / 255.0;
        if (!std::isfinite(step)) {  // The infinite one's block: its side.
          EXPECT_EQ(box[2 * a], block[2 * a]) << "piece " << p << " axis " << a;
          EXPECT_EQ(box[2 * a + 1], block[2 * a + 1]) << "piece " << p << " axis " << a;
          continue;
        }
        EXPECT_LE(attained[2 * a] - box[2 * a], step * (1 + 1e-9))
            << "piece " << p << " axis " << a;
        EXPECT_LE(box[2 * a + 1] - attained[2 * a + 1], step * (1 + 1e-9))
            << "piece " << p << " axis " << a;
      }
    }
  }
}

TEST(PackedChunkTest, TheCensusCountsEveryPointInItsCube) {
  // Scattered points, a scan line's worth of neighbours and points on cube
  // faces, at both signs; and a chunk spanning more cubes than the dense
  // count takes (2^18: here 1.5 km x 60 m x 6 m), counted the other way.
  auto room = MakePoints(20000, 9, false);
  for (size_t i = 0; i < 5000; ++i) {
    CloudPoint& p = room[i];
    p.x = SnapToGrid(-3.0f + 0.002f * static_cast<float>(i));
    p.y = SnapToGrid(1.25f);
    p.z = SnapToGrid(0.5f * std::sin(0.01f * static_cast<float>(i)));
  }
  const float faces[] = {0.0f, 0.5f, -0.5f, 1.0f, -1.0f, 29.5f};
  for (size_t i = 0; i < 6; ++i) room[6000 + i].x = room[6000 + i].y = room[6000 + i].z = faces[i];
  auto wide = MakePoints(3000, 10, false);
  for (size_t i = 0; i < wide.size(); ++i) {
    wide[i].x = SnapToGrid(-750.0f + 0.5f * static_cast<float>(i));
  }
  // And a point with a NaN coordinate, which the bounds do not hold.
  auto with_nan = MakePoints(1000, 11, false, /*off_grid=*/true);
  with_nan[500].y = std::numeric_limits<float>::quiet_NaN();
  for (const auto* points : {&room, &wide, &with_nan}) {
    const auto chunk = PackedChunk::Pack(points->data(), points->size(), nullptr);
    // The cubes found independently: floor(v / 0.5) in double, offset by 2^15.
    std::map<uint64_t, uint32_t> expected;
    for (const CloudPoint& p : *points) {
      uint64_t key = 0;
      for (const float v : {p.x, p.y, p.z}) {
        if (std::isnan(v)) {  // CellIndex's low end
          key = key << 16;
          continue;
        }
        key = key << 16 |
              static_cast<uint64_t>(static_cast<int64_t>(std::floor(static_cast<double>(v) / 0.5)) +
                                    32768);
      }
      ++expected[key];
    }
    const auto& keys = chunk->cell_keys();
    const auto& counts = chunk->cell_counts();
    ASSERT_EQ(keys.size(), expected.size());
    ASSERT_EQ(counts.size(), expected.size());
    size_t k = 0;
    for (const auto& [key, count] : expected) {
      EXPECT_EQ(keys[k], key) << "cube " << k;  // ascending, as the map
      EXPECT_EQ(counts[k], count) << "cube " << k;
      ++k;
    }
    // Each point lies in the box of its own key: lo <= v < hi an axis.
    for (const CloudPoint& p : *points) {
      const float v[3] = {p.x, p.y, p.z};
      if (std::isnan(p.y)) continue;
      const std::array<float, 6> box = PackedChunk::CellBox(PackedChunk::CellKey(v));
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(box[2 * a], v[a]);
        EXPECT_LT(v[a], box[2 * a + 1]);
      }
    }
  }
}

TEST(PackedChunkTest, TheGridStepsComeBackExactlyWithinEightKilometres) {
  // Every whole millimetre within +-8.192 km: the float of k * 0.001 is
  // k / 1000's and its grid index is k again (the store's exactness rests
  // on it; cloud.h).
  size_t bad = 0;
  for (int64_t k = -8'192'000; k <= 8'192'000; ++k) {
    const float v = GridPosition(k);
    if (GridIndex(v) != k || v != static_cast<float>(static_cast<double>(k) / 1000.0)) ++bad;
  }
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(SnapToGrid(1.23449f), GridPosition(1234));
  EXPECT_EQ(SnapToGrid(-0.0005001f), GridPosition(-1));
  EXPECT_EQ(SnapToGrid(SnapToGrid(3.14159f)), SnapToGrid(3.14159f));
  EXPECT_TRUE(std::isnan(SnapToGrid(std::nanf(""))));
}

TEST(PackedChunkTest, PositionsOffTheGridOrWiderThan65MetresStayFloats) {
  // Points from elsewhere (a PLY opened, a transformed session).
  auto points = MakePoints(10000, 7, false, true);
  auto chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  std::vector<CloudPoint> back;
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
  EXPECT_FALSE(chunk->positions_on_grid());
  EXPECT_EQ(chunk->payload_bytes(), 20u * points.size());

  // One point off the grid among thousands on it.
  points = MakePoints(10000, 8, false);
  points[5000].y = std::nextafter(points[5000].y, 100.0f);
  chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  back.clear();
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
  EXPECT_FALSE(chunk->positions_on_grid());

  // On the grid but 65.535 m wide: 65 535 steps do not fit 16 bits about
  // any origin; 65.534 m do.
  points = MakePoints(1000, 9, false);
  points[10].x = GridPosition(-32767);
  points[20].x = GridPosition(32767);
  chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  EXPECT_TRUE(chunk->positions_on_grid());
  back.clear();
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
  points[20].x = GridPosition(32768);
  chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  EXPECT_FALSE(chunk->positions_on_grid());
  back.clear();
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));

  // Far from the origin (a building's georeferenced frame, 5 km out): the
  // origin moves with the chunk.
  points = MakePoints(1000, 10, false);
  for (CloudPoint& p : points) p.x = SnapToGrid(p.x + 5000.0f);
  chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  EXPECT_TRUE(chunk->positions_on_grid());
  back.clear();
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
}

TEST(PackedChunkTest, RangesThatAreNotQuarterMillimetresStayFloats) {
  const auto points = MakePoints(10000, 2, true);
  const auto chunk = PackedChunk::Pack(points.data(), points.size(), nullptr);
  std::vector<CloudPoint> back;
  chunk->Decode(&back);
  EXPECT_TRUE(SamePoints(back, points));
  EXPECT_EQ(chunk->payload_bytes(), 16u * points.size());
  uint16_t q = 0;
  EXPECT_TRUE(QuantiseRange(2.5f, &q));
  EXPECT_EQ(q, 10000);
  EXPECT_FALSE(QuantiseRange(2.50001f, &q));
  EXPECT_FALSE(QuantiseRange(20.0f, &q));  // Beyond 16 bits of quarter mm.
  EXPECT_FALSE(QuantiseRange(-1.0f, &q));
}

TEST(PackedChunkTest, PointChunksPackWhatTheySealAndFlattenExactly) {
  const auto points = MakePoints(25000, 3, false);
  PointChunks chunks(4096);
  for (const CloudPoint& p : points) chunks.Append(p);
  EXPECT_EQ(chunks.SealedChunks().size(), 25000u / 4096u);
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
}

TEST(CloudPagerTest, SmallCloudsStayUnpacked) {
  // Under the unpacked budget (128 MiB by default: ~9.5 M points) nothing is
  // compressed: a small cloud costs no encoding and no decoding.
  CloudPager pager(size_t{1} << 30);
  const auto points = MakePoints(20 * 4096, 8, false);
  PointChunks chunks(4096, &pager);
  for (const CloudPoint& p : points) chunks.Append(p);
  EXPECT_EQ(pager.packed_chunks(), 0u);
  EXPECT_EQ(pager.unpacked_bytes(), 20u * 14 * 4096);
  EXPECT_EQ(pager.resident_bytes(), pager.unpacked_bytes());
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_EQ(pager.unpacks(), 0u);
}

TEST(CloudPagerTest, CompressesAboveTheUnpackedBudgetAndUnpacksExactly) {
  CloudPager pager(size_t{1} << 30);
  const size_t per_chunk = 14 * 4096;
  pager.SetUnpackedBudget(3 * per_chunk);
  const auto points = MakePoints(20 * 4096, 9, false);
  PointChunks chunks(4096, &pager);
  for (const CloudPoint& p : points) {
    chunks.Append(p);
    ASSERT_LE(pager.unpacked_bytes(), 3 * per_chunk);
  }
  EXPECT_EQ(pager.packed_chunks(), 17u);  // Each compressed once, on eviction.
  const auto sealed = chunks.SealedChunks();
  EXPECT_FALSE(sealed.front()->unpacked());
  EXPECT_TRUE(sealed.front()->resident());  // Compressed, in memory.
  EXPECT_GT(sealed.front()->packed_bytes(), 0u);
  EXPECT_TRUE(sealed.back()->unpacked());
  EXPECT_EQ(pager.paged_out_chunks(), 0u);
  EXPECT_EQ(pager.page_outs(), 0u);

  // Unpacked for each reader, twice over, and not kept: the chunks kept
  // unpacked are still the newest, and nothing is compressed again.
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_EQ(pager.unpacks(), 34u);
  EXPECT_EQ(pager.packed_chunks(), 17u);
  EXPECT_TRUE(sealed.back()->unpacked());
  EXPECT_FALSE(sealed.front()->unpacked());

  // A block's positions of a compressed chunk, decoded alone, the chunk
  // left compressed.
  const uint64_t unpacks = pager.unpacks();
  const auto& c = sealed[2];
  ASSERT_FALSE(c->unpacked());
  size_t first = 0;
  const auto part = c->PinBlockPositions(5, &first);
  EXPECT_EQ(first, 1280u);  // Blocks of kBlockPoints, the second of segment 1.
  EXPECT_EQ(part->xyz_mm.size(), 3u * 256);
  EXPECT_TRUE(part->dt_ns.empty());
  for (size_t i = 1280; i < 1536; ++i) {
    float xyz[3];
    c->PositionOf(*part, i - first, xyz);
    EXPECT_EQ(xyz[0], points[2 * 4096 + i].x);
    EXPECT_EQ(xyz[2], points[2 * 4096 + i].z);
    EXPECT_EQ(xyz[1], points[2 * 4096 + i].y);
  }
  EXPECT_EQ(pager.unpacks(), unpacks);
  EXPECT_FALSE(c->unpacked());
}

TEST(CloudPagerTest, PagesOutAboveTheBudgetAndReadsBackExactly) {
  ScratchDir dir;
  const size_t per_chunk = 14 * 4096;
  CloudPager pager(3 * per_chunk, dir.path);  // Half of it for unpacked payloads: one chunk.
  const auto points = MakePoints(20 * 4096, 4, false);
  PointChunks chunks(4096, &pager);
  for (const CloudPoint& p : points) {
    chunks.Append(p);
    // The most recently used chunk stays unpacked whatever the budget.
    ASSERT_LE(pager.resident_bytes(), 3 * per_chunk + per_chunk);
  }
  EXPECT_GT(pager.page_outs(), 0u);
  EXPECT_GT(pager.paged_out_chunks(), 0u);
  EXPECT_EQ(pager.page_outs(), pager.paged_out_chunks());  // Each written once, not yet read.
  const auto sealed = chunks.SealedChunks();
  EXPECT_FALSE(sealed.front()->resident());
  EXPECT_TRUE(sealed.back()->unpacked());
  size_t in_file = 0;
  for (const auto& c : sealed) in_file += c->resident() ? 0 : c->packed_bytes();
  EXPECT_EQ(pager.file_bytes(), in_file);  // The compressed bytes, nothing else.
  // The cache file has no name: nothing in the directory, during or after.
  EXPECT_TRUE(dir.empty());

  // Everything comes back, twice over (the second time from pages read in
  // again after they were dropped once more; a payload is written once).
  const size_t file_bytes = pager.file_bytes();
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_GT(pager.page_ins(), 0u);
  EXPECT_LE(pager.resident_bytes(), 3 * per_chunk + per_chunk);
  EXPECT_GE(pager.file_bytes(), file_bytes);

  // A bigger budget keeps what is read back, compressed, in memory.
  pager.SetBudget(100 * per_chunk);
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_EQ(pager.paged_out_chunks(), 0u);
  for (const auto& c : sealed) EXPECT_TRUE(c->resident());
}

TEST(CloudPagerTest, GridAndFloatChunksPageOutAndBackAlike) {
  // Chunks of either layout (positions in 16-bit steps or floats, ranges in
  // quarter millimetres or floats) share one cache file.
  ScratchDir dir;
  CloudPager pager(1, dir.path);  // Everything but the newest goes out.
  std::vector<CloudPoint> points;
  for (int k = 0; k < 4; ++k) {
    const auto part = MakePoints(3000, 20 + k, k % 2 == 1, k >= 2);
    points.insert(points.end(), part.begin(), part.end());
  }
  PointChunks chunks(3000, &pager);
  for (const CloudPoint& p : points) chunks.Append(p);
  const auto sealed = chunks.SealedChunks();
  ASSERT_EQ(sealed.size(), 4u);
  EXPECT_EQ(sealed[0]->payload_bytes(), 14u * 3000);
  EXPECT_EQ(sealed[1]->payload_bytes(), 16u * 3000);
  EXPECT_EQ(sealed[2]->payload_bytes(), 20u * 3000);
  EXPECT_EQ(sealed[3]->payload_bytes(), 22u * 3000);
  EXPECT_EQ(pager.file_bytes(), sealed[0]->packed_bytes() + sealed[1]->packed_bytes() +
                                    sealed[2]->packed_bytes());
  for (int k = 0; k < 3; ++k) EXPECT_FALSE(sealed[k]->resident()) << k;
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
  EXPECT_GE(pager.page_ins(), 3u);
}

TEST(CloudPagerTest, TheCacheFileIsEmptiedWhenItsCloudGoes) {
  // The app opens one session after another in one process: a cloud's file
  // space comes back when the cloud is cleared, not at exit.
  ScratchDir dir;
  CloudPager pager(1, dir.path);
  const auto points = MakePoints(10 * 1024, 6, false);
  for (int round = 0; round < 2; ++round) {
    auto chunks = std::make_unique<PointChunks>(1024, &pager);
    for (const CloudPoint& p : points) chunks->Append(p);
    size_t packed = 0;
    {
      const auto sealed = chunks->SealedChunks();  // Holding them keeps them.
      for (size_t k = 0; k + 1 < sealed.size(); ++k) packed += sealed[k]->packed_bytes();
    }
    EXPECT_EQ(pager.file_bytes(), packed) << round;  // All but the newest, each written once.
    EXPECT_TRUE(SamePoints(chunks->Flatten(), points));
    chunks.reset();
    EXPECT_EQ(pager.file_bytes(), 0u) << round;
    EXPECT_EQ(pager.resident_bytes(), 0u);
    EXPECT_EQ(pager.paged_out_chunks(), 0u);
    EXPECT_EQ(pager.packed_chunks(), 0u);
  }
}

// One session after another from different disks: once the first cloud is
// gone, the next one's cache file opens beside the next session (a USB disk
// is not kept busy, a RAM-backed fallback is not kept for good).
TEST(CloudPagerTest, TheNextCloudsCacheFileOpensWhereItsSessionIs) {
  ScratchDir first, second;
  CloudPager pager(1, first.path);
  const auto points = MakePoints(4 * 1024, 7, false);
  auto chunks = std::make_unique<PointChunks>(1024, &pager);
  for (const CloudPoint& p : points) chunks->Append(p);
  EXPECT_EQ(pager.file_directory(), first.path);
  pager.SetCacheDirectory(second.path);  // Opened while the first cloud lives.
  EXPECT_EQ(pager.file_directory(), first.path);  // Its chunks are in the file.
  chunks.reset();
  EXPECT_EQ(pager.file_directory(), "");
  chunks = std::make_unique<PointChunks>(1024, &pager);
  for (const CloudPoint& p : points) chunks->Append(p);
  EXPECT_EQ(pager.file_directory(), second.path);
  EXPECT_TRUE(SamePoints(chunks->Flatten(), points));
}

// A cache file that cannot be written (a full disk: the file opens, the
// write fails) keeps that cloud in memory, whole, and the budget the
// operator set: the next cloud pages out again. The budget was lifted for
// the rest of the process. The file size limit stands in for the full disk
// (SIGXFSZ ignored: the write fails with EFBIG instead).
TEST(CloudPagerTest, AFailedCacheWriteKeepsTheCloudAndTheBudgetForTheNext) {
  ScratchDir dir;
  CloudPager pager(1, dir.path);
  const auto points = MakePoints(6 * 1024, 8, false);
  struct rlimit old_limit;
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit tiny = old_limit;
  tiny.rlim_cur = 512;  // below one chunk's compressed bytes
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &tiny), 0);
  auto chunks = std::make_unique<PointChunks>(1024, &pager);
  for (const CloudPoint& p : points) chunks->Append(p);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old_limit), 0);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_TRUE(pager.cache_failed());
  EXPECT_EQ(pager.paged_out_chunks(), 0u);
  EXPECT_EQ(pager.budget(), 1u);
  EXPECT_TRUE(SamePoints(chunks->Flatten(), points));
  // The next cloud, made while this one still lives (the app builds a
  // session's cloud before it lets the last one go): paged out once the
  // retry interval has passed (here at once), its points all there.
  pager.SetCacheRetryInterval(std::chrono::milliseconds(0));
  auto next = std::make_unique<PointChunks>(1024, &pager);
  for (const CloudPoint& p : points) next->Append(p);
  EXPECT_FALSE(pager.cache_failed());
  EXPECT_GT(pager.paged_out_chunks(), 0u);
  EXPECT_GT(pager.file_bytes(), 0u);
  EXPECT_TRUE(SamePoints(next->Flatten(), points));
  EXPECT_TRUE(SamePoints(chunks->Flatten(), points));
  chunks.reset();
  next.reset();
  EXPECT_FALSE(pager.cache_failed());
  EXPECT_EQ(pager.file_bytes(), 0u);
}

// A snapshot is the cloud as it was when taken, decoded later on another
// thread while the cloud grows and pages out (an export or an evaluation on
// a job while the recording goes on).
TEST(CloudPagerTest, ASnapshotDecodedOnAnotherThreadIsTheCloudWhenItWasTaken) {
  ScratchDir dir;
  CloudPager pager(1, dir.path);  // Everything but the newest pages out.
  const auto points = MakePoints(10 * 1024 + 300, 9, false);
  PointChunks chunks(1024, &pager);
  for (size_t i = 0; i < 5 * 1024 + 300; ++i) chunks.Append(points[i]);
  const CloudSnapshotRef snapshot = chunks.Snapshot();
  EXPECT_EQ(snapshot.size(), 5u * 1024 + 300);
  std::vector<CloudPoint> decoded;
  std::thread job([&] { decoded = snapshot.Flatten(); });
  for (size_t i = 5 * 1024 + 300; i < points.size(); ++i) chunks.Append(points[i]);
  job.join();
  EXPECT_TRUE(SamePoints(decoded,
                         std::vector<CloudPoint>(points.begin(), points.begin() + 5 * 1024 + 300)));
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
}

TEST(CloudPagerTest, ConcurrentReadersWhileTheWriterPagesOut) {
  // The view (GUI thread) and an export (a job thread) read sealed chunks
  // while the processing thread appends and the pager evicts.
  // A budget of two chunks: one unpacked, the rest compressed and paged.
  ScratchDir dir;
  CloudPager pager(2 * 14 * 1024, dir.path);
  const auto points = MakePoints(64 * 1024, 5, false);
  PointChunks chunks(1024, &pager);
  std::atomic<bool> done{false};
  std::atomic<size_t> bad{0}, checked{0};
  std::atomic<int> started{0};
  auto reader = [&] {
    ++started;
    for (;;) {
      const bool last = done;  // One whole pass after the writer is done.
      const auto sealed = chunks.SealedChunks();
      size_t offset = 0;
      for (const auto& c : sealed) {
        std::vector<CloudPoint> got;
        c->Decode(&got);
        for (size_t i = 0; i < got.size(); ++i) {
          if (std::memcmp(&got[i], &points[offset + i], sizeof(CloudPoint)) != 0) ++bad;
        }
        offset += got.size();
        ++checked;
      }
      if (last) break;
    }
  };
  std::thread a(reader), b(reader);
  while (started < 2) std::this_thread::yield();  // Readers running before the writer.
  for (const CloudPoint& p : points) chunks.Append(p);
  done = true;
  a.join();
  b.join();
  EXPECT_EQ(bad.load(), 0u);
  EXPECT_GT(checked.load(), 0u);
  EXPECT_GT(pager.page_outs(), 0u);
  EXPECT_GT(pager.unpacks(), 0u);
  EXPECT_TRUE(SamePoints(chunks.Flatten(), points));
}

}  // namespace
}  // namespace sweepscan
