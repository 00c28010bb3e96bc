// Byte streams over a real pseudo-terminal and loopback TCP, link address
// parsing, key files, and direct device mode (an X4 / HI219 on a serial
// port, here the slave of a pty whose master plays the device).
#include "hardware/link/qt_transport.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QFile>
#include <QTcpServer>
#include <QTcpSocket>
#include <QTemporaryDir>
#include <cstring>
#include <functional>
#include <vector>

#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/station/direct_device.h"
#include "tests/testing/qt_wait.h"

namespace sweepscan {
namespace hardware {
namespace {

using testing::WaitFor;

TEST(LinkAddressTest, Parses) {
  LinkAddress a;
  QString error;
  ASSERT_TRUE(ParseLinkAddress("tcp:127.0.0.1:5600", &a, &error));
  EXPECT_EQ(a.kind, LinkAddress::Kind::kTcp);
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 5600);
  ASSERT_TRUE(ParseLinkAddress("10.0.0.2:7000", &a, &error));
  EXPECT_EQ(a.port, 7000);
  ASSERT_TRUE(ParseLinkAddress("[::1]:7000", &a, &error));
  EXPECT_EQ(a.host, "::1");
  ASSERT_TRUE(ParseLinkAddress("serial:/dev/ttyUSB0@115200", &a, &error));
  EXPECT_EQ(a.kind, LinkAddress::Kind::kSerial);
  EXPECT_EQ(a.serial_port, "/dev/ttyUSB0");
  EXPECT_EQ(a.baud, 115200);
  ASSERT_TRUE(ParseLinkAddress("serial:/dev/pts/3", &a, &error));
  EXPECT_EQ(a.baud, 921600);
  EXPECT_FALSE(ParseLinkAddress("nonsense", &a, &error));
  EXPECT_FALSE(error.isEmpty());
  EXPECT_FALSE(ParseLinkAddress("host:99999", &a, &error));
  EXPECT_FALSE(ParseLinkAddress("serial:/dev/x@fast", &a, &error));
}

TEST(KeyFileTest, StripsOneTrailingNewlineAndRefusesEmpty) {
  QTemporaryDir tmp;
  const QString path = tmp.path() + "/key";
  QFile f(path);
  ASSERT_TRUE(f.open(QIODevice::WriteOnly));
  f.write("secret\n");
  f.close();
  std::vector<uint8_t> key;
  QString error;
  ASSERT_TRUE(ReadKeyFile(path, &key, &error));
  EXPECT_EQ(std::string(key.begin(), key.end()), "secret");
  ASSERT_TRUE(f.open(QIODevice::WriteOnly | QIODevice::Truncate));
  f.write("\n");
  f.close();
  EXPECT_FALSE(ReadKeyFile(path, &key, &error));
  EXPECT_FALSE(ReadKeyFile(tmp.path() + "/missing", &key, &error));
  EXPECT_TRUE(error.contains("missing"));
}

// The rule docs/protocol.md gives third-party clients ("The key"): the key
// file's bytes exactly, except one trailing line end, LF or CR LF. A lone
// trailing CR is a key byte: it was dropped, so the package's 32 random
// bytes lost their last one whenever it was 0x0D, and a client that
// followed the rule (or the docs' "raw bytes") was refused.
TEST(KeyFileTest, TheKeyIsTheFilesBytesExceptOneTrailingLineEnd) {
  QTemporaryDir tmp;
  const QString path = tmp.path() + "/key";
  const auto key_of = [&](const QByteArray& bytes) {
    QFile f(path);
    EXPECT_TRUE(f.open(QIODevice::WriteOnly | QIODevice::Truncate));
    f.write(bytes);
    f.close();
    std::vector<uint8_t> key;
    QString error;
    EXPECT_TRUE(ReadKeyFile(path, &key, &error)) << error.toStdString();
    return QByteArray(reinterpret_cast<const char*>(key.data()), static_cast<int>(key.size()));
  };
  EXPECT_EQ(key_of("secret\n"), "secret");
  EXPECT_EQ(key_of("secret\r\n"), "secret");
  EXPECT_EQ(key_of("secret\n\n"), "secret\n") << "one line end only";
  EXPECT_EQ(key_of("secret"), "secret");
  EXPECT_EQ(key_of(" secret \t\n"), " secret \t") << "nothing trimmed";
  EXPECT_EQ(key_of("secret\r"), "secret\r") << "a lone CR is a key byte";
  EXPECT_EQ(key_of("secret\n\r"), "secret\n\r");
  QByteArray random(32, '\0');
  for (int i = 0; i < 32; ++i) random[i] = static_cast<char>(i * 37 + 13);
  random[31] = '\r';
  EXPECT_EQ(key_of(random), random) << "32 binary bytes ending in 0x0D are the key";
  random[31] = '\n';
  EXPECT_EQ(key_of(random), random.left(31)) << "and ending in 0x0A, 31 of them";
}

TEST(PtyStreamTest, BinaryBytesBothWaysThroughQSerialPort) {
  PtyMasterStream master;
  QString error;
  ASSERT_TRUE(master.Open(&error)) << error.toStdString();
  ASSERT_TRUE(master.SlavePath().startsWith("/dev/"));
  SerialStream slave;
  ASSERT_TRUE(slave.Open(master.SlavePath(), 921600, &error)) << error.toStdString();
  QByteArray at_master, at_slave;
  QObject::connect(&master, &ByteStream::bytesReceived,
                   [&](const QByteArray& b) { at_master += b; });
  QObject::connect(&slave, &ByteStream::bytesReceived, [&](const QByteArray& b) { at_slave += b; });
  QByteArray all;  // Every byte value, including ^C, ^S, CR, LF, 0x7F, 0xFF.
  for (int i = 0; i < 256; ++i) all.append(static_cast<char>(i));
  all += all;
  ASSERT_TRUE(master.WriteBytes(all));
  ASSERT_TRUE(slave.WriteBytes(all));
  ASSERT_TRUE(WaitFor(
      [&] { return at_master.size() >= all.size() && at_slave.size() >= all.size(); }, 5000));
  EXPECT_EQ(at_master, all);
  EXPECT_EQ(at_slave, all);
}

TEST(PtyStreamTest, WritesNeverBlockWhenNobodyReads) {
  PtyMasterStream master;
  QString error;
  ASSERT_TRUE(master.Open(&error));
  const QByteArray chunk(64 * 1024, 'x');
  QElapsedTimer timer;
  timer.start();
  for (int i = 0; i < 64; ++i) master.WriteBytes(chunk);  // 4 MiB into a few-KiB buffer.
  EXPECT_LT(timer.elapsed(), 2000);
  EXPECT_GT(master.bytes_dropped(), 0u);
}

// A reader that falls behind loses whole writes, never a part of one: the
// simulator's --pty link used to drop what the kernel would not take in
// the middle of a frame, which the workstation then counted as corrupt.
// The link's stream keeps the rest queued (BytesQueued, as a serial port
// does) and sends it when the reader catches up; a device's keeps nothing
// beyond the write it began. Each 1000-byte write is a "frame": its index
// then 996 copies of the index's low byte; the reader must see only whole
// frames, in order, and every frame not seen must be counted as dropped.
TEST(PtyStreamTest, AReaderBehindLosesWholeWritesNeverPartOfOne) {
  for (const qint64 max_queued : {qint64{0}, PtyMasterStream::kLinkMaxQueued}) {
    SCOPED_TRACE(max_queued);
    PtyMasterStream master(nullptr, max_queued);
    QString error;
    ASSERT_TRUE(master.Open(&error)) << error.toStdString();
    const int reader = ::open(QFile::encodeName(master.SlavePath()).constData(),
                              O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(reader, 0);
    constexpr int kFrames = 600;  // 600 kB: past the kernel's buffer, within the link's bound.
    constexpr int kFrameBytes = 1000;
    int accepted = 0;
    for (int i = 0; i < kFrames; ++i) {
      std::vector<uint8_t> frame(kFrameBytes, static_cast<uint8_t>(i));
      std::memcpy(frame.data(), &i, sizeof(i));
      if (master.Write(frame.data(), frame.size())) ++accepted;
    }
    if (max_queued == 0) {
      EXPECT_LE(master.BytesQueued(), kFrameBytes) << "a device keeps at most the write it began";
      EXPECT_LT(accepted, kFrames);
    } else {
      EXPECT_EQ(accepted, kFrames) << "the link's bound is 1 MiB";
      EXPECT_GT(master.BytesQueued(), 0);
    }
    EXPECT_EQ(master.bytes_dropped(), static_cast<uint64_t>(kFrames - accepted) * kFrameBytes);
    // The reader catches up; the event loop sends what was queued.
    std::vector<uint8_t> got;
    ASSERT_TRUE(WaitFor(
        [&] {
          uint8_t buffer[65536];
          ssize_t n;
          while ((n = ::read(reader, buffer, sizeof(buffer))) > 0)
            got.insert(got.end(), buffer, buffer + n);
          return got.size() >= static_cast<size_t>(accepted) * kFrameBytes &&
                 master.BytesQueued() == 0;
        },
        10000))
        << got.size() << " bytes read of " << accepted * kFrameBytes;
    ::close(reader);
    ASSERT_EQ(got.size(), static_cast<size_t>(accepted) * kFrameBytes);
    int last = -1;
    for (size_t at = 0; at < got.size(); at += kFrameBytes) {
      int index = 0;
      std::memcpy(&index, got.data() + at, sizeof(index));
      ASSERT_GT(index, last) << "frames out of order at byte " << at;
      ASSERT_LT(index, kFrames) << "not a frame's start at byte " << at;
      for (int k = sizeof(index); k < kFrameBytes; ++k) {
        ASSERT_EQ(got[at + static_cast<size_t>(k)], static_cast<uint8_t>(index))
            << "frame " << index << " cut at its byte " << k;
      }
      last = index;
    }
  }
}

TEST(TcpStreamTest, ConnectsSendsAndReportsClose) {
  QTcpServer server;
  ASSERT_TRUE(server.listen(QHostAddress::LocalHost, 0));
  TcpStream client(new QTcpSocket());
  bool connected = false;
  QString closed_reason;
  QObject::connect(&client, &TcpStream::connected, [&] { connected = true; });
  QObject::connect(&client, &ByteStream::closed, [&](const QString& r) { closed_reason = r; });
  client.ConnectTo("127.0.0.1", server.serverPort());
  ASSERT_TRUE(WaitFor([&] { return connected && server.hasPendingConnections(); }, 5000));
  TcpStream accepted(server.nextPendingConnection());
  QByteArray got;
  QObject::connect(&accepted, &ByteStream::bytesReceived, [&](const QByteArray& b) { got += b; });
  ASSERT_TRUE(client.WriteBytes(QByteArray("hello")));
  ASSERT_TRUE(WaitFor([&] { return got == "hello"; }, 5000));
  accepted.Close();
  ASSERT_TRUE(WaitFor([&] { return !closed_reason.isEmpty(); }, 5000));
  EXPECT_FALSE(client.IsOpen());
}

TEST(TcpStreamTest, RefusedConnectionIsReported) {
  QTcpServer server;
  ASSERT_TRUE(server.listen(QHostAddress::LocalHost, 0));
  const quint16 port = server.serverPort();
  server.close();
  TcpStream client(new QTcpSocket());
  QString closed_reason;
  QObject::connect(&client, &ByteStream::closed, [&](const QString& r) { closed_reason = r; });
  client.ConnectTo("127.0.0.1", port);
  EXPECT_TRUE(WaitFor([&] { return !closed_reason.isEmpty(); }, 5000));
}

// An X4 on the bench: the pty master answers like the device.
TEST(DirectDeviceTest, X4DeviceInfoHealthAndScans) {
  PtyMasterStream device;
  QString error;
  ASSERT_TRUE(device.Open(&error));
  QByteArray commands;
  QObject::connect(&device, &ByteStream::bytesReceived,
                   [&](const QByteArray& b) { commands += b; });
  DirectDevice bench(DirectDevice::Kind::kX4, device.SlavePath());
  ASSERT_TRUE(bench.Open(&error)) << error.toStdString();
  bool got_info = false, got_health = false;
  QObject::connect(&bench, &DirectDevice::deviceInfoReceived, [&] { got_info = true; });
  QObject::connect(&bench, &DirectDevice::healthReceived, [&] { got_health = true; });
  ASSERT_TRUE(bench.RequestDeviceInfo());
  ASSERT_TRUE(bench.RequestHealth());
  ASSERT_TRUE(bench.StartScan());
  ASSERT_TRUE(WaitFor([&] { return commands.size() >= 6; }, 5000));
  EXPECT_EQ(commands.left(6), QByteArray("\xA5\x90\xA5\x92\xA5\x60", 6));

  X4DeviceInfo info;
  info.model = 6;
  info.firmware = 0x0108;
  info.hardware = 1;
  X4Health health;
  std::vector<uint8_t> reply = EncodeX4DeviceInfo(info);
  const auto h = EncodeX4Health(health);
  reply.insert(reply.end(), h.begin(), h.end());
  const auto start = EncodeX4ScanStartHeader();
  reply.insert(reply.end(), start.begin(), start.end());
  // Three revolutions: a ring-start packet, then ordinary packets.
  for (int rev = 0; rev < 3; ++rev) {
    X4PacketToEncode ring;
    ring.ring_start = true;
    ring.first_angle_deg = 0.0;
    ring.last_angle_deg = 0.0;
    ring.distances_mm = {1000.0};
    EncodeX4ScanPacket(ring, &reply);
    for (int p = 0; p < 9; ++p) {
      X4PacketToEncode packet;
      packet.first_angle_deg = 1.0 + 36.0 * p;
      packet.last_angle_deg = 35.0 + 36.0 * p;
      packet.distances_mm.assign(40, 1500.0);
      EncodeX4ScanPacket(packet, &reply);
    }
  }
  ASSERT_TRUE(device.Write(reply.data(), reply.size()));
  ASSERT_TRUE(WaitFor([&] { return got_info && got_health && bench.scans_received() >= 2; }, 5000));
  EXPECT_EQ(bench.device_info().model, 6);
  EXPECT_EQ(bench.device_info().firmware, 0x0108);
  EXPECT_EQ(bench.health().status, 0);
  const auto scans = bench.TakeScans();
  ASSERT_GE(scans.size(), 2u);
  EXPECT_EQ(scans[0].samples.size(), 1u + 9u * 40u);
  EXPECT_EQ(bench.stats().checksum_errors, 0u);
  bench.Close();
}

TEST(DirectDeviceTest, Hi219LiveSamples) {
  PtyMasterStream device;
  QString error;
  ASSERT_TRUE(device.Open(&error));
  DirectDevice bench(DirectDevice::Kind::kHi219, device.SlavePath());
  ASSERT_TRUE(bench.Open(&error)) << error.toStdString();
  std::vector<uint8_t> bytes;
  for (int i = 0; i < 20; ++i) {
    ImuSample sample;
    sample.yaw_deg = static_cast<float>(i);
    sample.gyro_dps = {0.f, 0.f, 10.f};
    sample.fields = kImuGyro | kImuEuler;
    const auto frame = EncodeHi219Packet91Frame(sample);
    bytes.insert(bytes.end(), frame.begin(), frame.end());
    bytes.push_back(0x00);  // Garbage between frames is skipped.
  }
  ASSERT_TRUE(device.Write(bytes.data(), bytes.size()));
  ASSERT_TRUE(WaitFor([&] { return bench.imu_samples_received() >= 20; }, 5000));
  const auto samples = bench.TakeImuSamples();
  ASSERT_EQ(samples.size(), 20u);
  EXPECT_FLOAT_EQ(samples[19].yaw_deg, 19.f);
  EXPECT_FALSE(bench.StartScan());  // No X4 commands to an IMU.
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
