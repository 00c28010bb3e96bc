// sweepscan-robotd as a process, as systemd and an operator start and stop
// it: its key file's permissions and the refusal's words, its options, its
// configuration file (quoting, bad lines, the link given on the command
// line), and its start-up and shutdown (a stop during start-up, a wedged
// serial adapter at the stop). Its notifications to systemd:
// service_notify_test.cc.
// Real processes, pseudo-terminals for the boards and loopback TCP; the
// kernel holds chosen calls (seccomp user notification) where a test needs
// a slow open or a wedged port.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QFile>
#include <QProcess>
#include <QProcessEnvironment>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "hardware/agent/robot_agent.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/link/hmac_sha256.h"
#include "hardware/link/qt_transport.h"
#include "hardware/station/robot_connection.h"
#include "tests/testing/forged_link_frames.h"
#include "tests/testing/held_ioctl_process.h"
#include "tests/testing/qt_wait.h"
#include "tests/testing/read_available.h"

namespace sweepscan {
namespace hardware {
namespace {

using testing::HeldIoctlProcess;
using testing::ReadAvailable;
using testing::WaitFor;

// --- Key files and options of sweepscan-robotd ---------------------------

std::string TempDirPath() {
  static const std::string dir = [] {
    char tmpl[] = "/tmp/sweepscan_hardening_XXXXXX";
    return std::string(::mkdtemp(tmpl));
  }();
  return dir;
}

std::string WriteKey(const std::string& name, const std::string& content, mode_t mode) {
  const std::string path = TempDirPath() + "/" + name;
  std::ofstream(path, std::ios::binary) << content;
  ::chmod(path.c_str(), mode);
  return path;
}

TEST(KeyFileHardeningTest, PermissionsSizeAndFolders) {
  std::vector<uint8_t> key;
  QString error, warning;
  const QString shared = QString::fromStdString(WriteKey("shared.key", "secret\n", 0644));
  const QString own = QString::fromStdString(WriteKey("own.key", "secret\n", 0600));
  // Like ssh: a key others may read is refused by the agent ...
  EXPECT_FALSE(ReadKeyFile(shared, &key, &error, KeyFilePermissions::kOwnerOnly));
  EXPECT_TRUE(error.contains("chmod 600")) << error.toStdString();
  EXPECT_TRUE(error.contains("0644")) << error.toStdString();
  // ... warned about by the simulator, accepted as before by default.
  EXPECT_TRUE(ReadKeyFile(shared, &key, &error, KeyFilePermissions::kWarn, &warning));
  EXPECT_TRUE(warning.contains("can be read by its group and others (mode 0644)"))
      << warning.toStdString();
  EXPECT_TRUE(ReadKeyFile(shared, &key, &error));
  ASSERT_TRUE(ReadKeyFile(own, &key, &error, KeyFilePermissions::kOwnerOnly));
  EXPECT_EQ(std::string(key.begin(), key.end()), "secret");
  // Oversized keys are refused, not cut (the first 64 KiB used to be taken).
  const QString big =
      QString::fromStdString(WriteKey("big.key", std::string(64 * 1024 + 1, 'k'), 0600));
  EXPECT_FALSE(ReadKeyFile(big, &key, &error, KeyFilePermissions::kOwnerOnly));
  EXPECT_TRUE(error.contains("refused")) << error.toStdString();
  const QString exact =
      QString::fromStdString(WriteKey("exact.key", std::string(64 * 1024, 'k'), 0600));
  EXPECT_TRUE(ReadKeyFile(exact, &key, &error, KeyFilePermissions::kOwnerOnly));
  EXPECT_EQ(key.size(), 64u * 1024u);
  EXPECT_FALSE(ReadKeyFile(QString::fromStdString(TempDirPath()), &key, &error));
  EXPECT_TRUE(error.contains("folder")) << error.toStdString();
}

// The refusal says what the mode allows, and whom: a key file of mode 0620
// (its group may write it, not read it) was refused as "readable by
// others". The rule is unchanged: any access at all for the group or others
// is refused (a key its group may write may be replaced by a key of theirs).
TEST(KeyFileHardeningTest, TheRefusalSaysWhatTheModeAllowsAndTheFix) {
  const struct {
    mode_t mode;
    const char* says;  // After "key file PATH ".
  } cases[] = {
      {0620, "can be written by its group (mode 0620)"},
      {0640, "can be read by its group (mode 0640)"},
      {0604, "can be read by others (mode 0604)"},
      {0602, "can be written by others (mode 0602)"},
      {0644, "can be read by its group and others (mode 0644)"},
      {0664, "can be read and written by its group, and read by others (mode 0664)"},
      {0610, "can be executed by its group (mode 0610)"},
      {0677, "can be read, written and executed by its group and others (mode 0677)"},
      {0401, "can be executed by others (mode 0401)"},
  };
  for (const auto& c : cases) {
    const QString path = QString::fromStdString(WriteKey("mode.key", "secret\n", c.mode));
    std::vector<uint8_t> key;
    QString error;
    EXPECT_FALSE(ReadKeyFile(path, &key, &error, KeyFilePermissions::kOwnerOnly)) << c.says;
    EXPECT_EQ(error.toStdString(),
              QStringLiteral("key file %1 %2; only its owner may have access: chmod 600 %1")
                  .arg(path, QString::fromLatin1(c.says))
                  .toStdString());
  }
  for (const mode_t mode : {0400, 0600, 0700}) {
    const QString path = QString::fromStdString(WriteKey("mode.key", "secret\n", mode));
    std::vector<uint8_t> key;
    QString error;
    EXPECT_TRUE(ReadKeyFile(path, &key, &error, KeyFilePermissions::kOwnerOnly))
        << std::oct << mode << ": " << error.toStdString();
  }
}

struct ProcessRun {
  int code = -1;
  std::string err;
};
ProcessRun RunRobotd(const std::vector<std::string>& args) {
  std::string command = SWEEPSCAN_ROBOTD;
  for (const std::string& a : args) command += " '" + a + "'";
  command += " 2>&1";
  ProcessRun r;
  FILE* p = ::popen(command.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), p)) > 0) r.err.append(buf, n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(RobotdOptionsTest, UnsafeKeyFilesAndWatchdogPeriodsAreRefused) {
  const std::string own = WriteKey("robotd.key", "secret\n", 0600);
  const std::string shared = WriteKey("robotd-shared.key", "secret\n", 0644);
  const std::string big = WriteKey("robotd-big.key", std::string(100000, 'k'), 0600);
  const std::vector<std::string> base = {"--imu", "/nonexistent/tty", "--listen", "127.0.0.1:0"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = base;
    a.insert(a.end(), extra.begin(), extra.end());
    return RunRobotd(a);
  };
  ProcessRun r = with({"--key-file", shared});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("chmod 600"), std::string::npos) << r.err;
  // Writable by its group, not readable: said as such (it said "readable by others").
  const std::string group_writable = WriteKey("robotd-group-writable.key", "secret\n", 0620);
  r = with({"--key-file", group_writable});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("sweepscan-robotd: key file " + group_writable +
                       " can be written by its group (mode 0620); only its owner may have "
                       "access: chmod 600 " +
                       group_writable + "\n"),
            std::string::npos)
      << r.err;
  r = with({"--key-file", big});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("refused"), std::string::npos) << r.err;
  for (const char* ms : {"1e9", "0", "50", "5001", "nan", "-500"}) {
    r = with({"--key-file", own, "--watchdog-ms", ms});
    EXPECT_EQ(r.code, 2) << ms << ": " << r.err;
    EXPECT_NE(r.err.find("100..5000"), std::string::npos) << ms << ": " << r.err;
  }
}

