// `sweepscan-cli record` against the simulated robot (a sweepscan-sim
// process on loopback TCP): a scripted drive recorded headless, a clean stop
// on SIGTERM, a session that survives SIGKILL, a wrong key refused with the
// app's message, bad options refused. The same recorder on robotd's real
// device ports (and the arm64 build) is in robotd_process_test.
#include <gtest/gtest.h>
#include <signal.h>

#include <QCoreApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QFile>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QProcess>
#include <QTemporaryDir>
#include <string>

#include "core/common/time.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/fault_proxy.h"
#include "tests/testing/held_ioctl_process.h"
#include "tests/testing/qt_wait.h"

namespace sweepscan {
namespace {

using sweepscan::testing::WaitFor;

const QString kScenario = QStringLiteral(SWEEPSCAN_SOURCE_DIR "/resources/scenarios/lab.json");

class CliRecordTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(dir_.isValid());
    key_ = WriteKey("robot.key", "the simulated robot's key, long enough");
    ASSERT_NO_FATAL_FAILURE(StartSim(&sim_, {}, &address_));
  }
  // The simulated robot on loopback with this fixture's key: *address is
  // "127.0.0.1:PORT".
  void StartSim(QProcess* sim, const QStringList& extra, QString* address) {
    sim->start(QStringLiteral(SWEEPSCAN_SIM),
               QStringList{"--scenario", kScenario, "--listen", "127.0.0.1:0", "--key-file", key_} + extra);
    QByteArray out;
    ASSERT_TRUE(WaitFor(
        [&] {
          out += sim->readAllStandardOutput();
          return out.contains('\n');
        },
        10000));
    ASSERT_TRUE(out.startsWith("listening on 127.0.0.1:")) << out.toStdString();
    *address = QString::fromUtf8(out.mid(13).trimmed());
  }
  void TearDown() override {
    sim_.terminate();
    sim_.waitForFinished(5000);
  }
  QString WriteKey(const QString& name, const QByteArray& bytes) {
    const QString path = dir_.filePath(name);
    QFile f(path);
    f.open(QIODevice::WriteOnly);
    f.write(bytes);
    f.close();
    f.setPermissions(QFile::ReadOwner | QFile::WriteOwner);
    return path;
  }
  // 30 s straight on at 0.1 m/s: a drive script still running when a
  // test's fault comes.
  QString WriteSlowStraightScript() {
    const QString script = dir_.filePath("drive.json");
    QFile f(script);
    EXPECT_TRUE(f.open(QIODevice::WriteOnly));
    f.write(R"({"segments": [{"v_mps": 0.1, "w_radps": 0, "duration_s": 30}]})");
    return script;
  }
  // `record` through a FaultProxy (or any relay) on this port.
  void StartRecordVia(QProcess* p, quint16 port, const QString& out, const QStringList& extra) {
    p->start(QStringLiteral(SWEEPSCAN_CLI),
             QStringList{"record", "--connect", QStringLiteral("127.0.0.1:%1").arg(port),
                         "--key-file", key_, "--out", out} +
                 extra);
  }
  void StartRecord(QProcess* p, const QString& out, const QStringList& extra = {}) {
    p->start(QStringLiteral(SWEEPSCAN_CLI),
             QStringList{"record", "--connect", address_, "--key-file", key_, "--out", out} + extra);
  }
  // Waits for the recorder's first health line: the session is being written.
  static bool WaitRecording(QProcess* p, QByteArray* err) {
    return WaitFor(
        [&] {
          *err += p->readAllStandardError();
          return err->contains("recording to") && err->contains(" s  connected");
        },
        15000);
  }
  void StopsCleanlyOn(int signal, const QString& session, int after_ms);
  static double RecordedSeconds(const QString& session, SensorLog* log) {
    hardware::SessionDecodeInfo info;
    const Status s = hardware::DecodeSession(session.toStdString(), log, &info);
    EXPECT_TRUE(s.ok()) << s.message();
    if (log->imu.empty()) return 0.0;
    return ToSeconds(log->imu.back().time - log->imu.front().time);
  }

  QTemporaryDir dir_;
  QString key_;
  QString address_;
  QProcess sim_;
};

