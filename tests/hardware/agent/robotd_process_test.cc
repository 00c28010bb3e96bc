// sweepscan-robotd as a process, on its real device ports: the simulated X4,
// HI219 and motor board on pseudo-terminals (DevicePtys, byte-exact), the
// workstation's RobotConnection over loopback TCP. Run for the amd64 build
// and, when the arm64 cross-build exists (scripts/build-arm64.sh; CMake
// option SWEEPSCAN_ROBOTD_ARM64), for the arm64 binary under
// qemu-aarch64-static: the same sensor records from the same device bytes,
// recorded by the app's recorder and by `sweepscan-cli record`, and the
// watchdog stopping the robot within its bound under emulation.
// Lines "figure: ..." are the figures docs/performance.md quotes
// (scripts/arm64-e2e.sh collects them).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <pty.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QEventLoop>
#include <QFile>
#include <QJsonDocument>
#include <QJsonObject>
#include <QProcess>
#include <QTemporaryDir>
#include <QTimer>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "core/scenario/scenario.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/emulation/device_ptys.h"
#include "hardware/link/telemetry_decoder.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/fault_proxy.h"
#include "tests/testing/qt_wait.h"
#include "tests/testing/read_available.h"

namespace sweepscan {
namespace hardware {
namespace {

using sweepscan::testing::WaitFor;

struct Build {
  std::string name;
  QStringList command;  // Program and leading arguments (qemu's, for arm64).
};

// gtest prints the parameter in test names (ctest lists them).
void PrintTo(const Build& build, std::ostream* os) { *os << build.name; }

std::vector<Build> Builds() {
  std::vector<Build> builds = {{"amd64", {QStringLiteral(SWEEPSCAN_ROBOTD)}}};
  const QString arm64 = QStringLiteral(SWEEPSCAN_ROBOTD_ARM64);
  if (!arm64.isEmpty() && QFile::exists(arm64)) {
    builds.push_back({"arm64", {QStringLiteral(SWEEPSCAN_QEMU_AARCH64), "-L", "/", arm64}});
  }
  return builds;
}

std::string Scenario(const char* name) {
  return std::string(SWEEPSCAN_SOURCE_DIR) + "/resources/scenarios/" + name;
}

// CPU seconds (user + system) the process has used, from /proc.
double CpuSeconds(qint64 pid) {
  QFile stat(QStringLiteral("/proc/%1/stat").arg(pid));
  if (!stat.open(QIODevice::ReadOnly)) return 0.0;
  const QByteArray line = stat.readAll();
  const QList<QByteArray> fields = line.mid(line.lastIndexOf(')') + 2).split(' ');
  // After the command: state is field 3, utime 14 and stime 15 (proc(5)).
  return (fields.value(11).toDouble() + fields.value(12).toDouble()) / ::sysconf(_SC_CLK_TCK);
}

// Runs the event loop for `ms` without spinning (WaitFor and Pump poll, and
// would take a core from a robotd whose CPU time is measured meanwhile).
void IdleFor(int ms) {
  QEventLoop loop;
  QTimer::singleShot(ms, &loop, &QEventLoop::quit);
  loop.exec();
}

using sweepscan::testing::ReadAvailable;

// A pseudo-terminal standing in for a board on a USB adapter; the test
// holds the master. Closing it is the adapter unplugged: the kernel hangs
// the slave up (read() returns 0 with nothing to read, as for a USB serial
// adapter pulled out) and the node goes away.
struct BoardPty {
  int master = -1;
  QString slave;
  bool Open() {
    int slave_fd = -1;
    char name[128];
    termios raw{};
    ::cfmakeraw(&raw);
    if (::openpty(&master, &slave_fd, name, &raw, nullptr) != 0) return false;
    ::fcntl(master, F_SETFL, O_NONBLOCK);
    ::fcntl(master, F_SETFD, FD_CLOEXEC);  // robotd must not hold it too.
    ::close(slave_fd);                     // The master alone keeps the pair.
    slave = QString::fromLocal8Bit(name);
    return true;
  }
  void Unplug() {
    if (master >= 0) ::close(master);
    master = -1;
  }
  ~BoardPty() { Unplug(); }
};

// Calls `each` with every command robotd writes to the motor board's pty
// (decoded as the board would), in order.
void OnMotorCommands(DevicePtys* ptys, std::function<void(const MotorCommand&)> each) {
  auto board = std::make_shared<MotorCommandDecoder>();
  QObject::connect(ptys, &DevicePtys::hostBytes,
                   [board, each](int, int device, const QByteArray& bytes) {
                     if (device != static_cast<int>(LinkDevice::kMotorBoard)) return;
                     board->Feed(reinterpret_cast<const uint8_t*>(bytes.constData()),
                                 static_cast<size_t>(bytes.size()), Time());
                     for (const MotorCommand& c : board->TakeRecords()) each(c);
                   });
}

// One robotd process on one set of device ptys, serving TCP on a free port.
class Robotd {
 public:
  Robotd(const Build& build, const std::array<QString, 3>& ports, const QString& key_file,
         const QStringList& extra = {}) {
    QStringList args = build.command.mid(1);
    args << "--lidar" << ports[0] << "--imu" << ports[1] << "--motor" << ports[2] << "--listen"
         << "127.0.0.1:0" << "--key-file" << key_file << extra;
    process_.start(build.command.first(), args);
  }
  ~Robotd() {
    if (process_.state() != QProcess::NotRunning) {
      process_.terminate();  // SIGTERM: it stops the motors and exits.
      if (!process_.waitForFinished(10000)) process_.kill();
    }
  }
  // Waits for "listening on 127.0.0.1:PORT" (qemu starts slowly).
  bool WaitListening(int timeout_ms) {
    return WaitFor(
        [&] {
          out_ += process_.readAllStandardOutput();
          const int at = out_.indexOf("listening on 127.0.0.1:");
          if (at < 0) return false;
          const int end = out_.indexOf('\n', at);
          if (end < 0) return false;
          port_ = out_.mid(at + 23, end - at - 23).toUShort();
          return port_ != 0;
        },
        timeout_ms);
  }
  QString Address() const { return QStringLiteral("tcp:127.0.0.1:%1").arg(port_); }
  quint16 port() const { return port_; }
  qint64 pid() const { return process_.processId(); }
  QString Stderr() { return QString::fromUtf8(process_.readAllStandardError()); }
  int Terminate() { return Signal(SIGTERM); }
  bool Running() const { return process_.state() != QProcess::NotRunning; }
  // Sends `signal` and waits; the exit code, -1 if killed by a signal.
  int Signal(int signal) {
    ::kill(static_cast<pid_t>(process_.processId()), signal);
    process_.waitForFinished(10000);
    return process_.exitStatus() == QProcess::NormalExit ? process_.exitCode() : -1;
  }

