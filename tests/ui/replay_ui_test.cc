// Replaying an opened session in the desktop app (the workspace and its
// processing thread, under a real display): the replayed cloud against
// `sweepscan-cli reconstruct` point for point, and seeking.
#include <gtest/gtest.h>

#include <QObject>
#include <string>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::WaitFor;

class ReplayTest : public testing::AppFixture {
 protected:
  // The seek scenario below, on the session decoded whole (a small one) or
  // read as it replays (`read_as_it_goes`: the threshold of a large session
  // lowered to 0, hardware/station/replay_source.h).
  void SeeksInSlicesKeepThePauseAndEndWithTheCliCloud(bool read_as_it_goes);
  void APausedSeekToTheEndFinishesWhenUnpaused(bool read_as_it_goes);
  // No samples held: the session is read as it replays.
  void ExpectNoSamplesHeld() {
    const hardware::Recording* opened = workspace_->recording_opened();
    ASSERT_NE(opened, nullptr);
    EXPECT_TRUE(opened->log.scans.empty());
  }
};

void RunEventsFor(int ms) {
  WaitFor([] { return false; }, ms);
}

// Simulates the one-turn circle drive as DIR/c.sweepscan and returns the
// cloud `sweepscan-cli reconstruct` makes of it.
std::vector<CloudPoint> CircleSessionAndItsCliCloud(const std::string& dir) {
  const std::string cli = SWEEPSCAN_CLI;
  const auto sim = testing::RunCommand(cli + " simulate --scenario " + kResources.toStdString() +
                                       "/scenarios/lab_circle.json --out " + dir + "/c.ply");
  EXPECT_EQ(sim.code, 0) << sim.out;
  const auto rec =
      testing::RunCommand(cli + " reconstruct " + dir + "/c.sweepscan --out " + dir + "/cli.ply");
  EXPECT_EQ(rec.code, 0) << rec.out;
  std::vector<CloudPoint> cloud;
  EXPECT_TRUE(LoadCloud(dir + "/cli.ply", &cloud).ok());
  return cloud;
}

// The first points of `expected`, exactly: what a replay has placed so far.
::testing::AssertionResult IsAPrefix(const std::vector<CloudPoint>& shown,
                                     const std::vector<CloudPoint>& expected) {
  if (shown.size() > expected.size())
    return ::testing::AssertionFailure() << shown.size() << " points, more than all";
  for (size_t i = 0; i < shown.size(); ++i) {
    if (shown[i].x != expected[i].x || shown[i].y != expected[i].y || shown[i].z != expected[i].z) {
      return ::testing::AssertionFailure() << "point " << i << " differs";
    }
  }
  return ::testing::AssertionSuccess();
}

TEST_F(ReplayTest, ReplayGivesTheCloudThatTheCliReconstructionGives) {
  const std::string dir = tmp_.path().toStdString();
  const std::vector<CloudPoint> expected = CircleSessionAndItsCliCloud(dir);
  ASSERT_GT(expected.size(), 10000u);

  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  workspace_->OpenSession(QString::fromStdString(dir + "/c.sweepscan"), 0.0);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 120000));
  const std::vector<CloudPoint> replayed = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(replayed.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(replayed[i].x, expected[i].x) << i;
    ASSERT_EQ(replayed[i].y, expected[i].y) << i;
    ASSERT_EQ(replayed[i].z, expected[i].z) << i;
  }
}