TEST_F(CliRecordTest, DrivesAScriptHeadlessAndTheSessionHoldsTheDrive) {
  const QString script = dir_.filePath("drive.json");
  QFile f(script);
  ASSERT_TRUE(f.open(QIODevice::WriteOnly));
  f.write(R"({"segments": [{"v_mps": 0, "w_radps": 0, "duration_s": 1},
                          {"v_mps": 0.2, "w_radps": 0, "duration_s": 3}]})");
  f.close();
  const QString session = dir_.filePath("drive.sweepscan");
  QProcess record;
  StartRecord(&record, session, {"--drive-script", script, "--scenario", kScenario, "--json"});
  ASSERT_TRUE(record.waitForFinished(30000));
  const QByteArray err = record.readAllStandardError();
  ASSERT_EQ(record.exitCode(), 0) << err.toStdString();
  EXPECT_TRUE(err.contains("drive script done")) << err.toStdString();
  const QJsonObject summary = QJsonDocument::fromJson(record.readAllStandardOutput()).object();
  EXPECT_EQ(summary["stopped_by"].toString(), "script");
  EXPECT_EQ(summary["frames_lost"].toInt(), 0);

  SensorLog log;
  EXPECT_NEAR(RecordedSeconds(session, &log), 4.0, 0.6);
  ASSERT_FALSE(log.scans.empty()) << "the recorder turns the lidar on";
  // The wheels' distance: 0.2 m/s for 3 s, with the board's lag.
  double distance = 0.0;
  for (size_t i = 1; i < log.wheels.size(); ++i) {
    const double dt = ToSeconds(log.wheels[i].time - log.wheels[i - 1].time);
    distance += 0.5 * (log.wheels[i].left_mps + log.wheels[i].right_mps) * dt;
  }
  EXPECT_NEAR(distance, 0.6, 0.08);
  // The scenario travels with the session, as the app records it.
  QFile meta(session + "/meta.json");
  ASSERT_TRUE(meta.open(QIODevice::ReadOnly));
  EXPECT_TRUE(meta.readAll().contains("\"scenario\""));
}

// Issue 31: the link cut for 3 s mid-recording (testing::FaultProxy between
// the recorder and the simulated robot). The recorder says so on stderr,
// reconnects by itself, the drive script stops for good (the robot stays
// stopped), the session is one folder whose `info --json` lists the gap, and
// the robot's buffer filled it: no lidar data lost.
TEST_F(CliRecordTest, ALinkCutMidRecordingIsOneSessionWithTheGapListedAndNothingLost) {
  const QString script = WriteSlowStraightScript();
  const quint16 agent_port = address_.section(':', -1).toUShort();
  sweepscan::testing::FaultProxy proxy(agent_port);
  ASSERT_TRUE(proxy.isListening());
  const QString session = dir_.filePath("flaky.sweepscan");
  QProcess record;
  StartRecordVia(&record, proxy.port(), session, {"--duration", "9", "--drive-script", script, "--json"});
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&record, &err)) << err.toStdString();
  sweepscan::testing::Pump(2500);
  proxy.CutFor(3000, sweepscan::testing::FaultProxy::RefuseMode::kClosed);
  ASSERT_TRUE(WaitFor(
      [&] {
        err += record.readAllStandardError();
        return record.state() == QProcess::NotRunning;
      },
      30000));
  // The path was not driven as asked: exit 1, the session kept.
  ASSERT_EQ(record.exitCode(), 1) << err.toStdString();
  EXPECT_TRUE(err.contains("link lost at")) << err.toStdString();
  EXPECT_TRUE(err.contains("drive script aborted at")) << err.toStdString();
  EXPECT_TRUE(err.contains("the link was lost")) << err.toStdString();
  EXPECT_TRUE(err.contains("reconnected after")) << err.toStdString();
  const QByteArray out = record.readAllStandardOutput();
  const QJsonObject summary = QJsonDocument::fromJson(out).object();
  ASSERT_EQ(summary["outages_s"].toArray().size(), 1) << out.toStdString() << err.toStdString();
  EXPECT_TRUE(summary["drive_script"].toObject()["aborted"].toBool()) << out.toStdString();
  EXPECT_NEAR(summary["outages_s"].toArray()[0].toDouble(), 3.0, 1.5);

  QProcess info;
  info.start(QStringLiteral(SWEEPSCAN_CLI), {"info", session, "--strict", "--json"});
  ASSERT_TRUE(info.waitForFinished(30000));
  ASSERT_EQ(info.exitCode(), 0) << info.readAllStandardError().toStdString();
  const QJsonObject j = QJsonDocument::fromJson(info.readAllStandardOutput()).object();
  const QJsonArray gaps = j["gaps"].toArray();
  ASSERT_EQ(gaps.size(), 1);
  const QJsonObject gap = gaps[0].toObject();
  EXPECT_TRUE(gap["restored"].toBool());
  EXPECT_GT(gap["resent_bytes"].toDouble(), 10000.0);
  EXPECT_EQ(gap["data_lost_s"].toObject()["lidar"].toDouble(), 0.0);
  EXPECT_FALSE(gap["new_clock_epoch"].toBool());
  // The robot stopped at the cut and did not move again: the wheels' last
  // records (after the reconnection) are at rest.
  SensorLog log;
  RecordedSeconds(session, &log);
  ASSERT_FALSE(log.wheels.empty());
  EXPECT_LT(std::abs(log.wheels.back().left_mps) + std::abs(log.wheels.back().right_mps), 1e-3);
}