 private:
  QProcess process_;
  QByteArray out_;
  quint16 port_ = 0;
};

class RobotdProcessTest : public ::testing::TestWithParam<Build> {
 protected:
  // The lab's devices on ptys, the simulated board driven by the motor
  // commands it hears (null, with the failure reported, if the ptys fail).
  static std::unique_ptr<DevicePtys> LabDevicePtys() {
    sim::SimConfig world;
    EXPECT_TRUE(LoadScenario(Scenario("lab.json"), &world).ok());
    auto ptys = std::make_unique<DevicePtys>(
        std::make_unique<SimDevices>(world, SimDevices::Mode::kCommanded), 1);
    QString error;
    if (!ptys->Open(&error)) {
      ADD_FAILURE() << error.toStdString();
      return nullptr;
    }
    return ptys;
  }
  void SetUp() override {
    ASSERT_TRUE(dir_.isValid());
    key_file_ = dir_.filePath("robot.key");
    QFile key(key_file_);
    ASSERT_TRUE(key.open(QIODevice::WriteOnly));
    key.write("a pre-shared key of the robot link, 32+ bytes long");
    key.close();
    key.setPermissions(QFile::ReadOwner | QFile::WriteOwner);
  }
  RobotConnectionOptions Client(const QString& address, const QString& session = QString()) {
    RobotConnectionOptions o;
    o.address = address;
    o.key.assign(std::begin(kKey), std::end(kKey) - 1);
    o.session_dir = session;
    return o;
  }
  static constexpr char kKey[] = "a pre-shared key of the robot link, 32+ bytes long";
  QTemporaryDir dir_;
  QString key_file_;
};

// Index of the first record of `b` (from `b_first`) found in `a`, comparing
// `same` on a run of `run` records; -1 if none.
template <typename T, typename Same>
long Align(const std::vector<T>& a, const std::vector<T>& b, size_t b_first, size_t run, Same same) {
  if (b.size() < b_first + run) return -1;
  for (size_t i = 0; i + run <= a.size(); ++i) {
    bool all = true;
    for (size_t k = 0; k < run && all; ++k) all = same(a[i + k], b[b_first + k]);
    if (all) return static_cast<long>(i);
  }
  return -1;
}

bool SameImu(const ImuMeasurement& x, const ImuMeasurement& y) {
  return x.gyro_z == y.gyro_z && x.roll == y.roll && x.pitch == y.pitch && x.yaw == y.yaw;
}
bool SameWheels(const WheelSpeedMeasurement& x, const WheelSpeedMeasurement& y) {
  return x.left_mps == y.left_mps && x.right_mps == y.right_mps;
}
bool SameScan(const LidarScan& x, const LidarScan& y) {
  if (x.samples.size() != y.samples.size()) return false;
  for (size_t i = 0; i < x.samples.size(); ++i) {
    if (x.samples[i].range_m != y.samples[i].range_m || x.samples[i].theta != y.samples[i].theta) {
      return false;
    }
  }
  return true;
}

// Checks that every record of `b` from b_first on equals `a`'s from the
// aligned index, over their overlap; returns the overlap's length and the
// spread (max - min) of the time offsets b - a, in seconds.
template <typename T, typename Same, typename TimeOf>
size_t ExpectSameRun(const char* what, const std::vector<T>& a, const std::vector<T>& b, size_t b_first,
                     Same same, TimeOf time_of, double* spread_s) {
  const long at = Align(a, b, b_first, 10, same);
  EXPECT_GE(at, 0) << what << ": no run of 10 of the arm64 records found in the amd64 ones";
  if (at < 0) return 0;
  const size_t n = std::min(a.size() - static_cast<size_t>(at), b.size() - b_first);
  double lo = 1e9, hi = -1e9;
  size_t mismatches = 0;
  for (size_t k = 0; k < n; ++k) {
    const T& x = a[static_cast<size_t>(at) + k];
    const T& y = b[b_first + k];
    if (!same(x, y)) ++mismatches;
    const double d = ToSeconds(time_of(y) - time_of(x));
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  EXPECT_EQ(mismatches, 0u) << what << ": of " << n << " records in both";
  *spread_s = hi - lo;
  return n;
}

// Two robotd processes (the amd64 build and the one under test) read the
// very same device bytes (two sets of ptys, one stream) and two workstations
// record them at once: the sessions decode to the same sensor records.
TEST_P(RobotdProcessTest, RecordsTheSameSensorRecordsAsTheAmd64BuildFromTheSameDeviceBytes) {
  sim::SimConfig world;
  ASSERT_TRUE(LoadScenario(Scenario("lab_circle.json"), &world).ok());
  DevicePtys ptys(std::make_unique<SimDevices>(world, SimDevices::Mode::kScripted), 2);
  QString error;
  ASSERT_TRUE(ptys.Open(&error)) << error.toStdString();
  Robotd reference(Builds()[0], ptys.SlavePaths(0), key_file_);
  Robotd tested(GetParam(), ptys.SlavePaths(1), key_file_);
  ASSERT_TRUE(reference.WaitListening(10000)) << reference.Stderr().toStdString();
  ASSERT_TRUE(tested.WaitListening(60000)) << tested.Stderr().toStdString();
  ASSERT_TRUE(WaitFor([&] { return ptys.started(); }, 30000));

  // The app's recorder (RobotConnection) on the amd64 agent, the headless
  // one (sweepscan-cli record) on the agent under test.
  const QString session_a = dir_.filePath("amd64.sweepscan");
  const QString session_b = dir_.filePath(QString::fromStdString(GetParam().name) + "-b.sweepscan");
  RobotConnection a(Client(reference.Address()));
  ASSERT_TRUE(a.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return a.authenticated(); }, 30000));
  ASSERT_TRUE(a.StartRecording(session_a, SessionMeta(), &error)) << error.toStdString();
  a.SetLidarMotor(true);  // Set 0's commands reach the devices.
  QProcess recorder;
  recorder.start(QStringLiteral(SWEEPSCAN_CLI),
                 {"record", "--connect", tested.Address().mid(4), "--key-file", key_file_, "--out",
                  session_b, "--duration", "8", "--json"});
  const double cpu0 = CpuSeconds(tested.pid());
  QElapsedTimer wall;
  wall.start();
  ASSERT_TRUE(WaitFor([&] { return recorder.state() == QProcess::NotRunning; }, 40000));
  const double cpu_per_s = (CpuSeconds(tested.pid()) - cpu0) / (wall.elapsed() * 1e-3);
  ASSERT_EQ(recorder.exitCode(), 0) << recorder.readAllStandardError().toStdString();
  const QJsonObject summary = QJsonDocument::fromJson(recorder.readAllStandardOutput()).object();
  EXPECT_EQ(summary["stopped_by"].toString(), "duration");
  EXPECT_NEAR(summary["seconds"].toDouble(), 8.0, 0.5);
  ASSERT_TRUE(a.StopRecording().ok());
  a.Shutdown();
  EXPECT_EQ(tested.Terminate(), 0) << "SIGTERM ends robotd cleanly";
  EXPECT_EQ(ptys.bytes_dropped(), 0u) << "an agent did not keep up with its device ports";

