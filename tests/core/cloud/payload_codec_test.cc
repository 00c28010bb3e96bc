// The store's compressed payloads (core/cloud/payload_codec.h): every field
// of every point comes back bit for bit, in either layout and for data that
// does not compress; a scan of a room as an X4 makes it takes about 3 bytes
// a point; segments, and a segment's blocks, decode alone; damaged frames
// are refused, not misread.
#include "core/cloud/payload_codec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/cloud/packed_chunk.h"

namespace sweepscan {
namespace {

// A vertical scan plane swept along a 8 x 5 x 3 m room, as the robot drives
// down its middle at 5 cm/s: an X4's 5 000 samples a second, ~720 a turn,
// on the 1 mm grid, ranges in quarter millimetres, times with the decoder's
// jitter, the odd dropped beam. Positions relative to the room's middle.
ChunkPayload RoomScan(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> jitter(-900, 900);
  std::uniform_real_distribution<double> noise(-0.004, 0.004);
  ChunkPayload p;
  uint32_t dt = 0;
  uint16_t beam = 0;
  for (size_t i = 0; i < n; ++i) {
    if (rng() % 50 == 0) ++beam;  // A dropped sample (no return).
    const double t = i / 5000.0;
    const double robot_x = -3.0 + 0.05 * t;
    const double a = 2.0 * M_PI * beam / 720.0;
    const double dy = std::cos(a), dz = std::sin(a);
    // The scan plane x = robot_x: walls at y = +-2.5, floor z = -1.5 (the
    // lidar 0.2 m above it), ceiling z = 1.5.
    double r = std::numeric_limits<double>::infinity();
    if (dy != 0) r = std::min(r, 2.5 / std::abs(dy));
    if (dz > 0) r = std::min(r, 1.5 / dz);
    if (dz < 0) r = std::min(r, 0.2 / -dz);
    r += noise(rng);
    const double y = r * dy, z = r * dz;
    p.xyz_mm.push_back(static_cast<int16_t>(std::lround(robot_x * 1000)));
    p.xyz_mm.push_back(static_cast<int16_t>(std::lround(y * 1000)));
    p.xyz_mm.push_back(static_cast<int16_t>(std::lround(z * 1000)));
    p.range_q.push_back(static_cast<uint16_t>(std::lround(r / PackedChunk::kRangeStepM)));
    p.dt_ns.push_back(dt);
    p.beam.push_back(beam);
    dt += 200'000 + jitter(rng);
    if (++beam == 720) {
      beam = 0;
      dt = 0;  // A new scan run.
    }
  }
  return p;
}

// Any bits at all, in either layout.
ChunkPayload Noise(size_t n, uint32_t seed, bool grid, bool quantised) {
  std::mt19937 rng(seed);
  ChunkPayload p;
  for (size_t i = 0; i < 3 * n; ++i) {
    if (grid) {
      p.xyz_mm.push_back(static_cast<int16_t>(rng()));
    } else {
      const uint32_t bits = rng();
      float f;
      std::memcpy(&f, &bits, 4);  // NaNs and infinities too: bits, not values.
      p.xyz.push_back(f);
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (quantised) {
      p.range_q.push_back(static_cast<uint16_t>(rng()));
    } else {
      const uint32_t bits = rng();
      float f;
      std::memcpy(&f, &bits, 4);
      p.range_f.push_back(f);
    }
    p.dt_ns.push_back(rng());
    p.beam.push_back(static_cast<uint16_t>(rng()));
  }
  return p;
}

bool SameBits(const ChunkPayload& a, const ChunkPayload& b) {
  auto same = [](const auto& x, const auto& y) {
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  return same(a.xyz_mm, b.xyz_mm) && same(a.xyz, b.xyz) && same(a.range_q, b.range_q) &&
         same(a.range_f, b.range_f) && same(a.dt_ns, b.dt_ns) && same(a.beam, b.beam);
}

// Points [first, first + count) of a payload, as a payload.
ChunkPayload Slice(const ChunkPayload& p, size_t first, size_t count) {
  auto cut = [&](const auto& v, size_t per) {
    using V = std::decay_t<decltype(v)>;
    return v.empty() ? V() : V(v.begin() + per * first, v.begin() + per * (first + count));
  };
  ChunkPayload s;
  s.xyz_mm = cut(p.xyz_mm, 3);
  s.xyz = cut(p.xyz, 3);
  s.range_q = cut(p.range_q, 1);
  s.range_f = cut(p.range_f, 1);
  s.dt_ns = cut(p.dt_ns, 1);
  s.beam = cut(p.beam, 1);
  return s;
}

size_t Segments(size_t n) { return (n + kCodecSegmentPoints - 1) / kCodecSegmentPoints; }

// A payload's compressed form: its bytes and where each frame ends.
struct Encoded {
  Encoded(const ChunkPayload& p, size_t n) { EncodePayload(p, n, &bytes, &ends); }
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> ends;
};

TEST(PayloadCodecTest, ARoomScanComesBackBitForBitInAboutThreeBytesAPoint) {
  const size_t n = 65536;
  const ChunkPayload scan = RoomScan(n, 1);
  const Encoded encoded(scan, n);
  const std::vector<uint8_t>& bytes = encoded.bytes;
  const std::vector<uint32_t>& ends = encoded.ends;
  ASSERT_EQ(ends.size(), n > 0 ? Segments(n) + 1 : 0);  // Positions, then the rest.
  EXPECT_EQ(ends.back(), bytes.size());
  const double per_point = static_cast<double>(bytes.size()) / n;
  // 14 bytes unpacked; the lab's simulated drives give 3.1 (docs/cloud-store.md).
  EXPECT_LT(per_point, 4.5);
  EXPECT_GT(per_point, 1.0);  // The 4 mm of range noise cannot compress away.
  ChunkPayload back;
  std::string error;
  ASSERT_TRUE(DecodeSegments(bytes, ends, n, true, true, 0, Segments(n), false, &back, &error)) << error;
  EXPECT_TRUE(SameBits(back, scan));
}

TEST(PayloadCodecTest, AnyBitsComeBackInEitherLayoutAndAnySize) {
  for (int layout = 0; layout < 4; ++layout) {
    for (size_t n : {size_t{0}, size_t{1}, size_t{1023}, size_t{1024}, size_t{1025}, size_t{5000}}) {
      const bool grid = layout & 1, quantised = layout & 2;
      const ChunkPayload p = Noise(n, 7 + layout, grid, quantised);
      const Encoded encoded(p, n);
      const std::vector<uint8_t>& bytes = encoded.bytes;
      const std::vector<uint32_t>& ends = encoded.ends;
      ASSERT_EQ(ends.size(), n > 0 ? Segments(n) + 1 : 0);  // Positions, then the rest.
      ChunkPayload back;
      std::string error;
      ASSERT_TRUE(DecodeSegments(bytes, ends, n, grid, quantised, 0, Segments(n), false, &back, &error))
          << error;
      EXPECT_TRUE(SameBits(back, p)) << "layout " << layout << ", " << n << " points";
    }
  }
}

TEST(PayloadCodecTest, SegmentsDecodeAlone) {
  const size_t n = 5000;  // Segments of 1024: the last holds 904.
  const ChunkPayload scan = RoomScan(n, 2);
  const Encoded encoded(scan, n);
  const std::vector<uint8_t>& bytes = encoded.bytes;
  const std::vector<uint32_t>& ends = encoded.ends;
  for (size_t s0 = 0; s0 < Segments(n); ++s0) {
    for (size_t s1 = s0 + 1; s1 <= Segments(n); ++s1) {
      ChunkPayload part;
      std::string error;
      ASSERT_TRUE(DecodeSegments(bytes, ends, n, true, true, s0, s1, false, &part, &error)) << error;
      const size_t first = s0 * kCodecSegmentPoints;
      const size_t count = std::min(n, s1 * kCodecSegmentPoints) - first;
      ChunkPayload want = Slice(scan, first, count);
      EXPECT_TRUE(SameBits(part, want)) << s0 << ".." << s1;
      // The positions alone (what a pick reads).
      ASSERT_TRUE(DecodeSegments(bytes, ends, n, true, true, s0, s1, true, &part, &error)) << error;
      want.range_q.clear();
      want.dt_ns.clear();
      want.beam.clear();
      EXPECT_TRUE(SameBits(part, want)) << s0 << ".." << s1 << ", positions";
    }
  }
}

// A pick's read: one block's positions, in either position layout, for
// every block of chunks whose last segment and last block are short, and
// of noise (every group 16 bits wide) as well as of a room.
TEST(PayloadCodecTest, BlocksDecodeAlone) {
  for (int layout = 0; layout < 3; ++layout) {
    for (size_t n : {size_t{1}, size_t{256}, size_t{1024}, size_t{1300}, size_t{5000}}) {
      const bool grid = layout != 1;
      const ChunkPayload p = layout == 2 ? RoomScan(n, 5) : Noise(n, 11 + layout, grid, true);
      const Encoded encoded(p, n);
      const size_t blocks = (n + kCodecBlockPoints - 1) / kCodecBlockPoints;
      for (size_t b = 0; b <= blocks; ++b) {  // The one past the end: no points.
        ChunkPayload part;
        std::string error;
        ASSERT_TRUE(DecodeBlockPositions(encoded.bytes, encoded.ends, n, grid, b, &part, &error)) << error;
        const size_t first = std::min(n, b * kCodecBlockPoints);
        ChunkPayload want = Slice(p, first, std::min(n - first, kCodecBlockPoints));
        want.range_q.clear();
        want.dt_ns.clear();
        want.beam.clear();
        EXPECT_TRUE(SameBits(part, want)) << "layout " << layout << ", " << n << " points, block " << b;
        // Its first points alone (a pick's first pieces), in whole groups of 8.
        for (size_t points : {size_t{0}, size_t{8}, size_t{32}, size_t{100}, size_t{224}}) {
          ASSERT_TRUE(
              DecodeBlockPositions(encoded.bytes, encoded.ends, n, grid, b, &part, &error, points))
              << error;
          const size_t count = std::min({n - first, kCodecBlockPoints, (points + 7) / 8 * 8});
          ChunkPayload head = Slice(p, first, count);
          head.range_q.clear();
          head.dt_ns.clear();
          head.beam.clear();
          EXPECT_TRUE(SameBits(part, head))
              << "layout " << layout << ", " << n << " points, block " << b << ", first " << points;
        }
      }
    }
  }
  // A block of a damaged segment is refused, though the damage lies in
  // another block: the segment's CRC covers all four.
  const size_t n = 2048;
  const ChunkPayload scan = RoomScan(n, 6);
  Encoded encoded(scan, n);
  encoded.bytes[encoded.ends[0] - 8] ^= 0x10;  // Segment 0's last block.
  ChunkPayload part;
  std::string error;
  EXPECT_FALSE(DecodeBlockPositions(encoded.bytes, encoded.ends, n, true, 0, &part, &error));
  EXPECT_NE(error.find("segment 0's positions"), std::string::npos) << error;
  EXPECT_TRUE(DecodeBlockPositions(encoded.bytes, encoded.ends, n, true, 4, &part, &error)) << error;
}

TEST(PayloadCodecTest, DamagedFramesAreRefusedWithTheSegment) {
  // The compressed bytes live in this process's memory and its own cache
  // file; a flipped bit there is a fault of the machine. Each frame's
  // checksum catches it; the test flips bytes, truncates frames and puts
  // their boundaries out of order, and asks for a clear refusal (or, for a
  // flip in a frame's header that changes nothing decoded, the right
  // size), never a crash or a read past the end.
  const size_t n = 4096;
  const ChunkPayload scan = RoomScan(n, 3);
  const Encoded encoded(scan, n);
  const std::vector<uint8_t>& bytes = encoded.bytes;
  const std::vector<uint32_t>& ends = encoded.ends;
  std::mt19937 rng(4);
  size_t refused = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<uint8_t> damaged = bytes;
    std::vector<uint32_t> damaged_ends = ends;
    switch (trial % 3) {
      case 0:
        for (int k = 0; k < 1 + trial % 5; ++k) damaged[rng() % damaged.size()] ^= static_cast<uint8_t>(1 + rng() % 255);
        break;
      case 1:  // A frame cut short (segment 1's positions).
        damaged_ends[1] = damaged_ends[0] + (damaged_ends[1] - damaged_ends[0]) * (rng() % 100) / 100;
        break;
      default:  // Frame boundaries out of order (segments 0 and 1).
        std::swap(damaged_ends[0], damaged_ends[1]);
        break;
    }
    ChunkPayload back;
    std::string error;
    if (!DecodeSegments(damaged, damaged_ends, n, true, true, 0, Segments(n), false, &back, &error)) {
      ++refused;
      EXPECT_NE(error.find("compressed chunk"), std::string::npos) << error;
    } else {
      EXPECT_EQ(back.dt_ns.size(), n);
      EXPECT_EQ(trial % 3, 0) << "a cut or misplaced frame decoded";
    }
  }
  EXPECT_GT(refused, 1950u);
}

}  // namespace
}  // namespace sweepscan
