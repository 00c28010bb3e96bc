// DriveScript on explicit clocks: the path's set-points in time, and the
// aborts that keep a script from driving on after the robot stopped (issue:
// a recorder frozen for 10 s sent the segment 10 s further on, 20 ms after
// SIGCONT, and the robot drove it).
#include "hardware/station/drive_script.h"

#include <gtest/gtest.h>

namespace sweepscan {
namespace hardware {
namespace {

constexpr int64_t kMs = 1000000;

// Both clocks advance together (no suspend), from an arbitrary origin.
ScriptClocks At(int64_t ms, int64_t suspended_ms = 0) {
  return {5000 * kMs + ms * kMs, 9000 * kMs + (ms + suspended_ms) * kMs};
}

std::vector<sim::DriveSegment> Path() { return {{0.0, 0.0, 1.0}, {0.2, 0.1, 10.0}, {0.0, 0.3, 5.0}}; }

LinkStatus StatusWithTrips(uint32_t trips) {
  LinkStatus s;
  s.watchdog_trips = trips;
  return s;
}

TEST(DriveScriptTest, FollowsThePathAtTenHertzAndEnds) {
  DriveScript script(Path());
  EXPECT_DOUBLE_EQ(script.duration_s(), 16.0);
  script.Start(At(0));
  const LinkStatus status = StatusWithTrips(3);
  double v_at_5 = -1.0, w_at_12 = -1.0;
  int64_t t = 0;
  for (; t <= 16000; t += 100) {
    const DriveScript::Step step = script.Tick(At(t), &status);
    if (step.action != DriveScript::Action::kDrive) break;
    if (t == 5000) v_at_5 = step.v;
    if (t == 12000) w_at_12 = step.w;
  }
  EXPECT_EQ(t, 16000) << "done at the path's end";
  EXPECT_DOUBLE_EQ(v_at_5, 0.2);
  EXPECT_DOUBLE_EQ(w_at_12, 0.3);
  EXPECT_FALSE(script.aborted());
  EXPECT_FALSE(script.running());
  EXPECT_EQ(script.Tick(At(16100), &status).action, DriveScript::Action::kDone);
}

// SIGSTOP for 10 s, then SIGCONT: the old player sent the segment 10 s on.
TEST(DriveScriptTest, ALoopThatStoodStillLongerThanTheWatchdogAborts) {
  DriveScript script(Path());
  script.Start(At(0));
  for (int64_t t = 0; t <= 2000; t += 100) {
    ASSERT_EQ(script.Tick(At(t), nullptr).action, DriveScript::Action::kDrive);
  }
  const DriveScript::Step step = script.Tick(At(12000), nullptr);
  EXPECT_EQ(step.action, DriveScript::Action::kAbort);
  EXPECT_NE(step.reason.find("did not run for 10.0 s"), std::string::npos) << step.reason;
  EXPECT_TRUE(script.aborted());
  EXPECT_NEAR(script.elapsed_s(), 2.0, 1e-9) << "where the path was when the robot stopped";
  // Over for good: the next ticks do not drive either.
  EXPECT_EQ(script.Tick(At(12100), nullptr).action, DriveScript::Action::kAbort);
}

TEST(DriveScriptTest, AGapWithinTheWatchdogDrivesOn) {
  DriveScript script(Path());
  script.Start(At(0));
  for (int64_t t = 100; t <= 1000; t += 100) {
    ASSERT_EQ(script.Tick(At(t), nullptr).action, DriveScript::Action::kDrive);
  }
  const DriveScript::Step step = script.Tick(At(1450), nullptr);  // A 450 ms hiccup.
  EXPECT_EQ(step.action, DriveScript::Action::kDrive);
  EXPECT_DOUBLE_EQ(step.v, 0.2);
}

// Linux's CLOCK_MONOTONIC stands still in a suspend: only CLOCK_BOOTTIME
// shows the 30 s the laptop slept between two ticks 100 ms apart.
TEST(DriveScriptTest, ASuspendSeenOnlyByTheBoottimeClockAborts) {
  DriveScript script(Path());
  script.Start(At(0));
  for (int64_t t = 100; t <= 2000; t += 100) {
    ASSERT_EQ(script.Tick(At(t), nullptr).action, DriveScript::Action::kDrive);
  }
  const DriveScript::Step step = script.Tick(At(2100, 30000), nullptr);
  EXPECT_EQ(step.action, DriveScript::Action::kAbort);
  EXPECT_NE(step.reason.find("suspended for 30.1 s"), std::string::npos) << step.reason;
}

TEST(DriveScriptTest, AWatchdogTripTheRobotReportsAborts) {
  DriveScript script(Path());
  script.Start(At(0));
  const LinkStatus before = StatusWithTrips(2);  // Trips before the script are not its business.
  ASSERT_EQ(script.Tick(At(100), &before).action, DriveScript::Action::kDrive);
  ASSERT_EQ(script.Tick(At(200), &before).action, DriveScript::Action::kDrive);
  const LinkStatus tripped = StatusWithTrips(3);
  const DriveScript::Step step = script.Tick(At(300), &tripped);
  EXPECT_EQ(step.action, DriveScript::Action::kAbort);
  EXPECT_NE(step.reason.find("watchdog stopped it"), std::string::npos) << step.reason;
}

TEST(DriveScriptTest, ARestartedAgentOrALatchedEmergencyStopAborts) {
  {
    DriveScript script(Path());
    script.Start(At(0));
    const LinkStatus before = StatusWithTrips(5);
    ASSERT_EQ(script.Tick(At(100), &before).action, DriveScript::Action::kDrive);
    const LinkStatus restarted = StatusWithTrips(0);
    EXPECT_EQ(script.Tick(At(200), &restarted).action, DriveScript::Action::kAbort);
    EXPECT_NE(script.abort_reason().find("restarted"), std::string::npos);
  }
  DriveScript script(Path());
  script.Start(At(0));
  LinkStatus latched;
  latched.emergency_stop_latched = true;
  EXPECT_EQ(script.Tick(At(100), &latched).action, DriveScript::Action::kAbort);
  EXPECT_NE(script.abort_reason().find("emergency stop"), std::string::npos);
}

TEST(DriveScriptTest, AnAbortFromOutsideIsKeptWithItsReason) {
  DriveScript script(Path());
  script.Start(At(0));
  ASSERT_EQ(script.Tick(At(100), nullptr).action, DriveScript::Action::kDrive);
  script.Abort("the link was lost (connection reset)");
  const DriveScript::Step step = script.Tick(At(200), nullptr);
  EXPECT_EQ(step.action, DriveScript::Action::kAbort);
  EXPECT_EQ(step.reason, "the link was lost (connection reset)");
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