  SensorLog log_a, log_b;
  SessionDecodeInfo info_a, info_b;
  ASSERT_TRUE(DecodeSession(session_a.toStdString(), &log_a, &info_a).ok());
  ASSERT_TRUE(DecodeSession(session_b.toStdString(), &log_b, &info_b).ok());
  EXPECT_EQ(info_b.link.sequence[0].frames_missing, 0u);
  EXPECT_EQ(info_b.link.codec.checksum_errors, 0u);
  ASSERT_GE(log_b.imu.size(), 500u);  // 100 Hz for most of 8 s.
  ASSERT_GE(log_b.scans.size(), 30u);  // ~7 Hz.
  double imu_spread = 0, wheel_spread = 0, scan_spread = 0;
  // From the second record (scan) on: the first may be a partial one.
  const size_t imu = ExpectSameRun("imu", log_a.imu, log_b.imu, 1, SameImu,
                                   [](const ImuMeasurement& m) { return m.time; }, &imu_spread);
  const size_t wheels = ExpectSameRun("wheels", log_a.wheels, log_b.wheels, 1, SameWheels,
                                      [](const WheelSpeedMeasurement& m) { return m.time; }, &wheel_spread);
  const size_t scans = ExpectSameRun("scans", log_a.scans, log_b.scans, 1, SameScan,
                                     [](const LidarScan& s) { return s.start_time(); }, &scan_spread);
  EXPECT_GE(imu, 500u);
  EXPECT_GE(wheels, 250u);
  EXPECT_GE(scans, 30u);
  // Both agents stamp the bytes as they read them: the offsets between the
  // two clocks vary only by how late each read (qemu is slower).
  EXPECT_LT(imu_spread, 0.25) << "robot-time jitter between the two agents, s";
  std::printf("figure: %s robotd: %zu IMU, %zu wheel records and %zu scans identical to amd64's; "
              "time-stamp spread %.1f ms (IMU), %.1f ms (scans); round trip mean %.2f ms, max %.2f ms; "
              "CPU %.1f %% of one core while streaming\n",
              GetParam().name.c_str(), imu, wheels, scans, imu_spread * 1e3, scan_spread * 1e3,
              summary["round_trip_ms"].toObject()["mean"].toDouble(),
              summary["round_trip_ms"].toObject()["max"].toDouble(), cpu_per_s * 100.0);
}

// The link watchdog under emulation: the workstation drives, then goes quiet;
// robotd must send the motor board its zero within 500 ms (+ a tick and the
// serial write), measured at the board (the pty) in wall-clock time.
TEST_P(RobotdProcessTest, WatchdogStopsTheRobotWithinItsBound) {
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  Robotd robotd(GetParam(), ptys.SlavePaths(0), key_file_, {"--watchdog-ms", "500"});
  ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
  ASSERT_TRUE(WaitFor([&] { return ptys.started(); }, 30000));

  QElapsedTimer wall;
  wall.start();
  double last_moving_ms = -1, zero_ms = -1;
  OnMotorCommands(&ptys, [&](const MotorCommand& c) {
    if (c.vx_mps > 0.2) last_moving_ms = wall.elapsed();
    if (c.vx_mps == 0.0 && last_moving_ms >= 0 && zero_ms < 0) zero_ms = wall.elapsed();
  });
  RobotConnection client(Client(robotd.Address()));
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 30000));
  for (int i = 0; i < 20; ++i) {  // 2 s of driving at 10 Hz.
    client.Drive(0.3, 0.0);
    sweepscan::testing::Pump(100);
  }
  ASSERT_GE(last_moving_ms, 0) << "the board never got a drive command";
  ASSERT_LT(zero_ms, 0) << "stopped while still driving";
  client.SetHeartbeatEnabled(false);
  client.Drive(0.3, 0.0);
  const double quiet_from_ms = wall.elapsed();
  ASSERT_TRUE(WaitFor([&] { return zero_ms >= 0; }, 5000)) << "the watchdog never stopped the robot";
  const double reaction_ms = zero_ms - quiet_from_ms;
  // 500 ms watchdog + a 10 ms tick; emulation and a loaded machine: + 150 ms.
  EXPECT_LE(reaction_ms, 660.0);
  EXPECT_GE(reaction_ms, 450.0);
  std::printf("figure: %s robotd: watchdog stop %.0f ms after the last command (watchdog 500 ms)\n",
              GetParam().name.c_str(), reaction_ms);
  client.Shutdown();
}

