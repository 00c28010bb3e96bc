// The service manager's notification protocol as sweepscan-robotd speaks it
// itself (app/service_notify.h; no libsystemd): one AF_UNIX datagram per
// message to $NOTIFY_SOCKET, a path or an abstract name. The notifier
// against real datagram sockets bound by the test (the exact bytes, the
// addresses it refuses, a failure logged once, a manager that reads
// nothing), and the real robotd started with NOTIFY_SOCKET pointing at a
// socket the test reads: READY=1 once its port takes connections,
// STOPPING=1 on SIGTERM.
#include "app/service_notify.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QDir>
#include <QElapsedTimer>
#include <QFile>
#include <QProcess>
#include <QProcessEnvironment>
#include <QStringList>
#include <QTemporaryDir>
#include <cerrno>
#include <csignal>
#include <cstddef>
#include <cstring>
#include <string>
#include <vector>

#include "tests/testing/qt_wait.h"

namespace sweepscan::app {
namespace {

using sweepscan::testing::WaitFor;

// A datagram socket bound where the service manager's would be: a path, or
// with a leading '@' an abstract name (bound with the name's exact length).
struct ManagerSocket {
  int fd = -1;
  std::string name;  // As NOTIFY_SOCKET says it.
  explicit ManagerSocket(const std::string& at) : name(at) {
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    socklen_t length;
    if (at[0] == '@') {
      std::memcpy(address.sun_path + 1, at.data() + 1, at.size() - 1);
      length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + at.size());
    } else {
      ::unlink(at.c_str());
      std::memcpy(address.sun_path, at.data(), at.size());
      length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + at.size() + 1);
    }
    if (::bind(fd, reinterpret_cast<sockaddr*>(&address), length) != 0) {
      ADD_FAILURE() << "bind " << at << ": " << std::strerror(errno);
      ::close(fd);
      fd = -1;
    }
  }
  ~ManagerSocket() {
    if (fd >= 0) ::close(fd);
    if (name[0] != '@') ::unlink(name.c_str());
  }
  // The next datagram, whole (bytes as sent), or "" after `timeout_ms`.
  std::string Receive(int timeout_ms = 2000) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) != 1) return "";
    char buffer[4096];
    const ssize_t n = ::recv(fd, buffer, sizeof(buffer), MSG_TRUNC);
    if (n < 0) return "";
    EXPECT_LE(n, static_cast<ssize_t>(sizeof(buffer))) << "datagram cut";
    return std::string(buffer, static_cast<size_t>(n));
  }
};

std::string AbstractName(const char* what) {
  return "@sweepscan-notify-test/" + std::to_string(::getpid()) + "/" + what;
}

ServiceNotifier::Environment At(const std::string& socket) {
  ServiceNotifier::Environment e;
  e.notify_socket = QByteArray::fromStdString(socket);
  return e;
}

// Exact bytes, at a path and at an abstract name: READY=1 and its status in
// one datagram, no trailing newline; then STATUS= and STOPPING=1; nothing
// logged. The abstract name is bound with its exact length: a sender that
// counted a NUL after it (or left out the leading one) reaches no socket.
TEST(ServiceNotifyTest, SendsTheExactDatagramsToAPathAndToAnAbstractName) {
  QTemporaryDir dir;
  ASSERT_TRUE(dir.isValid());
  for (const std::string& where : {dir.filePath("notify").toStdString(), AbstractName("exact")}) {
    SCOPED_TRACE(where);
    ManagerSocket manager(where);
    ASSERT_GE(manager.fd, 0);
    QStringList log;
    ServiceNotifier notifier(At(where), [&](const QString& line) { log << line; });
    EXPECT_TRUE(notifier.active());
    notifier.Ready(QStringLiteral("listening on 127.0.0.1:5600"));
    EXPECT_EQ(manager.Receive(), "READY=1\nSTATUS=listening on 127.0.0.1:5600");
    notifier.Status(QStringLiteral("listening on 127.0.0.1:5600, client 127.0.0.1:40000 \u00e9"));
    EXPECT_EQ(manager.Receive(),
              "STATUS=listening on 127.0.0.1:5600, client 127.0.0.1:40000 \xc3\xa9");
    notifier.Stopping();
    EXPECT_EQ(manager.Receive(), "STOPPING=1");
    EXPECT_EQ(manager.Receive(100), "") << "one datagram per message";
    EXPECT_EQ(notifier.watchdog_interval_ms(), 0) << "no WATCHDOG_USEC: no pings";
    EXPECT_TRUE(log.isEmpty()) << log.join('\n').toStdString();
  }
}

