// Byte streams for the robot link and the device ports, behind one small
// interface so the agent and the workstation do not care whether bytes go
// over a QSerialPort, a QTcpSocket or a pseudo-terminal master:
//
//   ByteStream       bytesReceived(QByteArray) / closed(reason); Write(); Close().
//   SerialStream     QSerialPort (8N1, raw).
//   TcpStream        QTcpSocket (connected, or connecting with ConnectTo()).
//   PtyMasterStream  the master side of an openpty() pair, for sweepscan-sim
//                    --pty: the slave path is a real serial device that the
//                    workstation opens with QSerialPort.
//
// Writes never block: they are queued by Qt (serial, TCP) or written with a
// non-blocking write(2) (pty). What the pty's kernel buffer cannot take of a
// write is queued and sent when it can, up to a bound; beyond it whole
// writes are dropped and counted, as a serial line with nobody listening
// would lose them, but a write begun is finished: a frame is not cut in the
// middle (the link's receiver would count it corrupt), unless the agent
// throws away a queue its reader has not touched for seconds
// (DiscardQueued: the frame at the kernel's end may then be cut).
//
// Threading: every stream lives on the thread that created it (the I/O
// thread) and is used only there; signals are emitted on that thread.
#ifndef SWEEPSCAN_HARDWARE_LINK_QT_TRANSPORT_H_
#define SWEEPSCAN_HARDWARE_LINK_QT_TRANSPORT_H_

#include <QByteArray>
#include <QObject>
#include <QString>
#include <QtGlobal>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

class QSerialPort;
class QSocketNotifier;
class QTcpSocket;

namespace sweepscan {
namespace hardware {

class ByteStream : public QObject {
  Q_OBJECT
 public:
  explicit ByteStream(QObject* parent = nullptr) : QObject(parent) {}
  ~ByteStream() override = default;

  virtual bool IsOpen() const = 0;
  // Queues bytes for sending; returns false when the stream is not open or
  // refused them (the bytes are then lost).
  virtual bool Write(const uint8_t* data, size_t n) = 0;
  bool WriteBytes(const QByteArray& bytes) {
    return Write(reinterpret_cast<const uint8_t*>(bytes.constData()),
                 static_cast<size_t>(bytes.size()));
  }
  // Closes without emitting closed().
  virtual void Close() = 0;
  // "tcp:127.0.0.1:5600", "serial:/dev/ttyUSB0@115200", "pty:/dev/pts/4".
  virtual QString Describe() const = 0;
  uint64_t bytes_dropped() const { return bytes_dropped_; }
  // Bytes written but not yet handed to the kernel (Qt's write buffer); 0
  // for a stream that never queues (the pty, which drops instead).
  virtual qint64 BytesQueued() const { return 0; }
  // Throws away what is queued and not yet sent (a serial line: what the
  // driver still holds too); returns the bytes dropped (counted).
  virtual qint64 DiscardQueued() { return 0; }

 signals:
  void bytesReceived(const QByteArray& bytes);
  // The peer went away or the device failed (not emitted by Close()).
  void closed(const QString& reason);

 protected:
  uint64_t bytes_dropped_ = 0;
};

class SerialStream : public ByteStream {
  Q_OBJECT
 public:
  explicit SerialStream(QObject* parent = nullptr);
  ~SerialStream() override;
  // Opens `port` (e.g. /dev/ttyUSB0) at `baud`, 8N1, no flow control.
  bool Open(const QString& port, qint32 baud, QString* error);
  bool IsOpen() const override;
  bool Write(const uint8_t* data, size_t n) override;
  void Close() override;
  // Blocks until every byte written so far has left the port (at most
  // timeout_ms): QSerialPort only buffers a write, and its event loop sends
  // it, so a port closed without this loses what was last written. The
  // driver's own wait (tcdrain) is bounded too, on a thread of its own: a
  // wedged adapter's never returns. False with *why (if given) when the
  // bytes did not all leave in time; what the driver still held is then
  // thrown away, so that closing the port does not wait for it either.
  // The driver's wait, then, stays on its thread, holding the port open,
  // until the process exits (why: TcdrainWithin in qt_transport.cc): call
  // it before exiting, as the agent's shutdown and --stop-motors do.
  bool Drain(int timeout_ms, QString* why = nullptr);
  qint64 BytesQueued() const override;
  qint64 DiscardQueued() override;
  QString Describe() const override;
  // DTR drives the X4's motor enable on its USB adapter.
  void SetDataTerminalReady(bool on);

 private:
  bool OpenPort(const QString& port, qint32 baud, QString* error);