// The motor board hears a zero from robotd as it starts (a board that kept a
// crashed agent's last velocity stops: systemd restarts robotd after its
// watchdog killed it mid-drive), as robotd's last word on SIGTERM while a
// client drives (`systemctl stop`, a package upgrade, Ctrl+C), and from
// `--stop-motors` after a crash.
TEST_P(RobotdProcessTest, StopsTheMotorsAsItStartsOnSigtermMidDriveAndAfterACrash) {
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  std::vector<MotorCommand> heard;
  OnMotorCommands(&ptys, [&](const MotorCommand& c) { heard.push_back(c); });
  // A client of `robotd` driving at 0.3 m/s for 2 s (10 Hz: the ramp gets there).
  const auto drive = [&](const Robotd& robotd) {
    auto client = std::make_unique<RobotConnection>(Client(robotd.Address()));
    EXPECT_TRUE(client->Start(&error)) << error.toStdString();
    EXPECT_TRUE(WaitFor([&] { return client->authenticated(); }, 30000));
    for (int i = 0; i < 20; ++i) {
      client->Drive(0.3, 0.0);
      sweepscan::testing::Pump(100);
    }
    return client;
  };
  {
    Robotd robotd(GetParam(), ptys.SlavePaths(0), key_file_);
    ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
    ASSERT_TRUE(WaitFor([&] { return !heard.empty(); }, 5000))
        << "no command reached the motor board as robotd started";
    EXPECT_EQ(heard.front().vx_mps, 0.0);
    EXPECT_EQ(heard.front().wz_radps, 0.0);
    const auto client = drive(robotd);
    ASSERT_GT(heard.back().vx_mps, 0.2) << "the board never got the drive command";
    EXPECT_EQ(robotd.Terminate(), 0) << "SIGTERM ends robotd cleanly";
    sweepscan::testing::Pump(300);  // The pty's last bytes.
    EXPECT_EQ(heard.back().vx_mps, 0.0) << "robotd's last word to the board was not a stop";
    EXPECT_EQ(heard.back().wz_radps, 0.0);
    client->Shutdown();
  }

  // A crashed robotd (SIGKILL here) says nothing to the board, which drives
  // on at its last command. `--stop-motors`, which the service runs after
  // the agent exits however it exits (ExecStopPost), sends the zero command.
  Robotd robotd(GetParam(), ptys.SlavePaths(0), key_file_);
  ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
  const auto client = drive(robotd);
  ASSERT_EQ(::kill(static_cast<pid_t>(robotd.pid()), SIGKILL), 0);
  sweepscan::testing::Pump(300);
  ASSERT_GT(heard.back().vx_mps, 0.2) << "the crash left the board driving";
  const size_t before = heard.size();
  QProcess stop;
  const QStringList command = GetParam().command.mid(1);
  stop.start(GetParam().command.first(),
             QStringList(command) << "--motor" << ptys.SlavePaths(0)[2] << "--stop-motors");
  ASSERT_TRUE(stop.waitForFinished(60000));
  EXPECT_EQ(stop.exitCode(), 0) << stop.readAllStandardError().toStdString();
  ASSERT_TRUE(WaitFor([&] { return heard.size() > before; }, 5000)) << "nothing reached the board";
  EXPECT_EQ(heard.back().vx_mps, 0.0);
  EXPECT_EQ(heard.back().wz_radps, 0.0);
  // A port that is not there: exit 1 with the reason, as the service's log shows.
  stop.start(GetParam().command.first(), QStringList(command) << "--motor"
                                                              << "/nonexistent/tty"
                                                              << "--stop-motors");
  ASSERT_TRUE(stop.waitForFinished(60000));
  EXPECT_EQ(stop.exitCode(), 1);
  EXPECT_NE(stop.readAllStandardError().indexOf("--stop-motors"), -1);
  client->Shutdown();
}