// An outage longer than the robot's buffer (robotd --buffer-s 1, 4.5 s
// cut): the recorder says, as each device's first bytes after it arrive, how
// many seconds of its data were lost, and its summary sums them per device,
// as `info` lists them for the session's gap. It said "0 frames lost in
// transit" and nothing of the seconds lost.
TEST_F(CliRecordTest, DataLostBeyondTheRobotsBufferIsSaidAndSummed) {
  QProcess sim;
  QString address;
  ASSERT_NO_FATAL_FAILURE(StartSim(&sim, {"--buffer-s", "1"}, &address));
  sweepscan::testing::FaultProxy proxy(address.section(':', -1).toUShort());
  ASSERT_TRUE(proxy.isListening());
  const QString session = dir_.filePath("lossy.sweepscan");
  QProcess record;
  StartRecordVia(&record, proxy.port(), session, {"--duration", "12", "--json"});
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&record, &err)) << err.toStdString();
  sweepscan::testing::Pump(2000);
  proxy.CutFor(4500, sweepscan::testing::FaultProxy::RefuseMode::kClosed);
  ASSERT_TRUE(WaitFor(
      [&] {
        err += record.readAllStandardError();
        return record.state() == QProcess::NotRunning;
      },
      40000));
  sim.terminate();
  sim.waitForFinished(5000);
  ASSERT_EQ(record.exitCode(), 0) << err.toStdString();
  EXPECT_TRUE(err.contains("imu: ")) << err.toStdString();
  EXPECT_TRUE(err.contains("s of data lost in the outage")) << err.toStdString();
  const QByteArray out = record.readAllStandardOutput();
  const QJsonObject summary = QJsonDocument::fromJson(out).object();
  const QJsonObject lost = summary["data_lost_s"].toObject();
  ASSERT_EQ(summary["outages_s"].toArray().size(), 1) << out.toStdString() << err.toStdString();
  const double outage_s = summary["outages_s"].toArray()[0].toDouble();

  QProcess info;
  info.start(QStringLiteral(SWEEPSCAN_CLI), {"info", session, "--json"});
  ASSERT_TRUE(info.waitForFinished(30000));
  ASSERT_EQ(info.exitCode(), 0) << info.readAllStandardError().toStdString();
  const QJsonArray gaps =
      QJsonDocument::fromJson(info.readAllStandardOutput()).object()["gaps"].toArray();
  ASSERT_EQ(gaps.size(), 1);
  const QJsonObject in_session = gaps[0].toObject()["data_lost_s"].toObject();
  for (const char* device : {"lidar", "imu", "motor_board"}) {
    // Beyond the second the buffer kept, at most the outage (and a chunk's span).
    EXPECT_GT(lost[device].toDouble(), 1.0) << device << " " << out.toStdString();
    EXPECT_LT(lost[device].toDouble(), outage_s + 0.5) << device << " " << out.toStdString();
    EXPECT_NEAR(lost[device].toDouble(), in_session[device].toDouble(), 0.01) << device;
  }
}

// The wheels' speeds after the robot first came to rest from driving (the
// watchdog's stop): the largest, which is 0 when it stayed stopped.
double FastestAfterTheFirstStop(const SensorLog& log) {
  auto speed = [](const WheelSpeedMeasurement& w) { return std::abs(w.left_mps) + std::abs(w.right_mps); };
  size_t i = 0;
  while (i < log.wheels.size() && speed(log.wheels[i]) < 0.05) ++i;  // Until it drives.
  while (i < log.wheels.size() && speed(log.wheels[i]) > 1e-3) ++i;  // Until it stands.
  EXPECT_LT(i, log.wheels.size()) << "the robot never drove and stopped";
  double fastest = 0.0;
  for (; i < log.wheels.size(); ++i) fastest = std::max(fastest, speed(log.wheels[i]));
  return fastest;
}