// The addresses: a path needs room for its NUL in sun_path (108 bytes), an
// abstract name for the leading NUL; vsock: and relative paths are refused.
TEST(ServiceNotifyTest, ParsesTheAddressesAndRefusesWhatDoesNotFit) {
  NotifyAddress a;
  QString error;
  const size_t base = offsetof(sockaddr_un, sun_path);
  ASSERT_TRUE(ParseNotifySocket("/run/systemd/notify", &a, &error));
  EXPECT_EQ(a.address.sun_family, AF_UNIX);
  EXPECT_STREQ(a.address.sun_path, "/run/systemd/notify");
  EXPECT_EQ(a.length, base + 20);
  ASSERT_TRUE(ParseNotifySocket("@/org/freedesktop/systemd1/notify", &a, &error));
  EXPECT_EQ(a.address.sun_path[0], '\0');
  EXPECT_EQ(std::string(a.address.sun_path + 1, 32), "/org/freedesktop/systemd1/notify");
  EXPECT_EQ(a.length, base + 1 + 32) << "no NUL counted after the name";

  const QByteArray path107 = "/" + QByteArray(106, 'p');
  EXPECT_TRUE(ParseNotifySocket(path107, &a, &error));
  EXPECT_EQ(a.length, base + 108);
  EXPECT_FALSE(ParseNotifySocket(path107 + "p", &a, &error));
  EXPECT_TRUE(error.contains("108 bytes")) << error.toStdString();
  EXPECT_TRUE(error.contains("sun_path")) << error.toStdString();
  EXPECT_TRUE(ParseNotifySocket("@" + QByteArray(107, 'n'), &a, &error));
  EXPECT_EQ(a.length, base + 108);
  EXPECT_FALSE(ParseNotifySocket("@" + QByteArray(108, 'n'), &a, &error));
  EXPECT_TRUE(error.contains("abstract")) << error.toStdString();
  EXPECT_FALSE(ParseNotifySocket("@", &a, &error));
  EXPECT_FALSE(ParseNotifySocket("vsock:2:9999", &a, &error));
  EXPECT_TRUE(error.contains("AF_VSOCK")) << error.toStdString();
  EXPECT_FALSE(ParseNotifySocket("run/notify", &a, &error));
  EXPECT_TRUE(error.contains("absolute")) << error.toStdString();
}

// An address it cannot use is said once, when the notifier is made (at
// robotd's start), and nothing is sent; a path too long for sun_path is not
// cut to one that fits (it could be another socket).
TEST(ServiceNotifyTest, AnAddressItCannotUseIsSaidOnceAndNothingIsSent) {
  QTemporaryDir dir;
  ASSERT_TRUE(dir.isValid());
  // A socket at the first 107 bytes of the long path: a cut path would reach it.
  QString deep = dir.path();
  while (deep.size() < 90) {
    deep += QStringLiteral("/dddddddddd");
    ASSERT_TRUE(QDir().mkpath(deep));
  }
  const std::string fits = (deep + "/" + QString(106 - deep.size(), 's')).toStdString();
  ASSERT_EQ(fits.size(), 107u);
  ManagerSocket manager(fits);
  ASSERT_GE(manager.fd, 0);
  for (const std::string& where : {fits + "s", std::string("vsock:2:9999")}) {
    SCOPED_TRACE(where);
    QStringList log;
    ServiceNotifier notifier(At(where), [&](const QString& line) { log << line; });
    ASSERT_EQ(log.size(), 1);
    EXPECT_TRUE(log[0].startsWith(
        QStringLiteral("warning: NOTIFY_SOCKET=%1 ").arg(QString::fromStdString(where))))
        << log[0].toStdString();
    EXPECT_TRUE(log[0].contains(where[0] == '/' ? "sun_path" : "AF_VSOCK")) << log[0].toStdString();
    EXPECT_TRUE(log[0].contains("READY=1")) << log[0].toStdString();
    EXPECT_FALSE(notifier.active());
    notifier.Ready(QStringLiteral("listening"));
    notifier.Stopping();
    EXPECT_EQ(log.size(), 1) << log.join('\n').toStdString();
    EXPECT_EQ(manager.Receive(100), "");
  }
  // And the path that fits is used as it is.
  QStringList log;
  ServiceNotifier notifier(At(fits), [&](const QString& line) { log << line; });
  notifier.Stopping();
  EXPECT_EQ(manager.Receive(), "STOPPING=1");
  EXPECT_TRUE(log.isEmpty()) << log.join('\n').toStdString();
}

