// The processing thread's mailbox to the GUI (ui/workspace/live_batch.h):
// when it is full, a batch merges into the newest one, and every point,
// sealed chunk and the payload unpacked for it must still arrive, in order.
#include "ui/workspace/live_batch.h"

#include <gtest/gtest.h>

namespace sweepscan::ui {
namespace {

// A batch of `chunks` sealed chunks (identified by their payloads; the
// mailbox never opens a chunk) and one open-chunk point.
LiveBatch Batch(int first, int chunks, std::vector<std::shared_ptr<const ChunkPayload>>* made) {
  LiveBatch b;
  for (int i = 0; i < chunks; ++i) {
    b.sealed.push_back(nullptr);
    auto payload = std::make_shared<ChunkPayload>();
    payload->xyz = {static_cast<float>(first + i)};
    b.unpacked.push_back(payload);
    made->push_back(payload);
  }
  CloudPoint p;
  p.x = static_cast<float>(first);
  b.points.push_back(p);
  b.total_points = static_cast<size_t>(first);
  return b;
}

TEST(BatchMailboxTest, AFullMailboxMergesAndKeepsEveryUnpackedPayload) {
  BatchMailbox mailbox(2);
  std::vector<std::shared_ptr<const ChunkPayload>> made;
  mailbox.Push(Batch(0, 1, &made));
  mailbox.Push(Batch(10, 2, &made));
  mailbox.Push(Batch(20, 3, &made));  // Full: merged into the second.
  mailbox.Push(Batch(30, 1, &made));  // And this one too.
  EXPECT_EQ(mailbox.merged(), 2u);
  const std::deque<LiveBatch> got = mailbox.TakeAll();
  ASSERT_EQ(got.size(), 2u);
  std::vector<std::shared_ptr<const ChunkPayload>> arrived;
  for (const LiveBatch& b : got) {
    ASSERT_EQ(b.unpacked.size(), b.sealed.size());
    arrived.insert(arrived.end(), b.unpacked.begin(), b.unpacked.end());
  }
  ASSERT_EQ(arrived.size(), made.size());
  for (size_t i = 0; i < made.size(); ++i) EXPECT_EQ(arrived[i], made[i]) << i;
  // The open chunk's points: only the newest batch's are still open.
  ASSERT_EQ(got[1].points.size(), 1u);
  EXPECT_EQ(got[1].points[0].x, 30.0f);
  EXPECT_EQ(got[1].total_points, 30u);
}

}  // namespace
}  // namespace sweepscan::ui