// The recorder frozen (SIGSTOP, as a laptop's suspend or a debugger) for
// 2 s mid-script: the robot's watchdog stops the robot after 0.5 s, and the
// script must not drive it again. It did: 20 ms after SIGCONT the recorder
// sent the segment the wall clock had reached and the robot drove on, with
// no word said. Now the script is aborted with the reason, the recording
// goes on to its --duration, exit 1, and the robot stays stopped.
TEST_F(CliRecordTest, AFrozenRecorderAbortsItsDriveScriptAndTheRobotStaysStopped) {
  const QString script = WriteSlowStraightScript();
  const QString session = dir_.filePath("frozen.sweepscan");
  QProcess record;
  StartRecord(&record, session, {"--duration", "7", "--drive-script", script, "--json"});
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&record, &err)) << err.toStdString();
  sweepscan::testing::Pump(1500);
  const auto pid = static_cast<pid_t>(record.processId());
  ::kill(pid, SIGSTOP);
  sweepscan::testing::Pump(2000);
  ::kill(pid, SIGCONT);
  ASSERT_TRUE(WaitFor(
      [&] {
        err += record.readAllStandardError();
        return record.state() == QProcess::NotRunning;
      },
      30000));
  EXPECT_EQ(record.exitCode(), 1) << err.toStdString();
  EXPECT_TRUE(err.contains("drive script aborted at")) << err.toStdString();
  EXPECT_TRUE(err.contains("did not run for")) << err.toStdString();
  const QJsonObject summary = QJsonDocument::fromJson(record.readAllStandardOutput()).object();
  const QJsonObject drive = summary["drive_script"].toObject();
  EXPECT_TRUE(drive["aborted"].toBool());
  EXPECT_FALSE(drive["completed"].toBool());
  EXPECT_TRUE(drive["reason"].toString().contains("did not run for")) << drive["reason"].toString().toStdString();
  EXPECT_EQ(summary["stopped_by"].toString(), "duration") << "the recording went on";
  SensorLog log;
  EXPECT_NEAR(RecordedSeconds(session, &log), 7.0, 1.0);
  EXPECT_LT(FastestAfterTheFirstStop(log), 0.01);
}

// A stall on the way (1 s: the link survives, under the 2 s stall limit)
// trips the robot's watchdog; the held frames then arrive, a Drive among
// them. The recorder's loop never stood still, but the robot reports the
// trip in its Status, and the script is aborted for it.
TEST_F(CliRecordTest, AWatchdogTripTheRobotReportsAbortsTheDriveScript) {
  const QString script = WriteSlowStraightScript();
  const quint16 agent_port = address_.section(':', -1).toUShort();
  sweepscan::testing::FaultProxy proxy(agent_port);
  ASSERT_TRUE(proxy.isListening());
  const QString session = dir_.filePath("tripped.sweepscan");
  QProcess record;
  StartRecordVia(&record, proxy.port(), session, {"--duration", "6", "--drive-script", script, "--json"});
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&record, &err)) << err.toStdString();
  sweepscan::testing::Pump(1500);
  proxy.Stall(1000);
  ASSERT_TRUE(WaitFor(
      [&] {
        err += record.readAllStandardError();
        return record.state() == QProcess::NotRunning;
      },
      30000));
  EXPECT_EQ(record.exitCode(), 1) << err.toStdString();
  EXPECT_FALSE(err.contains("link lost")) << err.toStdString();
  EXPECT_TRUE(err.contains("watchdog stopped it")) << err.toStdString();
  SensorLog log;
  RecordedSeconds(session, &log);
  ASSERT_FALSE(log.wheels.empty());
  EXPECT_LT(std::abs(log.wheels.back().left_mps) + std::abs(log.wheels.back().right_mps), 1e-3);
}

