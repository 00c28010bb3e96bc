#include "core/cloud/cloud.h"
#include "core/cloud/packed_chunk.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace sweepscan {
namespace {

TEST(PointChunksTest, SealsFullChunksAndKeepsOrder) {
  PointChunks chunks(100);
  for (int i = 0; i < 250; ++i) {
    CloudPoint p;
    p.beam = static_cast<uint16_t>(i);
    chunks.Append(p);
  }
  EXPECT_EQ(chunks.SealedChunks().size(), 2u);
  EXPECT_EQ(chunks.sealed_point_count(), 200u);
  const auto all = chunks.Flatten();
  ASSERT_EQ(all.size(), 250u);
  for (int i = 0; i < 250; ++i) EXPECT_EQ(all[i].beam, i);
  chunks.Seal();
  EXPECT_EQ(chunks.sealed_point_count(), 250u);
}

TEST(PointChunksTest, ReaderSeesOnlyCompleteImmutableChunks) {
  PointChunks chunks(64);
  std::atomic<bool> done{false};
  std::atomic<size_t> bad{0};
  std::thread reader([&] {
    while (!done) {
      for (const auto& c : chunks.SealedChunks()) {
        if (c->size() != 64) ++bad;
        std::vector<CloudPoint> points;
        c->Decode(&points);
        for (size_t i = 0; i < points.size(); ++i) {
          if (points[i].scan != points[0].scan || points[i].beam != i) ++bad;
        }
      }
    }
  });
  for (uint32_t chunk = 0; chunk < 2000; ++chunk) {
    for (uint16_t i = 0; i < 64; ++i) {
      CloudPoint p;
      p.scan = chunk;
      p.beam = i;
      chunks.Append(p);
    }
  }
  done = true;
  reader.join();
  EXPECT_EQ(bad.load(), 0u);
  EXPECT_EQ(chunks.sealed_point_count(), 2000u * 64u);
}

}  // namespace
}  // namespace sweepscan