// SIGHUP (the terminal or ssh session that started robotd closed) and
// SIGQUIT (Ctrl+\) mid-drive end robotd as SIGTERM does: through its event
// loop, the zero command its last word to the board, exit 0. Their default
// action killed it with the board driving at its last command.
TEST_P(RobotdProcessTest, SighupAndSigquitMidDriveStopTheMotorsAndExitCleanly) {
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  std::vector<MotorCommand> heard;
  OnMotorCommands(&ptys, [&](const MotorCommand& c) { heard.push_back(c); });
  for (const int signal : {SIGHUP, SIGQUIT}) {
    SCOPED_TRACE(signal == SIGHUP ? "SIGHUP" : "SIGQUIT");
    Robotd robotd(GetParam(), ptys.SlavePaths(0), key_file_);
    ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
    RobotConnection client(Client(robotd.Address()));
    ASSERT_TRUE(client.Start(&error)) << error.toStdString();
    ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 30000));
    for (int i = 0; i < 20; ++i) {  // 2 s at 0.3 m/s, 10 Hz: the ramp gets there.
      client.Drive(0.3, 0.0);
      sweepscan::testing::Pump(100);
    }
    ASSERT_FALSE(heard.empty());
    ASSERT_GT(heard.back().vx_mps, 0.2) << "the board never got the drive command";
    EXPECT_EQ(robotd.Signal(signal), 0)
        << "robotd did not leave cleanly: " << robotd.Stderr().toStdString();
    sweepscan::testing::Pump(300);  // The pty's last bytes.
    EXPECT_EQ(heard.back().vx_mps, 0.0) << "robotd's last word to the board was not a stop";
    EXPECT_EQ(heard.back().wz_radps, 0.0);
    client.Shutdown();
  }
}

// Started under nohup (SIGHUP ignored: to outlive the ssh session),
// robotd keeps running through a SIGHUP, as it did before it took SIGHUP
// as a stop, and still stops cleanly on SIGTERM.
TEST_P(RobotdProcessTest, UnderNohupASighupIsIgnored) {
  if (GetParam().name != "amd64")
    GTEST_SKIP() << "the amd64 build shows the rule; qemu adds its own signals";
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  Build nohup = GetParam();
  nohup.command.prepend(QStringLiteral("nohup"));
  Robotd robotd(nohup, ptys.SlavePaths(0), key_file_);
  ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
  ::kill(static_cast<pid_t>(robotd.pid()), SIGHUP);
  sweepscan::testing::Pump(500);
  EXPECT_TRUE(robotd.Running()) << robotd.Stderr().toStdString();
  EXPECT_EQ(robotd.Terminate(), 0);
}