// A disk whose syncs take seconds (a busy laptop disk, a USB stick): the
// recorder's link goes on sending its heartbeats and the drive script's
// commands meanwhile (the syncs are the session writer's own thread's), so
// the robot's watchdog does not stop it, and nothing recorded is lost. The
// link's thread waited in fdatasync, and the watchdog stopped the robot.
TEST_F(CliRecordTest, ADiskThatSyncsSlowlyDoesNotStopTheRobot) {
  const QString script = WriteSlowStraightScript();
  const QString session = dir_.filePath("slow-disk.sweepscan");
  testing::HeldIoctlProcess record(
      {SWEEPSCAN_CLI, "record", "--connect", address_.toStdString(), "--key-file",
       key_.toStdString(), "--out", session.toStdString(), "--duration", "6", "--drive-script",
       script.toStdString()},
      testing::HeldSyscall{__NR_fdatasync});
  if (!record.error.empty()) GTEST_SKIP() << record.error;
  std::string out;
  // The first sync (half a second into the recording) held for 2.5 s ...
  ASSERT_TRUE(WaitFor(
      [&] {
        out += record.Read();
        return record.Holding();
      },
      15000))
      << out;
  sweepscan::testing::Pump(2500);
  // ... then every sync let go as it comes, until the recorder exits.
  ASSERT_TRUE(WaitFor(
      [&] {
        record.Continue();
        out += record.Read();
        return record.Exited();
      },
      30000))
      << out;
  out += record.Read();
  ASSERT_TRUE(WIFEXITED(record.status)) << out;
  EXPECT_EQ(WEXITSTATUS(record.status), 0) << out;
  EXPECT_EQ(out.find("watchdog"), std::string::npos) << out;
  EXPECT_EQ(out.find("link lost"), std::string::npos) << out;
  EXPECT_EQ(out.find("aborted"), std::string::npos) << out;
  SensorLog log;
  EXPECT_NEAR(RecordedSeconds(session, &log), 6.0, 1.0);
  // The IMU's 100 Hz without a hole across the held sync.
  double widest = 0.0;
  for (size_t i = 1; i < log.imu.size(); ++i)
    widest = std::max(widest, ToSeconds(log.imu[i].time - log.imu[i - 1].time));
  EXPECT_LT(widest, 0.1);
  // The robot drove on from its start to the recording's last half second
  // (the recorder's Stop): it never stood still in between.
  auto speed = [](const WheelSpeedMeasurement& w) { return std::abs(w.left_mps) + std::abs(w.right_mps); };
  size_t i = 0;
  while (i < log.wheels.size() && speed(log.wheels[i]) < 0.05) ++i;
  ASSERT_LT(i, log.wheels.size()) << "the robot never drove";
  const Time end = log.wheels.back().time;
  size_t stood = 0;
  for (; i < log.wheels.size() && ToSeconds(end - log.wheels[i].time) > 0.5; ++i)
    stood += speed(log.wheels[i]) < 0.01 ? 1 : 0;
  EXPECT_EQ(stood, 0u);
}

// A recording of `session` running `after_ms`, then `signal`: it stops
// through its event loop (exit 0, the summary printed, stopped by the
// signal) with everything up to the signal on disk, not just what was
// there a second before.
void CliRecordTest::StopsCleanlyOn(int signal, const QString& session, int after_ms) {
  QProcess record;
  StartRecord(&record, session, {"--json"});
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&record, &err)) << err.toStdString();
  sweepscan::testing::Pump(after_ms);
  ::kill(static_cast<pid_t>(record.processId()), signal);
  ASSERT_TRUE(record.waitForFinished(10000));
  EXPECT_EQ(record.exitStatus(), QProcess::NormalExit);
  EXPECT_EQ(record.exitCode(), 0) << record.readAllStandardError().toStdString();
  const QJsonObject summary = QJsonDocument::fromJson(record.readAllStandardOutput()).object();
  EXPECT_EQ(summary["stopped_by"].toString(), "signal");
  SensorLog log;
  const double seconds = RecordedSeconds(session, &log);
  EXPECT_NEAR(seconds, summary["seconds"].toDouble(), 0.3);
  EXPECT_GE(seconds, after_ms * 1e-3);
}