// --- sweepscan-robotd's configuration file -------------------------------

// A pseudo-terminal for robotd's --serial link; the test holds the master
// (not inherited by robotd, so closing it here is the far end going away).
struct LinkPty {
  int master = -1;
  std::string slave;
  LinkPty() {
    int slave_fd = -1;
    char name[128];
    termios raw{};
    ::cfmakeraw(&raw);
    if (::openpty(&master, &slave_fd, name, &raw, nullptr) != 0) return;
    ::fcntl(master, F_SETFL, O_NONBLOCK);
    ::fcntl(master, F_SETFD, FD_CLOEXEC);
    ::close(slave_fd);
    slave = name;
  }
  ~LinkPty() {
    if (master >= 0) ::close(master);
  }
};

// robotd with `args` until its stdout says `serving`; returns its stdout.
// Ends it with SIGTERM; *exit_code is its exit code (-1: killed or hung).
std::string ServeAndStop(const QStringList& args, const char* serving, int* exit_code,
                         const std::function<void()>& while_serving = {}) {
  QProcess robotd;
  robotd.start(QStringLiteral(SWEEPSCAN_ROBOTD), args);
  QByteArray out;
  const bool served = WaitFor(
      [&] {
        out += robotd.readAllStandardOutput();
        return out.contains(serving) || robotd.state() == QProcess::NotRunning;
      },
      10000);
  if (served && out.contains(serving) && while_serving) while_serving();
  robotd.terminate();
  robotd.waitForFinished(10000);
  *exit_code = robotd.exitStatus() == QProcess::NormalExit ? robotd.exitCode() : -1;
  return (out + robotd.readAllStandardError()).toStdString();
}