// NOTIFY_SOCKET unset or empty: nothing sent, nothing said.
TEST(ServiceNotifyTest, OutsideAServiceManagerItDoesNothing) {
  QStringList log;
  ServiceNotifier::Environment e;
  e.watchdog_usec = "1000000";
  ServiceNotifier notifier(e, [&](const QString& line) { log << line; });
  EXPECT_FALSE(notifier.active());
  EXPECT_FALSE(notifier.Send("READY=1"));
  notifier.Ready(QStringLiteral("listening"));
  EXPECT_TRUE(log.isEmpty());
}

// A failed send (no socket there, or the manager gone) is logged once, with
// what and why, and is not fatal; the next ones are not logged.
TEST(ServiceNotifyTest, AFailedSendIsLoggedOnce) {
  QTemporaryDir dir;
  ASSERT_TRUE(dir.isValid());
  const std::string nowhere = dir.filePath("nobody-here").toStdString();
  QStringList log;
  ServiceNotifier notifier(At(nowhere), [&](const QString& line) { log << line; });
  EXPECT_TRUE(notifier.active()) << "the address is good; no socket there yet";
  notifier.Ready(QStringLiteral("listening"));
  ASSERT_EQ(log.size(), 1);
  EXPECT_EQ(log[0].toStdString(),
            "warning: service notification READY=1 to NOTIFY_SOCKET=" + nowhere +
                " not sent (connect: No such file or directory); running on; further "
                "failures are not logged");
  notifier.Status(QStringLiteral("listening, no client"));
  notifier.Stopping();
  EXPECT_EQ(log.size(), 1);
  // The manager's socket appears: sending works again, still quietly.
  ManagerSocket manager(nowhere);
  ASSERT_GE(manager.fd, 0);
  EXPECT_TRUE(notifier.Send("STATUS=back"));
  EXPECT_EQ(manager.Receive(), "STATUS=back");
  EXPECT_EQ(log.size(), 1);
}

// A manager that reads nothing does not hold the event loop: once its queue
// is full, STATUS= and WATCHDOG=1 are dropped at once and STOPPING=1 waits
// 1 s at most; the first drop is logged, once.
TEST(ServiceNotifyTest, AManagerThatReadsNothingDoesNotHoldTheSender) {
  ManagerSocket manager(AbstractName("full"));
  ASSERT_GE(manager.fd, 0);
  QStringList log;
  ServiceNotifier notifier(At(manager.name), [&](const QString& line) { log << line; });
  QElapsedTimer clock;
  clock.start();
  int sent = 0;
  for (int i = 0; i < 5000; ++i) sent += notifier.Send("WATCHDOG=1") ? 1 : 0;
  EXPECT_LT(sent, 5000) << "the queue never filled";
  EXPECT_GT(sent, 0);
  EXPECT_LT(clock.elapsed(), 3000) << "the pings waited for room";
  ASSERT_EQ(log.size(), 1);
  EXPECT_TRUE(log[0].contains("WATCHDOG=1")) << log[0].toStdString();
  EXPECT_TRUE(log[0].contains("send: Resource temporarily unavailable")) << log[0].toStdString();
  clock.restart();
  notifier.Stopping();
  EXPECT_GE(clock.elapsed(), 900) << "STOPPING=1 waits for room, for a while";
  EXPECT_LT(clock.elapsed(), 2500);
  EXPECT_EQ(log.size(), 1);
  // Room again: the first queued datagram read, the next send goes out.
  EXPECT_EQ(manager.Receive(), "WATCHDOG=1");
  EXPECT_TRUE(notifier.Send("STOPPING=1", 1000));
}