TEST_F(CliRecordTest, SigtermStopsCleanlyAndSigkillKeepsAllButTheLastSecond) {
  StopsCleanlyOn(SIGTERM, dir_.filePath("clean.sweepscan"), 2500);

  const QString killed = dir_.filePath("killed.sweepscan");
  QProcess victim;
  StartRecord(&victim, killed);
  QByteArray err;
  ASSERT_TRUE(WaitRecording(&victim, &err)) << err.toStdString();
  sweepscan::testing::Pump(3000);
  ::kill(static_cast<pid_t>(victim.processId()), SIGKILL);
  ASSERT_TRUE(victim.waitForFinished(5000));
  // Recording began at most ~1 s before the first health line; everything
  // older than a second is on disk (the writer's promise).
  SensorLog survived;
  EXPECT_GE(RecordedSeconds(killed, &survived), 3.0 - 1.0 - 0.2);
  EXPECT_FALSE(survived.scans.empty());
}

// SIGHUP (the terminal or ssh session that ran the recorder closed) and
// SIGQUIT (Ctrl+\) stop it as SIGTERM does: the session closed with its
// buffered records, the summary printed. Their default action killed it
// with neither.
TEST_F(CliRecordTest, SighupAndSigquitStopCleanlyLikeSigterm) {
  for (const int signal : {SIGHUP, SIGQUIT}) {
    SCOPED_TRACE(signal == SIGHUP ? "SIGHUP" : "SIGQUIT");
    StopsCleanlyOn(signal, dir_.filePath(QStringLiteral("signal-%1.sweepscan").arg(signal)), 1500);
  }
}

// The disk fills (here a file size limit of 100 KiB, SIGXFSZ ignored as a
// full disk raises none): the recorder says so at once and stops, instead of
// driving on recording nothing and telling only at the end; what was
// written before stays readable.
TEST_F(CliRecordTest, AFailedWriteStopsTheRecorderAtOnceAndKeepsWhatWasWritten) {
  const QString session = dir_.filePath("full.sweepscan");
  QProcess record;
  record.start(QStringLiteral("bash"),
               {"-c", QStringLiteral("trap '' XFSZ; ulimit -f 100; exec '%1' record --connect %2 "
                                     "--key-file '%3' --out '%4'")
                          .arg(QStringLiteral(SWEEPSCAN_CLI), address_, key_, session)});
  ASSERT_TRUE(record.waitForFinished(40000)) << "still recording after the file could not grow";
  const std::string err = record.readAllStandardError().toStdString();
  EXPECT_EQ(record.exitCode(), 1) << err;
  EXPECT_NE(err.find("sweepscan-cli: recording failed at"), std::string::npos) << err;
  SensorLog log;
  EXPECT_GT(RecordedSeconds(session, &log), 0.5);
}

TEST_F(CliRecordTest, AWrongKeyIsRefusedWithTheAppsMessageAndLeavesNoSession) {
  const QString session = dir_.filePath("refused.sweepscan");
  QProcess record;
  record.start(QStringLiteral(SWEEPSCAN_CLI),
               {"record", "--connect", address_, "--key-file", WriteKey("wrong.key", "not the robot's key at all"),
                "--out", session});
  ASSERT_TRUE(record.waitForFinished(20000));
  const std::string err = record.readAllStandardError().toStdString();
  EXPECT_EQ(record.exitCode(), 2) << err;
  // The app's connection panel says "Refused: authentication failed".
  EXPECT_NE(err.find("refused: authentication failed"), std::string::npos) << err;
  EXPECT_FALSE(QFileInfo::exists(session));
}

TEST_F(CliRecordTest, BadOptionsAreRefusedBeforeConnecting) {
  struct Case {
    QStringList args;
    const char* says;
    int code = 2;  // bad input; 1 for an output in the way, as in every command
  };
  const QString out = dir_.filePath("x.sweepscan");
  QDir().mkpath(dir_.filePath("exists.sweepscan"));
  const Case cases[] = {
      {{"record", "--out", out}, "either --connect"},
      {{"record", "--connect", address_, "--serial", "/dev/null", "--out", out}, "either --connect"},
      {{"record", "--connect", address_, "--out", out}, "--key-file"},
      {{"record", "--connect", address_, "--key-file", key_}, "--out"},
      {{"record", "--connect", address_, "--key-file", key_, "--out", dir_.filePath("exists.sweepscan")}, "exists", 1},
      {{"record", "--serial", "/dev/null", "--key-file", key_, "--out", out}, "--key-file does not apply to --serial"},
      {{"record", "--connect", address_, "--key-file", key_, "--out", out, "--duration", "-1"}, "--duration"},
      {{"record", "--connect", address_, "--key-file", key_, "--out", out, "--drive-script", "/nonexistent.json"},
       "/nonexistent.json"},
  };
  for (const Case& c : cases) {
    QProcess p;
    p.start(QStringLiteral(SWEEPSCAN_CLI), c.args);
    ASSERT_TRUE(p.waitForFinished(10000));
    const std::string err = p.readAllStandardError().toStdString();
    EXPECT_EQ(p.exitCode(), c.code) << c.args.join(' ').toStdString() << ": " << err;
    EXPECT_NE(err.find(c.says), std::string::npos) << c.args.join(' ').toStdString() << ": " << err;
  }
  EXPECT_FALSE(QFileInfo::exists(out));
}