std::string WriteConfig(const std::string& name, const std::string& text) {
  return WriteKey(name, text, 0600);
}

// The command line overrides the file, the link included: `--serial` with
// the packaged file (which sets `listen`) serves the serial link, and
// `--listen` beats a file's `serial`. Refused before: "--listen and --serial
// exclude each other". A `#` inside a value is part of it; one after a space
// starts a comment. The serial link has no authentication: the file's
// key file is not read there (a missing one stopped the agent), and
// `--key-file` beside `--serial` on the command line is refused.
TEST(RobotdConfigFileTest, TheCommandLinesLinkReplacesTheFilesAndHashInsideAValueIsKept) {
  const std::string key = WriteKey("config-test.key", "the config test's key", 0600);
  LinkPty link;
  ASSERT_GE(link.master, 0);
  const std::string with_listen =
      WriteConfig("listen.conf",
                  "imu = /nonexistent/tty\nlisten = 127.0.0.1:1\nkey-file = /nonexistent/robotd.key"
                  "\nname = robot#2   # the second one\n");
  std::string hello;
  int code = -1;
  const std::string out = ServeAndStop({"--config", QString::fromStdString(with_listen), "--serial",
                                        QString::fromStdString(link.slave)},
                                       "serving the link on", &code, [&] {
                                         WaitFor(
                                             [&] {
                                               return ReadAvailable(link.master, &hello) > 0 &&
                                                      hello.find("robot#2") != std::string::npos;
                                             },
                                             5000);
                                       });
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("serving the link on " + link.slave), std::string::npos) << out;
  EXPECT_NE(hello.find("sweepscan-robotd 0.1.0 (robot#2)"), std::string::npos)
      << "the Hello's name: " << hello.size() << " bytes read";
  EXPECT_EQ(hello.find("second one"), std::string::npos);
  EXPECT_NE(out.find("note: " + with_listen +
                     ":3: key-file: not used on the serial link (it has no authentication)"),
            std::string::npos)
      << out;

  const std::string with_serial =
      WriteConfig("serial.conf",
                  "imu = /nonexistent/tty\nserial = /nonexistent/modem\nkey-file = " + key + "\n");
  const std::string out2 =
      ServeAndStop({"--config", QString::fromStdString(with_serial), "--listen", "127.0.0.1:0"},
                   "listening on", &code);
  EXPECT_EQ(code, 0) << out2;
  EXPECT_NE(out2.find("listening on 127.0.0.1:"), std::string::npos) << out2;

  // Both in the file, or both on the command line: still one or the other.
  const std::string both = WriteConfig("both.conf",
                                       "imu = /nonexistent/tty\nlisten = 127.0.0.1:0\n"
                                       "serial = /nonexistent/modem\n");
  ProcessRun r = RunRobotd({"--config", both});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find(both + ":2: listen and " + both + ":3: serial exclude each other"),
            std::string::npos)
      << r.err;
  r = RunRobotd(
      {"--imu", "/nonexistent/tty", "--listen", "127.0.0.1:0", "--serial", "/nonexistent/modem"});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--listen and --serial exclude each other"), std::string::npos) << r.err;
  r = RunRobotd({"--imu", "/nonexistent/tty", "--serial", link.slave, "--key-file", key});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--key-file does not apply to the serial link"), std::string::npos) << r.err;
}