// WATCHDOG_USEC: pings at half of it, from the event loop, once ready;
// none when WATCHDOG_PID names another process; a bad value is said.
TEST(ServiceNotifyTest, WatchdogPingsAtHalfWatchdogUsecForThisProcessOnly) {
  ManagerSocket manager(AbstractName("watchdog"));
  ASSERT_GE(manager.fd, 0);
  QStringList log;
  const auto logger = [&](const QString& line) { log << line; };
  ServiceNotifier::Environment e = At(manager.name);
  e.watchdog_usec = "300000";
  e.watchdog_pid = QByteArray::number(static_cast<qint64>(::getpid()));
  {
    ServiceNotifier notifier(e, logger);
    EXPECT_EQ(notifier.watchdog_interval_ms(), 150);
    sweepscan::testing::Pump(400);
    EXPECT_EQ(manager.Receive(50), "") << "no pings before READY=1";
    notifier.Ready(QStringLiteral("listening"));
    EXPECT_EQ(manager.Receive(), "READY=1\nSTATUS=listening");
    std::vector<std::string> pings;
    ASSERT_TRUE(WaitFor(
        [&] {
          const std::string m = manager.Receive(0);
          if (!m.empty()) pings.push_back(m);
          return pings.size() >= 3;
        },
        5000));
    for (const std::string& p : pings) EXPECT_EQ(p, "WATCHDOG=1");
    notifier.Stopping();
    EXPECT_EQ(manager.Receive(), "STOPPING=1");
    sweepscan::testing::Pump(400);
    EXPECT_EQ(manager.Receive(50), "") << "no pings after STOPPING=1";
  }
  e.watchdog_pid = QByteArray::number(static_cast<qint64>(::getpid()) + 1);
  EXPECT_EQ(ServiceNotifier(e, logger).watchdog_interval_ms(), 0) << "another process's";
  e.watchdog_pid.clear();
  e.watchdog_usec = "1000000";
  EXPECT_EQ(ServiceNotifier(e, logger).watchdog_interval_ms(), 500);
  EXPECT_TRUE(log.isEmpty()) << log.join('\n').toStdString();
  e.watchdog_usec = "1s";
  EXPECT_EQ(ServiceNotifier(e, logger).watchdog_interval_ms(), 0);
  ASSERT_EQ(log.size(), 1);
  EXPECT_TRUE(log[0].contains("WATCHDOG_USEC=1s")) << log[0].toStdString();
}

// --- The real sweepscan-robotd --------------------------------------------

// SWEEPSCAN_TEST_ROBOTD runs these against another build (an older one).
QString RobotdProgram() {
  return qEnvironmentVariableIsSet("SWEEPSCAN_TEST_ROBOTD")
             ? qEnvironmentVariable("SWEEPSCAN_TEST_ROBOTD")
             : QStringLiteral(SWEEPSCAN_ROBOTD);
}

// True if a TCP connection to 127.0.0.1:port is taken at once (one try).
bool Connects(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  ::close(fd);
  return ok;
}

class RobotdNotifyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(dir_.isValid());
    key_ = dir_.filePath("robotd.key");
    QFile f(key_);
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("the notify test's key");
    f.close();
    ASSERT_EQ(::chmod(qPrintable(key_), 0600), 0);
  }
  void Start(QProcess* robotd, const std::string& notify_socket) {
    QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
    env.remove("WATCHDOG_USEC");
    env.remove("WATCHDOG_PID");
    env.insert("NOTIFY_SOCKET", QString::fromStdString(notify_socket));
    robotd->setProcessEnvironment(env);
    // No devices to speak of: an IMU port that is not there (retried).
    robotd->start(RobotdProgram(),
                  {"--imu", "/nonexistent/tty", "--listen", "127.0.0.1:0", "--key-file", key_});
  }
  QTemporaryDir dir_;
  QString key_;
};