// The X4 spun on after the recorder left: it never sent LidarMotor off,
// assuming the agent stopped it. Now a clean end turns it off (the agent's
// state, read by a client that sends nothing), unless --keep-lidar.
TEST_F(CliRecordTest, TheRecordersCleanEndTurnsTheLidarOffUnlessToldToKeepIt) {
  for (const bool keep : {false, true}) {
    SCOPED_TRACE(keep ? "--keep-lidar" : "default");
    QProcess record;
    StartRecord(&record, dir_.filePath(keep ? "keep.sweepscan" : "off.sweepscan"),
                keep ? QStringList{"--duration", "2", "--keep-lidar"} : QStringList{"--duration", "2"});
    ASSERT_TRUE(record.waitForFinished(20000));
    ASSERT_EQ(record.exitCode(), 0) << record.readAllStandardError().toStdString();
    hardware::RobotConnectionOptions options;
    options.address = "tcp:" + address_;
    QFile key(key_);
    ASSERT_TRUE(key.open(QIODevice::ReadOnly));
    const QByteArray bytes = key.readAll();
    options.key.assign(bytes.begin(), bytes.end());
    hardware::RobotConnection look(options);
    QString error;
    ASSERT_TRUE(look.Start(&error)) << error.toStdString();
    ASSERT_TRUE(WaitFor([&] { return look.health().have_status; }, 10000));
    EXPECT_EQ(look.health().agent_status.lidar_motor_on, keep);
    look.Shutdown();
  }
}

// The link on a serial port: sweepscan-sim --pty offers a pseudo-terminal,
// a real serial device (no authentication on serial links, as the app).
TEST(CliRecordSerialTest, RecordsOverASerialLink) {
  QTemporaryDir dir;
  ASSERT_TRUE(dir.isValid());
  QProcess sim;
  sim.start(QStringLiteral(SWEEPSCAN_SIM), {"--scenario", kScenario, "--pty"});
  QByteArray out;
  ASSERT_TRUE(WaitFor(
      [&] {
        out += sim.readAllStandardOutput();
        return out.contains('\n');
      },
      10000));
  const QString pty = QString::fromUtf8(out.trimmed());
  ASSERT_TRUE(pty.startsWith("/dev/pts/")) << out.toStdString();
  const QString session = dir.filePath("serial.sweepscan");
  QProcess record;
  record.start(QStringLiteral(SWEEPSCAN_CLI),
               {"record", "--serial", pty, "--out", session, "--duration", "3", "--json"});
  ASSERT_TRUE(record.waitForFinished(20000));
  EXPECT_EQ(record.exitCode(), 0) << record.readAllStandardError().toStdString();
  // Its clean end turned the lidar off, as over TCP: the last messages left
  // the port before it closed (they stayed in QSerialPort's buffer, its
  // event loop over, and the X4 spun on).
  {
    hardware::RobotConnectionOptions options;
    options.address = "serial:" + pty;
    hardware::RobotConnection look(options);
    QString error;
    ASSERT_TRUE(look.Start(&error)) << error.toStdString();
    ASSERT_TRUE(WaitFor([&] { return look.health().have_status; }, 10000));
    EXPECT_FALSE(look.health().agent_status.lidar_motor_on);
    look.Shutdown();
  }
  sim.terminate();
  sim.waitForFinished(5000);
  SensorLog log;
  hardware::SessionDecodeInfo info;
  ASSERT_TRUE(hardware::DecodeSession(session.toStdString(), &log, &info).ok());
  EXPECT_NE(info.meta.link.find("serial:" + pty.toStdString()), std::string::npos) << info.meta.link;
  ASSERT_GE(log.imu.size(), 200u);  // 100 Hz for most of 3 s.
  EXPECT_FALSE(log.scans.empty());
}

}  // namespace
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
