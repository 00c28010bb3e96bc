// Issue 31 in the desktop app: the link to a simulated robot (a sweepscan-sim
// process) runs through testing::FaultProxy and is cut for 3 s while
// recording. The status bar says "reconnecting", then "reconnected after
// N s"; the GUI's event loop stays responsive throughout; the recording
// goes on in the same session, whose gap the session lists; the robot is
// not driven again by the reconnection.
#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QFile>
#include <QProcess>
#include <QRegularExpression>
#include <QStatusBar>
#include <QTest>
#include <QTimer>
#include <algorithm>
#include <vector>

#include "hardware/link/telemetry_decoder.h"
#include "tests/testing/event_loop_turns.h"
#include "tests/testing/fault_proxy.h"
#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::WaitFor;
using LinkOutageUiTest = testing::AppFixture;

TEST_F(LinkOutageUiTest, TheStatusBarSaysReconnectingThenReconnectedAfterAndTheRecordingGoesOn) {
  const QString key = tmp_.path() + "/robot.key";
  {
    QFile f(key);
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("the link outage UI test's key\n");
    f.close();
    f.setPermissions(QFile::ReadOwner | QFile::WriteOwner);
  }
  QProcess sim;
  sim.start(QStringLiteral(SWEEPSCAN_SIM), {"--scenario", kResources + "/scenarios/lab.json",
                                            "--listen", "127.0.0.1:0", "--key-file", key});
  ASSERT_TRUE(sim.waitForStarted(10000));
  ASSERT_TRUE(WaitFor([&] { return sim.canReadLine(); }, 20000));
  const QString line = QString::fromLocal8Bit(sim.readLine()).trimmed();  // listening on H:P
  const quint16 agent_port = static_cast<quint16>(line.section(':', -1).toUInt());
  ASSERT_GT(agent_port, 0) << line.toStdString();
  sweepscan::testing::FaultProxy proxy(agent_port);
  ASSERT_TRUE(proxy.isListening());

  ConnectOptions o;
  o.kind = LinkKind::kTcp;
  o.port = proxy.port();
  o.key_file = key;
  QString error;
  ASSERT_TRUE(workspace_->Connect(o, &error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return workspace_->authenticated(); }, 15000));
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  const QString session = workspace_->session_dir();
  workspace_->Drive(0.2, 0.0);
  QTest::qWait(1500);

  // The GUI's event loop, watched by a 10 ms timer from here on: each
  // tick's lateness in wall time, and the GUI thread's CPU time since the
  // last tick. Work on the GUI thread shows whole in the CPU time; the wall
  // time also grows with whatever else runs beside it (ctest -j2: a wall
  // p99 of 52 ms failed a fresh-clone CI run where alone it is about 22).
  std::vector<double> gaps_ms, cpu_ms;
  QElapsedTimer clock;
  clock.start();
  qint64 last = 0;
  double last_cpu = 0.0;
  QTimer watch;
  watch.setTimerType(Qt::PreciseTimer);
  QObject::connect(&watch, &QTimer::timeout, [&] {
    const qint64 now = clock.nsecsElapsed();
    const double now_cpu = sweepscan::testing::ThisThreadCpuMs();
    if (last > 0) {
      gaps_ms.push_back((now - last) * 1e-6 - 10.0);
      cpu_ms.push_back(now_cpu - last_cpu);
    }
    last = now;
    last_cpu = now_cpu;
  });
  watch.start(10);

  proxy.CutFor(3000, sweepscan::testing::FaultProxy::RefuseMode::kClosed);
  ASSERT_TRUE(WaitFor(
      [&] { return window_->statusBar()->currentMessage().contains("reconnecting"); }, 5000))
      << window_->statusBar()->currentMessage().toStdString();
  EXPECT_FALSE(workspace_->authenticated());
  EXPECT_TRUE(workspace_->recording()) << "a recording survives the outage";
  // What the operator sees (looked at; not compared). Grabbing renders the
  // whole window on this thread: not counted as the app's own stall.
  QTest::qWait(1200);  // The link label's once-a-second update.
  watch.stop();
  window_->grab().save(QCoreApplication::applicationDirPath() + "/link_outage_reconnecting.png");
  last = 0;
  watch.start(10);
  ASSERT_TRUE(WaitFor(
      [&] { return window_->statusBar()->currentMessage().contains("reconnected after"); }, 15000))
      << window_->statusBar()->currentMessage().toStdString();
  const QString message = window_->statusBar()->currentMessage();
  QTest::qWait(1100);
  watch.stop();
  window_->grab().save(QCoreApplication::applicationDirPath() + "/link_outage_reconnected.png");
  last = 0;
  watch.start(10);
  std::fprintf(stderr, "status bar: %s\n", qPrintable(message));
  const QRegularExpressionMatch m =
      QRegularExpression(QStringLiteral("reconnected after ([0-9.]+) s")).match(message);
  ASSERT_TRUE(m.hasMatch());
  EXPECT_NEAR(m.captured(1).toDouble(), 3.0, 1.5);
  EXPECT_TRUE(workspace_->authenticated());
  EXPECT_EQ(workspace_->commanded().v, 0.0) << "the reconnection does not drive";
  QTest::qWait(1000);
  watch.stop();
  std::sort(gaps_ms.begin(), gaps_ms.end());
  std::sort(cpu_ms.begin(), cpu_ms.end());
  ASSERT_FALSE(gaps_ms.empty());
  const double p99 = gaps_ms[gaps_ms.size() * 99 / 100];
  const double cpu_p99 = cpu_ms[cpu_ms.size() * 99 / 100];
  std::fprintf(stderr,
               "event loop through the outage: p99 %.1f ms late, max %.1f ms; GUI-thread CPU "
               "between ticks p99 %.1f ms, max %.1f ms\n",
               p99, gaps_ms.back(), cpu_p99, cpu_ms.back());
  EXPECT_LT(cpu_p99, 50.0);
  EXPECT_LT(p99, 250.0) << "a blocking wait on the GUI thread";

  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
  workspace_->Disconnect();
  sim.terminate();
  sim.waitForFinished(5000);
  SensorLog log;
  hardware::SessionDecodeInfo info;
  ASSERT_TRUE(hardware::DecodeSession(session.toStdString(), &log, &info).ok());
  ASSERT_EQ(info.gaps.size(), 1u) << info.ToString();
  EXPECT_TRUE(info.gaps[0].restored);
  EXPECT_EQ(info.gaps[0].data_lost_s[0], 0.0) << "the robot's buffer covered 3 s";
  EXPECT_GT(info.gaps[0].late_bytes, 0u);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