// As systemd's Type=notify unit waits for it: READY=1 (with the STATUS= of
// the port) comes once the port takes connections, the first datagram;
// SIGTERM brings STOPPING=1, the last, and exit 0. At a path and at an
// abstract name (systemd's user manager and containers use those).
TEST_F(RobotdNotifyTest, ReadyOnceListeningAndStoppingOnSigterm) {
  for (const std::string& where : {dir_.filePath("notify").toStdString(), AbstractName("robotd")}) {
    SCOPED_TRACE(where);
    ManagerSocket manager(where);
    ASSERT_GE(manager.fd, 0);
    QProcess robotd;
    Start(&robotd, where);
    std::string ready;
    ASSERT_TRUE(WaitFor(
        [&] {
          ready = manager.Receive(0);
          return !ready.empty() || robotd.state() == QProcess::NotRunning;
        },
        30000))
        << "no READY=1: " << robotd.readAllStandardError().toStdString();
    ASSERT_FALSE(ready.empty()) << "robotd exited: " << robotd.readAllStandardError().toStdString();
    const std::string prefix = "READY=1\nSTATUS=listening on 127.0.0.1:";
    ASSERT_EQ(ready.rfind(prefix, 0), 0u) << ready;
    const int port = std::stoi(ready.substr(prefix.size()));
    ASSERT_GT(port, 0) << ready;
    EXPECT_EQ(ready, prefix + std::to_string(port)) << "one datagram, no trailing newline";
    EXPECT_TRUE(Connects(port)) << "READY=1 before port " << port << " took connections";

    ASSERT_EQ(::kill(static_cast<pid_t>(robotd.processId()), SIGTERM), 0);
    ASSERT_TRUE(robotd.waitForFinished(20000));
    const std::string err = robotd.readAllStandardError().toStdString();
    EXPECT_EQ(robotd.exitStatus(), QProcess::NormalExit) << err;
    EXPECT_EQ(robotd.exitCode(), 0) << err;
    std::vector<std::string> after;
    for (std::string m; !(m = manager.Receive(200)).empty();) after.push_back(m);
    ASSERT_FALSE(after.empty()) << "nothing after READY=1: " << err;
    EXPECT_EQ(after.back(), "STOPPING=1") << err;
    for (size_t i = 0; i + 1 < after.size(); ++i) {
      EXPECT_EQ(after[i].rfind("STATUS=", 0), 0u) << "between READY=1 and STOPPING=1: " << after[i];
    }
    EXPECT_EQ(err.find("NOTIFY_SOCKET"), std::string::npos) << "nothing to say: " << err;
  }
}

// An address robotd cannot use (vsock:, which newer systemd may hand a
// service in a VM) is said in its log at start-up, and it runs as usual.
TEST_F(RobotdNotifyTest, AnAddressItCannotUseIsSaidAndItRunsOn) {
  QProcess robotd;
  Start(&robotd, "vsock:2:9999");
  QByteArray out;
  ASSERT_TRUE(WaitFor(
      [&] {
        out += robotd.readAllStandardOutput();
        return out.contains("listening on") || robotd.state() == QProcess::NotRunning;
      },
      30000));
  ASSERT_TRUE(out.contains("listening on 127.0.0.1:"))
      << robotd.readAllStandardError().toStdString();
  ASSERT_EQ(::kill(static_cast<pid_t>(robotd.processId()), SIGTERM), 0);
  ASSERT_TRUE(robotd.waitForFinished(20000));
  const std::string err = robotd.readAllStandardError().toStdString();
  EXPECT_EQ(robotd.exitCode(), 0) << err;
  EXPECT_NE(
      err.find("sweepscan-robotd: warning: NOTIFY_SOCKET=vsock:2:9999 is an AF_VSOCK address"),
      std::string::npos)
      << err;
}

}  // namespace
}  // namespace sweepscan::app

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