// A seek feeds the records up to its target at full speed in slices of
// robot time, reporting its position after each (the processing thread
// answers between them; one event that fed it all froze the thread for 30 s
// and held a copy of every record on a 5.7-hour session). A paused replay
// stays paused at the target; forwards or backwards, the replay then ends
// with exactly the cloud `reconstruct` gives.
void ReplayTest::SeeksInSlicesKeepThePauseAndEndWithTheCliCloud(bool read_as_it_goes) {
  const std::string dir = tmp_.path().toStdString();
  if (read_as_it_goes) workspace_->set_stream_open_above_bytes(0);
  const std::vector<CloudPoint> expected = CircleSessionAndItsCliCloud(dir);
  ASSERT_GT(expected.size(), 10000u);

  std::vector<double> positions;
  double length = 0.0;
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayProgress, [&](double position, double len) {
    positions.push_back(position);
    length = len;
  });
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  workspace_->OpenSession(QString::fromStdString(dir + "/c.sweepscan"), 1.0);  // 1x: a replay
  ASSERT_TRUE(WaitFor([&] { return length > 0.0; }, 60000));
  workspace_->SetReplayPaused(true);
  ASSERT_GT(length, 20.0);  // One turn of a 0.83 m circle at 0.2 m/s: 26 s.
  if (read_as_it_goes) ExpectNoSamplesHeld();

  // Forwards to 90 %, paused.
  const double ahead = 0.9 * length;
  RunEventsFor(200);  // The last 1x reports before the pause.
  positions.clear();
  workspace_->SeekReplay(ahead);
  ASSERT_TRUE(
      WaitFor([&] { return !positions.empty() && positions.back() >= ahead - 1e-6; }, 60000));
  // At most 2 s of robot time a slice: ~11 reports, each further on.
  EXPECT_GE(positions.size(), static_cast<size_t>(ahead / 2.0) - 1);
  for (size_t i = 1; i < positions.size(); ++i) EXPECT_GT(positions[i], positions[i - 1]) << i;
  EXPECT_NEAR(positions.back(), ahead, 1e-6);
  const size_t reports = positions.size();
  RunEventsFor(500);
  EXPECT_EQ(positions.size(), reports) << "the paused replay went on after the seek";
  EXPECT_FALSE(finished);
  const std::vector<CloudPoint> at_ahead = workspace_->CloudSnapshot().Flatten();
  EXPECT_GT(at_ahead.size(), expected.size() / 2);
  EXPECT_TRUE(IsAPrefix(at_ahead, expected));

  // Backwards to 30 %, still paused: the cloud starts over.
  positions.clear();
  const double back = 0.3 * length;
  workspace_->SeekReplay(back);
  ASSERT_TRUE(
      WaitFor([&] { return !positions.empty() && positions.back() >= back - 1e-6; }, 60000));
  EXPECT_NEAR(positions.back(), back, 1e-6);
  const std::vector<CloudPoint> at_back = workspace_->CloudSnapshot().Flatten();
  EXPECT_LT(at_back.size(), at_ahead.size() * 0.6);
  EXPECT_GT(at_back.size(), 0u);
  EXPECT_TRUE(IsAPrefix(at_back, expected));

  // On as fast as possible: the whole cloud, exactly the CLI's.
  workspace_->SetReplaySpeed(0.0);
  workspace_->SetReplayPaused(false);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000));
  const std::vector<CloudPoint> replayed = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(replayed.size(), expected.size());
  EXPECT_TRUE(IsAPrefix(replayed, expected));

  // After the end, a seek replays on from the target and ends again.
  finished = false;
  positions.clear();
  workspace_->SeekReplay(0.5 * length);
  EXPECT_TRUE(workspace_->replaying());
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000));
  ASSERT_FALSE(positions.empty());
  EXPECT_NEAR(positions.back(), length, 1e-6);
  const std::vector<CloudPoint> again = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(again.size(), expected.size());
  EXPECT_TRUE(IsAPrefix(again, expected));
  EXPECT_FALSE(workspace_->replaying());
  if (read_as_it_goes) ExpectNoSamplesHeld();
}

TEST_F(ReplayTest, SeekingFeedsInSlicesKeepsThePauseAndEndsWithTheCliCloud) {
  SeeksInSlicesKeepThePauseAndEndWithTheCliCloud(false);
}

// The same on a session read as it replays: its scans decoded from
// frames.bin as the replay reaches them, from the start again after a seek
// backwards, and none of its samples held.
TEST_F(ReplayTest, ASessionReadAsItReplaysSeeksAndEndsWithTheCliCloudHoldingNoSamples) {
  SeeksInSlicesKeepThePauseAndEndWithTheCliCloud(true);
}

// A paused replay sought to its very end (the slider at its right edge)
// finishes when it is unpaused.
void ReplayTest::APausedSeekToTheEndFinishesWhenUnpaused(bool read_as_it_goes) {
  const std::string dir = tmp_.path().toStdString();
  if (read_as_it_goes) workspace_->set_stream_open_above_bytes(0);
  const std::vector<CloudPoint> expected = CircleSessionAndItsCliCloud(dir);
  double length = 0.0, position = 0.0;
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayProgress, [&](double p, double len) {
    position = p;
    length = len;
  });
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  workspace_->OpenSession(QString::fromStdString(dir + "/c.sweepscan"), 1.0);
  ASSERT_TRUE(WaitFor([&] { return length > 0.0; }, 60000));
  workspace_->SetReplayPaused(true);
  workspace_->SeekReplay(length + 5.0);  // beyond: rounding, or --seek past the end
  ASSERT_TRUE(WaitFor([&] { return position >= length - 1e-6; }, 60000));
  RunEventsFor(300);
  EXPECT_FALSE(finished);  // paused
  workspace_->SetReplayPaused(false);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 10000));
  const std::vector<CloudPoint> replayed = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(replayed.size(), expected.size());
  EXPECT_TRUE(IsAPrefix(replayed, expected));
  EXPECT_NEAR(position, length, 1e-6);
}

TEST_F(ReplayTest, APausedSeekToTheEndFinishesWhenUnpaused) {
  APausedSeekToTheEndFinishesWhenUnpaused(false);
}

// Read as it replays, the end is known once the last scan is read.
TEST_F(ReplayTest, APausedSeekToTheEndOfASessionReadAsItReplaysFinishesWhenUnpaused) {
  APausedSeekToTheEndFinishesWhenUnpaused(true);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