// Values quoted as in systemd's or shell files (`serial = "/dev/pts/3"`)
// lose one pair of matching quotes; a `#` inside the quotes is the value's.
// Until 2026-11-29 the quotes were kept: the link's port was opened as
// `"/dev/pts/3"` (with its quotes) and robotd gave up. A quote left open, or
// text after the closing one, is refused at its line.
TEST(RobotdConfigFileTest, QuotedValuesLoseTheirQuotes) {
  LinkPty link;
  ASSERT_GE(link.master, 0);
  const std::string quoted =
      WriteConfig("quoted.conf", "imu = '/nonexistent/tty'\nserial = \"" + link.slave +
                                     "\"   # the radio\nname = \"robot #2's\" # the second one\n");
  std::string hello;
  int code = -1;
  const std::string out =
      ServeAndStop({"--config", QString::fromStdString(quoted)}, "serving the link on", &code, [&] {
        WaitFor(
            [&] {
              return ReadAvailable(link.master, &hello) > 0 &&
                     hello.find("robot #2's") != std::string::npos;
            },
            5000);
      });
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("serving the link on " + link.slave + "\n"), std::string::npos) << out;
  EXPECT_NE(hello.find("sweepscan-robotd 0.1.0 (robot #2's)"), std::string::npos)
      << "the Hello's name: " << hello.size() << " bytes read";
  EXPECT_NE(out.find("/nonexistent/tty: "), std::string::npos)
      << "the IMU's port, unquoted: " << out;

  const struct {
    std::string line;  // Line 2 of the file.
    std::string says;  // After "FILE:2: ".
  } cases[] = {
      {"lidar = \"/dev/ttyUSB0", "'lidar': the value's \" is not closed"},
      {"name = 'robot' 2", "'name': text after the value's closing ': '2'"},
      {"name = \"\"", "'name' has no value"},
  };
  for (const auto& c : cases) {
    const std::string conf =
        WriteConfig("bad-quotes.conf", "imu = /nonexistent/tty\n" + c.line + "\n");
    const ProcessRun r = RunRobotd({"--config", conf});
    EXPECT_EQ(r.code, 2) << c.line << ": " << r.err;
    EXPECT_NE(r.err.find(conf + ":2: " + c.says), std::string::npos) << c.line << ": " << r.err;
  }
}

// A bad value from the file names the setting as it is written there and
// its FILE:LINE (it said "v_max must be positive and finite" for
// `v-max = nan`, naming neither); on the command line, the option.
TEST(RobotdConfigFileTest, BadValuesFromTheFileNameTheSettingAndItsLine) {
  const std::string key = WriteKey("config-values.key", "the config test's key", 0600);
  const struct {
    std::string line;  // Line 3 of the file.
    std::string says;  // After "FILE:3: ".
  } cases[] = {
      {"v-max = nan", "v-max must be within (0, 32], got nan"},
      {"w-max = 40", "w-max must be within (0, 32], got 40"},
      {"alpha-max = -1", "alpha-max must be positive and finite, got -1"},
      {"accel-max = fast", "accel-max: 'fast' is not a number"},
      {"watchdog-ms = 1e9", "watchdog-ms must be within 100..5000, got 1e9"},
      {"buffer-s = 99", "buffer-s must be within 0..60, got 99"},
      {"listen = nowhere", "listen: link address 'nowhere': expected HOST:PORT"},
      {"listen = robot.local:5600", "listen: 'robot.local' is not an IP address"},
      {"serial = /dev/ttyS1@fast", "serial: link address 'serial:/dev/ttyS1@fast': bad baud rate"},
      {"name = " + std::string(240, 'n'), "name is over 230 bytes"},
  };
  for (const auto& c : cases) {
    const std::string conf = WriteConfig("values.conf", "# robotd\nimu = /nonexistent/tty\n" +
                                                            c.line + "\nkey-file = " + key + "\n");
    const ProcessRun r = RunRobotd({"--config", conf});
    EXPECT_EQ(r.code, 2) << c.line << ": " << r.err;
    EXPECT_NE(r.err.find(conf + ":3: " + c.says), std::string::npos) << c.line << ": " << r.err;
  }
  const std::string conf =
      WriteConfig("key.conf", "imu = /nonexistent/tty\nkey-file = /nonexistent/robotd.key\n");
  ProcessRun r = RunRobotd({"--config", conf});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find(conf + ":2: key-file: key file /nonexistent/robotd.key"), std::string::npos)
      << r.err;
  // The command line's own values are named by their option.
  r = RunRobotd({"--imu", "/nonexistent/tty", "--serial", "/nonexistent/modem", "--v-max", "nan"});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("sweepscan-robotd: --v-max must be within (0, 32], got nan"),
            std::string::npos)
      << r.err;
  // A value on the command line overrides the file's bad one.
  const std::string bad = WriteConfig("bad-v.conf", "imu = /nonexistent/tty\nv-max = nan\n");
  int code = -1;
  const std::string out =
      ServeAndStop({"--config", QString::fromStdString(bad), "--v-max", "0.4", "--listen",
                    "127.0.0.1:0", "--key-file", QString::fromStdString(key)},
                   "listening on", &code);
  EXPECT_EQ(code, 0) << out;
}