TEST_P(RobotdProcessTest, ARestartedRobotdIsTheSameClockAndTheRecordingGoesOn) {
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  auto robotd = std::make_unique<Robotd>(GetParam(), ptys.SlavePaths(0), key_file_);
  ASSERT_TRUE(robotd->WaitListening(60000)) << robotd->Stderr().toStdString();
  sweepscan::testing::FaultProxy proxy(robotd->port());
  ASSERT_TRUE(proxy.isListening());
  const QString session = dir_.filePath("restart.sweepscan");
  RobotConnection client(Client(QStringLiteral("tcp:127.0.0.1:%1").arg(proxy.port()), session));
  double outage_s = -1.0;
  QObject::connect(&client, &RobotConnection::linkRestored,
                   [&](double s, const QString&) { outage_s = s; });
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 30000));
  client.SetLidarMotor(true);
  sweepscan::testing::Pump(3000);
  QElapsedTimer down;
  down.start();
  EXPECT_EQ(robotd->Terminate(), 0);
  robotd = std::make_unique<Robotd>(GetParam(), ptys.SlavePaths(0), key_file_);
  ASSERT_TRUE(robotd->WaitListening(60000)) << robotd->Stderr().toStdString();
  proxy.SetTarget(robotd->port());
  ASSERT_TRUE(WaitFor([&] { return outage_s >= 0.0; }, 30000)) << client.health().ToString();
  const double down_s = down.elapsed() * 1e-3;
  client.SetLidarMotor(true);  // The new robotd stopped the X4 when it opened it.
  sweepscan::testing::Pump(3000);
  client.Shutdown();
  ASSERT_TRUE(client.session_status().ok()) << client.session_status().message();
  EXPECT_EQ(client.health().clock_epoch, 0u) << "robotd restarted, the clock did not";

  FramesLoadOptions strict;
  strict.skip_corrupt_records = false;
  SensorLog log;
  SessionDecodeInfo info;
  ASSERT_TRUE(DecodeSession(session.toStdString(), strict, &log, &info).ok());
  std::fprintf(stderr, "%s\n", info.ToString().c_str());
  ASSERT_EQ(info.gaps.size(), 1u);
  const SessionLinkGap& gap = info.gaps[0];
  EXPECT_TRUE(gap.restored);
  EXPECT_FALSE(gap.new_clock_epoch);
  EXPECT_NEAR(gap.outage_s, down_s, 1.5);
  // What the devices sent while no robotd read them (a pty keeps a few kB,
  // read by the new robotd at its start) is lost, and said to be.
  EXPECT_GT(gap.data_lost_s[1], 0.0);
  EXPECT_LT(gap.data_lost_s[1], down_s + 2.0);
  std::printf("figure: %s robotd restarted: link down %.2f s, IMU data lost %.2f s\n",
              GetParam().name.c_str(), gap.outage_s, gap.data_lost_s[1]);
  ASSERT_FALSE(log.imu.empty());
  for (size_t i = 1; i < log.imu.size(); ++i) ASSERT_GE(log.imu[i].time, log.imu[i - 1].time) << i;
  EXPECT_GT(ToSeconds(log.imu.back().time - log.imu.front().time), 5.0);
  ASSERT_FALSE(log.scans.empty()) << "the lidar scans again after the restart";
  EXPECT_GT(ToSeconds(log.scans.back().end_time() - log.imu.front().time), 5.0);
}