  QSerialPort* port_;
  QString name_;
  qint32 baud_ = 0;
  // Errors are Open()'s (or a DTR change's) to report, not a lost port.
  bool opening_ = false;
};

class TcpStream : public ByteStream {
  Q_OBJECT
 public:
  // Takes ownership of a socket (connected, or to be connected with ConnectTo()).
  explicit TcpStream(QTcpSocket* socket, QObject* parent = nullptr);
  ~TcpStream() override;
  // Starts connecting; connected() or closed() follows.
  void ConnectTo(const QString& host, quint16 port);
  bool IsOpen() const override;
  bool Write(const uint8_t* data, size_t n) override;
  void Close() override;
  // Drops the connection at once, like a pulled cable, without closed().
  void Abort();
  qint64 BytesQueued() const override;
  QString Describe() const override;
  QString PeerAddress() const;
  QTcpSocket* socket() const { return socket_; }

 signals:
  void connected();

 private:
  QTcpSocket* socket_;
  bool closing_ = false;
};

class PtyMasterStream : public ByteStream {
  Q_OBJECT
 public:
  // `max_queued`: bytes kept for the slave while its reader is behind,
  // beyond the kernel's few KiB. The link (sweepscan-sim --pty) keeps as
  // much as a TCP peer may have queued, and the agent bounds it further as
  // on a serial line; an emulated device keeps none beyond the write it
  // began (a device does not wait for its host: a stalled host loses data,
  // and finds fresh data when it reads again).
  static constexpr qint64 kLinkMaxQueued = 1 << 20;
  explicit PtyMasterStream(QObject* parent = nullptr, qint64 max_queued = kLinkMaxQueued);
  ~PtyMasterStream() override;
  // openpty() with the line in raw mode; SlavePath() is then e.g. /dev/pts/7.
  bool Open(QString* error);
  QString SlavePath() const { return slave_path_; }
  bool IsOpen() const override { return master_fd_ >= 0; }
  bool Write(const uint8_t* data, size_t n) override;
  void Close() override;
  QString Describe() const override { return QStringLiteral("pty:") + slave_path_; }
  qint64 BytesQueued() const override { return pending_.size(); }
  qint64 DiscardQueued() override;

 private:
  void OnReadable();
  // Writes what is pending until the kernel's buffer is full again.
  void Flush();

  int master_fd_ = -1;
  // Kept open on purpose: while the workstation has not opened (or has
  // closed) the slave, the master would otherwise report EIO/hang-up in a
  // busy loop. The workstation going away is then detected by the watchdog.
  int slave_fd_ = -1;
  QString slave_path_;
  QSocketNotifier* notifier_ = nullptr;
  QSocketNotifier* write_notifier_ = nullptr;  // Enabled while pending_ is not empty.
  QByteArray pending_;
  qint64 max_queued_;
};

// Parsed link address: "tcp:HOST:PORT", "HOST:PORT" (TCP), or
// "serial:PATH[@BAUD]" (default 921600 baud; ignored by pseudo-terminals).
struct LinkAddress {
  enum class Kind { kTcp, kSerial };
  Kind kind = Kind::kTcp;
  QString host = QStringLiteral("127.0.0.1");
  quint16 port = 5600;
  QString serial_port;
  qint32 baud = 921600;

  QString ToString() const;
};
bool ParseLinkAddress(const QString& text, LinkAddress* address, QString* error);

// What ReadKeyFile does with a key file its group or others have any
// access to (read, write or execute).
enum class KeyFilePermissions {
  kAny,        // Accept (the workstation's default).
  kWarn,       // Accept, with a warning in *warning (sweepscan-sim).
  kOwnerOnly,  // Refuse a file its group or others have any access to, like ssh (sweepscan-robotd).
};
inline constexpr qint64 kMaxKeyFileBytes = 64 * 1024;

// What a key file's mode lets its group and others do, for ReadKeyFile's
// message: "can be written by its group" (0620), "can be read by its group
// and others" (0644), "can be read and written by its group, and read by
// others" (0664); empty when only the owner has any access. Any group or
// others bit at all is refused by kOwnerOnly, as ssh refuses a private key.
QString KeyFileAccessOfOthers(unsigned mode);

// Reads a pre-shared key file: its bytes exactly, except one trailing line
// end (LF or CR LF), removed so `echo secret > key` works (the rule
// docs/protocol.md gives other clients, "The key"). Empty files, folders
// and files over kMaxKeyFileBytes are refused (never cut).
bool ReadKeyFile(const QString& path, std::vector<uint8_t>* key, QString* error,
                 KeyFilePermissions permissions = KeyFilePermissions::kAny,
                 QString* warning = nullptr);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_LINK_QT_TRANSPORT_H_