// `--config FILE --stop-motors` (the service's ExecStopPost) did nothing
// when the file had an unknown or a repeated key: exit 2, the motor port
// never opened, the board left driving after a crash. It reads the file
// leniently now: the motor port is found, the file's mistakes are warnings,
// and the board (a pseudo-terminal here) gets zero commands. Only a motor
// port that cannot be found or opened fails it.
TEST(RobotdConfigFileTest, StopMotorsStopsTheBoardWhateverElseTheFileGetsWrong) {
  LinkPty board;
  ASSERT_GE(board.master, 0);
  const std::string conf =
      WriteConfig("broken.conf",
                  "lidar = /nonexistent/lidar\nmotor = /nonexistent/motor\n"
                  "wheel-base = 0.3\nwatchdog-ms = 500\nwatchdog-ms = 400\nnot a setting\n"
                  "motor = " +
                      board.slave + "\n");
  ProcessRun r = RunRobotd({"--config", conf});
  EXPECT_EQ(r.code, 2) << "the agent itself still refuses the file: " << r.err;
  r = RunRobotd({"--config", conf, "--stop-motors"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find(conf + ":3: unknown key 'wheel-base'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(conf + ":5: 'watchdog-ms' is set twice"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(conf + ":7: 'motor' is set twice; the last one is used"), std::string::npos)
      << r.err;
  std::string bytes;
  WaitFor(
      [&] {
        ReadAvailable(board.master, &bytes);
        return bytes.size() >= 11;
      },
      3000);
  MotorCommandDecoder decoder;
  decoder.Feed(std::vector<uint8_t>(bytes.begin(), bytes.end()), Time());
  const std::vector<MotorCommand> commands = decoder.TakeRecords();
  ASSERT_FALSE(commands.empty()) << "nothing reached the board (" << bytes.size() << " bytes)";
  for (const MotorCommand& c : commands) {
    EXPECT_EQ(c.vx_mps, 0.0);
    EXPECT_EQ(c.wz_radps, 0.0);
  }
  // No motor port to be opened: that is a failure, said as such.
  const std::string lost =
      WriteConfig("lost.conf", "wheel-base = 0.3\nmotor = /nonexistent/motor\n");
  r = RunRobotd({"--config", lost, "--stop-motors"});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("/nonexistent/motor"), std::string::npos) << r.err;
}

// --- sweepscan-robotd's start-up and shutdown ---------------------------

// systemd's notification socket (NOTIFY_SOCKET), read by the test.
struct NotifySocket {
  int fd = -1;
  std::string path;
  explicit NotifySocket(std::string at) : path(std::move(at)) {
    ::unlink(path.c_str());
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::snprintf(address.sun_path, sizeof(address.sun_path), "%s", path.c_str());
    if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ~NotifySocket() {
    if (fd >= 0) ::close(fd);
    ::unlink(path.c_str());
  }
  // The messages received so far, each followed by '|'.
  std::string Receive() {
    std::string all;
    char buffer[512];
    ssize_t n;
    while ((n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0) all.append(buffer, n).append("|");
    return all;
  }
};

// `systemctl stop` while robotd starts (here: while it reads its
// configuration, or its key, from a pipe that the test fills only after its
// SIGTERM) ends the start there: exit 0 with a line saying so, no port
// opened, never "listening on" nor READY=1. It was acted on only once the
// event loop ran: robotd opened its ports, sent the board its zero, served
// the link and told systemd it was ready, and only then stopped.
TEST(RobotdStartupTest, AStopDuringStartUpEndsItBetweenItsSteps) {
  for (const bool key_in_pipe : {false, true}) {
    SCOPED_TRACE(key_in_pipe ? "the key file is a pipe" : "the configuration file is a pipe");
    LinkPty board;  // The motor board: robotd must not open its port.
    ASSERT_GE(board.master, 0);
    const std::string key = WriteKey("startup.key", "the start-up test's key", 0600);
    const std::string pipe = TempDirPath() + "/startup.fifo";
    ::unlink(pipe.c_str());
    ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0) << std::strerror(errno);
    const std::string conf_text = "motor = " + board.slave + "\nlisten = 127.0.0.1:0\nkey-file = " +
                                  (key_in_pipe ? pipe : key) + "\n";
    const std::string conf = key_in_pipe ? WriteConfig("startup.conf", conf_text) : pipe;
    NotifySocket notify(TempDirPath() + "/startup.notify");
    ASSERT_GE(notify.fd, 0);
    QProcess robotd;
    QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
    env.insert("NOTIFY_SOCKET", QString::fromStdString(notify.path));
    robotd.setProcessEnvironment(env);
    robotd.start(QStringLiteral(SWEEPSCAN_ROBOTD), {"--config", QString::fromStdString(conf)});
    // robotd blocks opening the pipe until a writer opens it; a writer's
    // non-blocking open succeeds only once robotd has it open for reading,
    // that is after robotd put its signal handlers in place.
    int writer = -1;
    ASSERT_TRUE(WaitFor(
        [&] {
          writer = ::open(pipe.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
          return writer >= 0 || robotd.state() == QProcess::NotRunning;
        },
        20000));
    ASSERT_GE(writer, 0) << robotd.readAllStandardError().toStdString();
    // SIGQUIT for the key: each signal is named as it is (glibc names them).
    const int signal = key_in_pipe ? SIGQUIT : SIGTERM;
    ASSERT_EQ(::kill(static_cast<pid_t>(robotd.processId()), signal), 0);
    // Then the rest of the start-up can go on: the file's bytes and its end.
    const std::string text = key_in_pipe ? std::string("the start-up test's key") : conf_text;
    ASSERT_EQ(::write(writer, text.data(), text.size()), static_cast<ssize_t>(text.size()));
    ::close(writer);
    ASSERT_TRUE(robotd.waitForFinished(20000)) << "robotd did not leave";
    const std::string out = robotd.readAllStandardOutput().toStdString();
    const std::string err = robotd.readAllStandardError().toStdString();
    EXPECT_EQ(robotd.exitStatus(), QProcess::NormalExit) << err;
    EXPECT_EQ(robotd.exitCode(), 0) << err;
    EXPECT_NE(err.find(std::string("sweepscan-robotd: ") + (key_in_pipe ? "SIGQUIT" : "SIGTERM") +
                       " during start-up: stopped before the ports were opened; exiting"),
              std::string::npos)
        << err;
    EXPECT_EQ(out.find("listening on"), std::string::npos) << out;
    EXPECT_EQ(notify.Receive().find("READY=1"), std::string::npos) << "ready while stopping";
    std::string heard;
    ReadAvailable(board.master, &heard);
    EXPECT_EQ(heard.size(), 0u) << "the motor port was opened after the stop";
    ::unlink(pipe.c_str());
  }
}

// SIGTERM's shutdown waits for the zero command to leave the motor board's
// port, and that wait is bounded: 200 ms, then what the driver holds is
// thrown away, the port closed, said in the log, exit 0. The driver's own
// wait (tcdrain) had no bound: on a wedged adapter `systemctl stop` hung
// until systemd killed the agent (TimeoutStopSec), the port never closed.
TEST(RobotdShutdownTest, AWedgedMotorPortDoesNotHoldTheStop) {
  const std::string key = WriteKey("wedged.key", "the wedged port test's key", 0600);
  LinkPty board;
  ASSERT_GE(board.master, 0);
  HeldIoctlProcess robotd(
      {SWEEPSCAN_ROBOTD, "--motor", board.slave, "--listen", "127.0.0.1:0", "--key-file", key},
      TCSBRK);
  if (robotd.pid > 0 && robotd.listener < 0 && robotd.error.find("refused") != std::string::npos) {
    GTEST_SKIP() << robotd.error;
  }
  ASSERT_GE(robotd.listener, 0) << robotd.error;
  std::string out, heard;
  ASSERT_TRUE(WaitFor(
      [&] {
        out += robotd.Read();
        ReadAvailable(board.master, &heard);
        return (out.find("listening on") != std::string::npos && heard.size() >= 11) ||
               robotd.Exited();
      },
      20000))
      << out;
  ASSERT_FALSE(robotd.Exited()) << out;
  ASSERT_EQ(::kill(robotd.pid, SIGTERM), 0);
  // Generous (200 ms are asked): a loaded machine, not a bound being measured.
  const bool exited = WaitFor([&] { return robotd.Exited(); }, 10000);
  robotd.ReleaseHeldCalls();  // The old robotd's stop goes on from here.
  WaitFor([&] { return robotd.Exited(); }, 10000);
  out += robotd.Read();
  ReadAvailable(board.master, &heard);
  EXPECT_TRUE(exited) << "the stop hung on the wedged port: " << out;
  ASSERT_TRUE(robotd.Exited()) << out;
  EXPECT_TRUE(WIFEXITED(robotd.status) && WEXITSTATUS(robotd.status) == 0) << out;
  EXPECT_NE(out.find("shutting down: " + board.slave +
                     ": the driver did not finish sending within 200 ms (a wedged adapter?); what "
                     "it held was thrown away"),
            std::string::npos)
      << out;
  // The zero command was handed to the port before the wait.
  MotorCommandDecoder decoder;
  decoder.Feed(std::vector<uint8_t>(heard.begin(), heard.end()), Time());
  const std::vector<MotorCommand> commands = decoder.TakeRecords();
  ASSERT_GE(commands.size(), 2u) << "the zero at the start and at the stop";
  EXPECT_EQ(commands.back().vx_mps, 0.0);
  EXPECT_EQ(commands.back().wz_radps, 0.0);
}

// No SIGTERM pending for `pid` (one of its threads has taken it).
// What the motor board's pty heard: at least one command, and every one a zero.
void ExpectOnlyZeroMotorCommands(int board_master) {
  std::string heard;
  ReadAvailable(board_master, &heard);
  MotorCommandDecoder decoder;
  decoder.Feed(std::vector<uint8_t>(heard.begin(), heard.end()), Time());
  const std::vector<MotorCommand> commands = decoder.TakeRecords();
  ASSERT_FALSE(commands.empty()) << "nothing reached the board (" << heard.size() << " bytes)";
  for (const MotorCommand& c : commands) {
    EXPECT_EQ(c.vx_mps, 0.0);
    EXPECT_EQ(c.wz_radps, 0.0);
  }
}

bool SigtermTaken(pid_t pid) {
  QFile status(QStringLiteral("/proc/%1/status").arg(pid));
  if (!status.open(QIODevice::ReadOnly)) return true;
  for (const QByteArray& line : status.readAll().split('\n')) {
    if (line.startsWith("ShdPnd:") || line.startsWith("SigPnd:")) {
      if ((line.mid(7).trimmed().toULongLong(nullptr, 16) & (1ULL << (SIGTERM - 1))) != 0) {
        return false;
      }
    }
  }
  return true;
}

// A stop while the ports open (a USB adapter's open can take seconds; here
// the motor port's open is held by the kernel until the SIGTERM is in) is
// seen once they are open: the agent's shutdown sends the board its zero
// and closes the ports, exit 0, never "listening on". It was acted on only
// once the event loop ran, after the link was served and READY=1 sent.
TEST(RobotdStartupTest, AStopWhileThePortsOpenStopsTheMotorsAndEndsTheStart) {
  const std::string key = WriteKey("opening.key", "the slow open test's key", 0600);
  LinkPty board;
  ASSERT_GE(board.master, 0);
  HeldIoctlProcess robotd(
      {SWEEPSCAN_ROBOTD, "--motor", board.slave, "--listen", "127.0.0.1:0", "--key-file", key},
      TIOCEXCL);
  if (robotd.pid > 0 && robotd.listener < 0 && robotd.error.find("refused") != std::string::npos) {
    GTEST_SKIP() << robotd.error;
  }
  ASSERT_GE(robotd.listener, 0) << robotd.error;
  std::string out;
  ASSERT_TRUE(WaitFor([&] { return robotd.Holding() || robotd.Exited(); }, 20000));
  ASSERT_FALSE(robotd.Exited()) << robotd.Read();
  ASSERT_EQ(::kill(robotd.pid, SIGTERM), 0);
  ASSERT_TRUE(WaitFor([&] { return SigtermTaken(robotd.pid); }, 10000));
  // The open goes on (the call the signal interrupted is made again).
  ASSERT_TRUE(WaitFor(
      [&] {
        robotd.Continue();
        out += robotd.Read();
        return robotd.Exited();
      },
      20000))
      << out;
  out += robotd.Read();
  EXPECT_TRUE(WIFEXITED(robotd.status) && WEXITSTATUS(robotd.status) == 0) << out;
  EXPECT_NE(out.find("sweepscan-robotd: SIGTERM during start-up: the ports were opened; motors "
                     "stopped, ports closed; exiting"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("listening on"), std::string::npos) << out;
  ExpectOnlyZeroMotorCommands(board.master);
}

// A stop while the second of the three ports opens (the IMU's, held by the
// kernel until the SIGTERM is in) ends the start there: the motor board,
// opened first, gets its zero; the lidar's port is never opened (it would
// have had the X4's stop command, A5 65, at once); exit 0. The stop was
// looked for only after all three opens, however long each took.
TEST(RobotdStartupTest, AStopBetweenThePortsOpensStopsTheMotorsAndOpensNoMore) {
  const std::string key = WriteKey("between.key", "the stop between opens test's key", 0600);
  LinkPty board, imu, lidar;
  ASSERT_GE(board.master, 0);
  ASSERT_GE(imu.master, 0);
  ASSERT_GE(lidar.master, 0);
  HeldIoctlProcess robotd({SWEEPSCAN_ROBOTD, "--motor", board.slave, "--imu", imu.slave, "--lidar",
                           lidar.slave, "--listen", "127.0.0.1:0", "--key-file", key},
                          TIOCEXCL);
  if (robotd.pid > 0 && robotd.listener < 0 && robotd.error.find("refused") != std::string::npos) {
    GTEST_SKIP() << robotd.error;
  }
  ASSERT_GE(robotd.listener, 0) << robotd.error;
  // The first open (TIOCEXCL) goes on; the second is held.
  ASSERT_TRUE(WaitFor([&] { return robotd.Holding() || robotd.Exited(); }, 20000));
  ASSERT_EQ(robotd.Continue(), 1);
  ASSERT_TRUE(WaitFor([&] { return robotd.Holding() || robotd.Exited(); }, 20000));
  ASSERT_FALSE(robotd.Exited()) << robotd.Read();
  ASSERT_EQ(::kill(robotd.pid, SIGTERM), 0);
  ASSERT_TRUE(WaitFor([&] { return SigtermTaken(robotd.pid); }, 10000));
  QElapsedTimer since_released;
  since_released.start();
  int opens_after_the_stop = 0;
  std::string out;
  ASSERT_TRUE(WaitFor(
      [&] {
        opens_after_the_stop += robotd.Continue();
        out += robotd.Read();
        return robotd.Exited();
      },
      20000))
      << out;
  const qint64 exit_ms = since_released.elapsed();
  out += robotd.Read();
  EXPECT_TRUE(WIFEXITED(robotd.status) && WEXITSTATUS(robotd.status) == 0) << out;
  // The IMU's, made again after the signal interrupted it; no third.
  EXPECT_EQ(opens_after_the_stop, 1) << out;
  EXPECT_LT(exit_ms, 5000) << "generous: a loaded machine, not a bound being measured";
  std::printf("exited %lld ms after the second open was let go\n", static_cast<long long>(exit_ms));
  EXPECT_NE(out.find("sweepscan-robotd: SIGTERM during start-up: stopped while the ports were "
                     "opened (the rest not opened); motors stopped, ports closed; exiting"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("stop asked for during start-up: " + lidar.slave + " not opened"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("listening on"), std::string::npos) << out;
  std::string lidar_heard;
  ReadAvailable(lidar.master, &lidar_heard);
  EXPECT_EQ(lidar_heard.size(), 0u) << "the lidar's port was opened after the stop";
  ExpectOnlyZeroMotorCommands(board.master);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