// A device port that is lost (its USB adapter pulled out) is noticed, as
// docs/robot-agent.md says: "port lost" in the log, Status fault bit 5, and
// opened again every second until it returns behind its stable name; the
// agent idles meanwhile. Qt reports the hung-up port's empty reads as a
// ReadError, which robotd took for harmless: the port stayed "open", its read
// notifier spun a core, and it was never reopened (the board plugged in
// again got nothing, not even the zero command).
TEST_P(RobotdProcessTest, ALostDevicePortIsNoticedAndOpenedAgainWithoutSpinning) {
  const QString link = dir_.filePath("motor");
  auto board = std::make_unique<BoardPty>();
  ASSERT_TRUE(board->Open());
  ASSERT_TRUE(QFile::link(board->slave, link));
  Robotd robotd(GetParam(), {QString(), QString(), link}, key_file_);
  ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
  std::string heard;
  ASSERT_TRUE(WaitFor([&] { return ReadAvailable(board->master, &heard) >= 11; }, 10000))
      << "no zero command as the port opened";
  ASSERT_EQ(::write(board->master, "board", 5), 5);
  sweepscan::testing::Pump(200);

  // No client meanwhile, as on a robot waiting for its workstation (a
  // client's socket changes which error Qt makes of the empty read).
  QString log;
  board->Unplug();
  // The name goes with the device, as udev's does: left pointing at the
  // freed /dev/pts/N, it would lead robotd's retries to the next pty of
  // that number, another test's under ctest -j.
  ASSERT_TRUE(QFile::remove(link));
  ASSERT_TRUE(WaitFor(
      [&] {
        log += robotd.Stderr();
        return log.contains("port lost");
      },
      10000))
      << "the lost port was not noticed: " << log.toStdString();
  // Retried every second against a name that is not there: robotd idles.
  // Spinning on the hung-up port took a core.
  const double cpu0 = CpuSeconds(robotd.pid());
  IdleFor(2000);
  const double cpu_s = CpuSeconds(robotd.pid()) - cpu0;
  EXPECT_LT(cpu_s, 0.6) << "robotd's CPU seconds over 2 s with the port lost";
  std::printf("figure: %s robotd: %.2f s of CPU over 2 s with the motor port lost\n",
              GetParam().name.c_str(), cpu_s);
  RobotConnection client(Client(robotd.Address()));
  QString error;
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 30000));
  const auto status = [&] { return client.health().agent_status; };
  ASSERT_TRUE(WaitFor([&] { return (status().fault_bits & kFaultDevicePortError) != 0; }, 5000))
      << "Status fault bit 5 (fault bits " << status().fault_bits << ")";
  EXPECT_EQ(status().device_bytes[2], 5u) << "the board's bytes before the loss";

  // Plugged in again: a new node behind the same name.
  board = std::make_unique<BoardPty>();
  ASSERT_TRUE(board->Open());
  ASSERT_TRUE(QFile::link(board->slave, link));
  heard.clear();
  ASSERT_TRUE(WaitFor([&] { return ReadAvailable(board->master, &heard) >= 11; }, 10000))
      << "the port was not opened again: " << (log + robotd.Stderr()).toStdString();
  EXPECT_EQ(static_cast<uint8_t>(heard[0]), 0x7b) << "the command in force (zero) as it reopens";
  ASSERT_EQ(::write(board->master, "again", 5), 5);
  EXPECT_TRUE(WaitFor([&] { return status().device_bytes[2] == 10; }, 10000))
      << "the board's bytes after the replug: " << status().device_bytes[2];
  EXPECT_EQ(status().fault_bits & kFaultDevicePortError, 0u) << "fault bit 5 cleared";
  log += robotd.Stderr();
  EXPECT_TRUE(log.contains("reopened")) << log.toStdString();
  client.Shutdown();
}

// As the packaged service runs it: options from a config file (the command
// line overriding it), and systemd's notification protocol (sd_notify) on a
// datagram socket: READY=1 once listening, WATCHDOG=1 at half WatchdogSec,
// STOPPING=1 on SIGTERM. The ping's period is checked, not only that pings
// come: WatchdogSec 1 s against the file's link watchdog of 300 ms, so that
// pings at any other cadence (the link watchdog's, or WatchdogSec itself,
// which would let systemd kill a healthy agent) fail.
TEST_P(RobotdProcessTest, ConfigFileAndServiceNotifications) {
  DevicePtys ptys(std::make_unique<SimDevices>(sim::SimConfig(), SimDevices::Mode::kCommanded), 1);
  QString error;
  ASSERT_TRUE(ptys.Open(&error)) << error.toStdString();
  const auto ports = ptys.SlavePaths(0);
  const QString config = dir_.filePath("robotd.conf");
  QFile f(config);
  ASSERT_TRUE(f.open(QIODevice::WriteOnly));
  f.write(QStringLiteral("# as /etc/sweepscan/robotd.conf\nlidar = %1\nimu=%2\n  motor =  %3  # the board\n"
                         "listen = 127.0.0.1:1\nkey-file = %4\nwatchdog-ms = 300\n")
              .arg(ports[0], ports[1], ports[2], key_file_)
              .toUtf8());
  f.close();

  const QString socket_path = dir_.filePath("notify");
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof(address.sun_path), "%s", qPrintable(socket_path));
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
  QStringList messages;
  QElapsedTimer clock;
  clock.start();
  std::vector<qint64> watchdog_ms;  // When each WATCHDOG=1 arrived.
  auto receive = [&] {
    char buffer[512];
    ssize_t n;
    while ((n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0) {
      messages << QString::fromUtf8(buffer, static_cast<int>(n));
      if (messages.back() == "WATCHDOG=1") watchdog_ms.push_back(clock.elapsed());
    }
  };

  QProcess robotd;
  QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
  env.insert("NOTIFY_SOCKET", socket_path);
  // WatchdogSec=1 (systemd sets WATCHDOG_PID too; it may be omitted): a ping every 500 ms.
  env.insert("WATCHDOG_USEC", "1000000");
  constexpr double kPingMs = 500.0;
  robotd.setProcessEnvironment(env);
  // --listen on the command line wins over the file's (port 1 needs root).
  robotd.start(GetParam().command.first(),
               GetParam().command.mid(1) + QStringList{"--config", config, "--listen", "127.0.0.1:0"});
  ASSERT_TRUE(WaitFor([&] { return robotd.readAllStandardOutput().contains("listening on 127.0.0.1:"); }, 60000))
      << robotd.readAllStandardError().toStdString();
  // Nine pings (4 s): their mean period is the configured one, whatever
  // the load (a late ping delays only itself, the timer keeps its period).
  ASSERT_TRUE(WaitFor(
      [&] {
        receive();
        return watchdog_ms.size() >= 9;
      },
      20000))
      << messages.join('|').toStdString();
  const double mean_ms = static_cast<double>(watchdog_ms.back() - watchdog_ms.front()) /
                         static_cast<double>(watchdog_ms.size() - 1);
  EXPECT_GT(mean_ms, 0.8 * kPingMs) << "WATCHDOG=1 more often than WatchdogSec / 2";
  EXPECT_LT(mean_ms, 1.25 * kPingMs) << "WATCHDOG=1 less often than WatchdogSec / 2";
  std::printf("figure: %s robotd: WATCHDOG=1 every %.0f ms on average (WatchdogSec 1 s)\n",
              GetParam().name.c_str(), mean_ms);
  ASSERT_FALSE(messages.isEmpty());
  EXPECT_TRUE(messages.first().startsWith("READY=1\nSTATUS=listening on 127.0.0.1:")) << messages.first().toStdString();
  EXPECT_TRUE(ptys.started()) << "robotd opened the file's device ports";
  robotd.terminate();
  ASSERT_TRUE(robotd.waitForFinished(20000));
  EXPECT_EQ(robotd.exitCode(), 0);
  receive();
  EXPECT_EQ(messages.last(), "STOPPING=1");
  ::close(fd);

  // A bad line is refused with the file and line.
  ASSERT_TRUE(f.open(QIODevice::WriteOnly | QIODevice::Truncate));
  f.write("lidar = /dev/null\nspeed = 3\n");
  f.close();
  robotd.start(GetParam().command.first(), GetParam().command.mid(1) + QStringList{"--config", config});
  ASSERT_TRUE(robotd.waitForFinished(60000));
  EXPECT_EQ(robotd.exitCode(), 2);
  EXPECT_TRUE(robotd.readAllStandardError().contains(QStringLiteral("%1:2: unknown key 'speed'").arg(config).toUtf8()));
}

// `--stop-motors` as the service's ExecStopPost runs it, through the
// configuration file: `sweepscan-robotd --config /etc/sweepscan/robotd.conf
// --stop-motors`. The board's port comes from the file; nothing else in it
// matters (a bad value elsewhere must not keep the board driving).
TEST_P(RobotdProcessTest, StopMotorsThroughTheConfigFileAsTheServiceRunsIt) {
  std::unique_ptr<DevicePtys> lab = LabDevicePtys();
  ASSERT_TRUE(lab);
  DevicePtys& ptys = *lab;
  QString error;
  const auto ports = ptys.SlavePaths(0);
  std::vector<MotorCommand> heard;
  OnMotorCommands(&ptys, [&](const MotorCommand& c) { heard.push_back(c); });
  // Driving, then killed (a crash says nothing to the board).
  Robotd robotd(GetParam(), ports, key_file_);
  ASSERT_TRUE(robotd.WaitListening(60000)) << robotd.Stderr().toStdString();
  RobotConnection client(Client(robotd.Address()));
  ASSERT_TRUE(client.Start(&error)) << error.toStdString();
  ASSERT_TRUE(WaitFor([&] { return client.authenticated(); }, 30000));
  for (int i = 0; i < 20; ++i) {
    client.Drive(0.3, 0.0);
    sweepscan::testing::Pump(100);
  }
  ASSERT_EQ(::kill(static_cast<pid_t>(robotd.pid()), SIGKILL), 0);
  sweepscan::testing::Pump(300);
  ASSERT_FALSE(heard.empty());
  ASSERT_GT(heard.back().vx_mps, 0.2) << "the crash left the board driving";
  client.Shutdown();

  const QString config = dir_.filePath("robotd.conf");
  QFile f(config);
  ASSERT_TRUE(f.open(QIODevice::WriteOnly));
  f.write(QStringLiteral("# as /etc/sweepscan/robotd.conf\nlidar = %1\nimu = %2\nmotor = %3\n"
                         "listen = 127.0.0.1:5600\nkey-file = %4\nwatchdog-ms = 500\n"
                         "v-max = nan   # a bad value: the agent would refuse to start\n"
                         "name = %5\n")
              .arg(ports[0], ports[1], ports[2], key_file_, QString(240, 'n'))
              .toUtf8());
  f.close();
  const size_t before = heard.size();
  QProcess stop;
  stop.start(GetParam().command.first(),
             GetParam().command.mid(1) + QStringList{"--config", config, "--stop-motors"});
  ASSERT_TRUE(stop.waitForFinished(60000));
  EXPECT_EQ(stop.exitCode(), 0) << stop.readAllStandardError().toStdString();
  EXPECT_TRUE(stop.readAllStandardOutput().contains(
      QStringLiteral("zero command sent to the motor board on %1").arg(ports[2]).toUtf8()));
  ASSERT_TRUE(WaitFor([&] { return heard.size() > before; }, 5000)) << "nothing reached the board";
  EXPECT_EQ(heard.back().vx_mps, 0.0);
  EXPECT_EQ(heard.back().wz_radps, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Builds, RobotdProcessTest, ::testing::ValuesIn(Builds()),
                         [](const ::testing::TestParamInfo<Build>& info) { return info.param.name; });

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
