#include "hardware/link/qt_transport.h"

#include <errno.h>
#include <fcntl.h>
#include <pty.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <QElapsedTimer>
#include <QFile>
#include <QHostAddress>
#include <QSerialPort>
#include <QSocketNotifier>
#include <QStringList>
#include <QTcpSocket>
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace sweepscan {
namespace hardware {

// ---------------------------------------------------------------------------
// SerialStream

SerialStream::SerialStream(QObject* parent) : ByteStream(parent), port_(new QSerialPort(this)) {
  connect(port_, &QSerialPort::readyRead, this, [this] { emit bytesReceived(port_->readAll()); });
  connect(port_, &QSerialPort::errorOccurred, this, [this](QSerialPort::SerialPortError error) {
    // Anything that makes the port unusable closes the stream, so its owner
    // notices and opens it again. An unplugged USB adapter, or a pty whose
    // master closed, is hung up: read() returns 0 with nothing to read, which
    // Qt reports as a ReadError (a ResourceError only if the errno an earlier
    // call left over says so) and leaves the read notifier armed: the event
    // loop spun a core on it with the port still "open", and nothing
    // reopened it. Write errors and unknown ones are taken as fatal too (a
    // port that recovers is simply reopened). Timeouts are not errors for
    // a non-blocking reader; an operation a device does not support (DTR on
    // a pty) and the settings errors of Open() leave the port usable.
    switch (error) {
      case QSerialPort::ResourceError:
      case QSerialPort::PermissionError:
      case QSerialPort::DeviceNotFoundError:
      case QSerialPort::ReadError:
      case QSerialPort::WriteError:
      case QSerialPort::UnknownError:
        break;
      default:
        return;
    }
    // A failed Open() reports through its return value.
    if (opening_ || !port_->isOpen()) return;
    // A hung-up port's ReadError carries whatever errno was left over.
    const QString reason = error == QSerialPort::ReadError
                               ? QStringLiteral("the device hung up (unplugged?)")
                               : port_->errorString();
    port_->close();
    emit closed(reason);
  });
}

SerialStream::~SerialStream() { Close(); }

namespace {
// Unix98 pseudo-terminal slaves (/dev/pts/N, or a symlink to one) have the
// major numbers 136..143 (Documentation/admin-guide/devices.txt).
bool IsPseudoTerminal(const QString& port) {
  struct stat st;
  if (::stat(QFile::encodeName(port).constData(), &st) != 0 || !S_ISCHR(st.st_mode)) return false;
  const unsigned major_number = major(st.st_rdev);
  return major_number >= 136 && major_number <= 143;
}
}  // namespace

bool SerialStream::Open(const QString& port, qint32 baud, QString* error) {
  name_ = port;
  baud_ = baud;
  opening_ = true;
  const bool opened = OpenPort(port, baud, error);
  opening_ = false;
  return opened;
}

bool SerialStream::OpenPort(const QString& port, qint32 baud, QString* error) {
  port_->setPortName(port);
  if (!port_->open(QIODevice::ReadWrite)) {
    if (error != nullptr) *error = QStringLiteral("%1: %2").arg(port, port_->errorString());
    return false;
  }
  // A pseudo-terminal has no line rate, and a real adapter refuses odd ones.
  // Setting the X4's 128000 (not a POSIX rate) needs termios2 (TCSETS2),
  // which some layers between us and a pty do not pass (qemu-user 7.2, which
  // runs the arm64 build here): on a pty, a rate that cannot be set is moot.
  if (!port_->setBaudRate(baud) && !IsPseudoTerminal(port)) {
    if (error != nullptr) {
      *error = QStringLiteral("%1: cannot set %2 baud: %3").arg(port).arg(baud).arg(port_->errorString());
    }
    port_->close();
    return false;
  }
  if (!port_->setDataBits(QSerialPort::Data8) ||
      !port_->setParity(QSerialPort::NoParity) || !port_->setStopBits(QSerialPort::OneStop) ||
      !port_->setFlowControl(QSerialPort::NoFlowControl)) {
    if (error != nullptr) {
      *error =
          QStringLiteral("%1: cannot set %2 8N1: %3").arg(port).arg(baud).arg(port_->errorString());
    }
    port_->close();
    return false;
  }
  port_->clear();  // Stale bytes from before we opened are not ours to decode.
  return true;
}

bool SerialStream::IsOpen() const { return port_->isOpen(); }

bool SerialStream::Write(const uint8_t* data, size_t n) {
  if (!port_->isOpen()) {
    bytes_dropped_ += n;
    return false;
  }
  const qint64 written = port_->write(reinterpret_cast<const char*>(data), static_cast<qint64>(n));
  if (written != static_cast<qint64>(n)) {
    bytes_dropped_ += n - static_cast<size_t>(written < 0 ? 0 : written);
    return false;
  }
  return true;
}

void SerialStream::Close() {
  if (!port_->isOpen()) return;
  // QSerialPort sends from its event loop: bytes still queued when the port
  // closes are lost, and a closing program's event loop has ended (the
  // recorder's last Stop and lidar-off were). They go to the driver first,
  // which sends them as the port closes; bounded, for an adapter that no
  // longer takes data (115 200 baud moves the few messages in ~1 ms).
  constexpr int kCloseFlushMs = 250;
  QElapsedTimer clock;
  clock.start();
  while (port_->bytesToWrite() > 0) {
    const qint64 left = kCloseFlushMs - clock.elapsed();
    if (left <= 0 || !port_->waitForBytesWritten(static_cast<int>(left))) break;
  }
  port_->close();
}

namespace {

// tcdrain(3) on `fd`, waited for at most `timeout_ms`: 0 when it is done,
// ETIMEDOUT when the time ran out, else tcdrain's errno. A wedged USB-serial
// adapter (or its driver) may never finish sending, and tcdrain has no
// timeout of its own: it runs on a thread of its own, on a duplicate of the
// descriptor that the thread closes, so the caller can leave it behind
// (it ends when the call returns, or with the process). On time-out what the
// driver still holds is thrown away (TCOFLUSH), which also wakes a tcdrain
// waiting for a UART's queue and spares close() its wait for the same bytes
// (up to 30 s for a serial port's closing_wait).
//
// A thread left behind stays until the process exits; it is not ended on
// purpose. Closing the caller's descriptor does not wake it (the call holds
// the open file), and TCOFLUSH need not: a USB-serial adapter that stopped
// taking data keeps its write in flight, which a flush does not reclaim on
// every driver (nor does it reach the call the tests hold in a seccomp
// listener). pthread_cancel would end it (tcdrain is a cancellation point,
// its wait interruptible), but the thread's duplicate is what keeps the
// port open after close(): with it gone, that close() is the port's last
// and the kernel waits there, up to closing_wait (30 s), for the very bytes
// the bound gave up on; keeping the duplicate instead leaks the open port.
// Drain's callers (the agent's shutdown, --stop-motors) exit right after it.
int TcdrainWithin(int fd, int timeout_ms) {
  struct State {
    std::mutex mutex;
    std::condition_variable done_changed;
    bool done = false;
    int error = 0;
  };
  auto state = std::make_shared<State>();
  const int copy = ::fcntl(fd, F_DUPFD_CLOEXEC, 0);
  if (copy < 0) return errno;
  std::thread([state, copy] {
    const int error = ::tcdrain(copy) == 0 ? 0 : errno;
    ::close(copy);
    const std::lock_guard<std::mutex> lock(state->mutex);
    state->done = true;
    state->error = error;
    state->done_changed.notify_all();
  }).detach();
  std::unique_lock<std::mutex> lock(state->mutex);
  if (state->done_changed.wait_for(lock, std::chrono::milliseconds(std::max(timeout_ms, 0)),
                                   [&] { return state->done; })) {
    return state->error;
  }
  lock.unlock();
  ::tcflush(fd, TCOFLUSH);
  return ETIMEDOUT;
}

}  // namespace

bool SerialStream::Drain(int timeout_ms, QString* why) {
  if (!port_->isOpen()) {
    if (why != nullptr) *why = QStringLiteral("%1 is not open").arg(name_);
    return false;
  }
  QElapsedTimer clock;
  clock.start();
  while (port_->bytesToWrite() > 0) {
    const qint64 left = timeout_ms - clock.elapsed();
    if (left <= 0 || !port_->waitForBytesWritten(static_cast<int>(left))) break;
  }
  if (port_->bytesToWrite() > 0) {
    if (why != nullptr) {
      *why = QStringLiteral("%1: %2 bytes not taken by the port within %3 ms")
                 .arg(name_)
                 .arg(port_->bytesToWrite())
                 .arg(timeout_ms);
    }
    return false;
  }
  // Written to the driver is not yet sent: wait for the UART too, within
  // what is left of the bound (a short minimum, for a pty's or a healthy
  // port's immediate answer when the wait above took it all).
  const int left = std::max<int>(static_cast<int>(timeout_ms - clock.elapsed()), 50);
  const int error = TcdrainWithin(static_cast<int>(port_->handle()), left);
  if (error == 0) return true;
  if (why != nullptr) {
    *why = error == ETIMEDOUT ? QStringLiteral(
                                    "%1: the driver did not finish sending within %2 ms (a wedged "
                                    "adapter?); what it held was thrown away")
                                    .arg(name_)
                                    .arg(timeout_ms)
                              : QStringLiteral("%1: tcdrain: %2")
                                    .arg(name_, QString::fromLocal8Bit(std::strerror(error)));
  }
  return false;
}

qint64 SerialStream::BytesQueued() const { return port_->isOpen() ? port_->bytesToWrite() : 0; }

qint64 SerialStream::DiscardQueued() {
  if (!port_->isOpen()) return 0;
  const qint64 queued = port_->bytesToWrite();
  port_->clear(QSerialPort::Output);  // Qt's buffer and the driver's (tcflush).
  bytes_dropped_ += static_cast<uint64_t>(queued);
  return queued;
}

QString SerialStream::Describe() const {
  return QStringLiteral("serial:%1@%2").arg(name_).arg(baud_);
}

void SerialStream::SetDataTerminalReady(bool on) {
  // Whatever the adapter answers (a pty has no DTR line; Qt may map an
  // odd errno to UnknownError), the port stays usable for its bytes: taken
  // as fatal, a reopen would set DTR again, fail again, and never settle.
  opening_ = true;
  if (port_->isOpen()) port_->setDataTerminalReady(on);
  opening_ = false;
}

// ---------------------------------------------------------------------------
// TcpStream

TcpStream::TcpStream(QTcpSocket* socket, QObject* parent) : ByteStream(parent), socket_(socket) {
  socket_->setParent(this);
  // Small frames (commands, acks) must not wait for Nagle's timer: the
  // round trip is what the operator sees as latency.
  socket_->setSocketOption(QAbstractSocket::LowDelayOption, 1);
  connect(socket_, &QTcpSocket::readyRead, this,
          [this] { emit bytesReceived(socket_->readAll()); });
  connect(socket_, &QTcpSocket::connected, this, [this] {
    socket_->setSocketOption(QAbstractSocket::LowDelayOption, 1);
    emit connected();
  });
  connect(socket_, &QTcpSocket::disconnected, this, [this] {
    if (!closing_) emit closed(QStringLiteral("connection closed by peer"));
  });
  connect(socket_, &QTcpSocket::errorOccurred, this, [this](QAbstractSocket::SocketError error) {
    if (closing_) return;
    // RemoteHostClosedError is followed by disconnected(); report the rest
    // (refused, timeout, network) when no connection was established.
    if (error != QAbstractSocket::RemoteHostClosedError &&
        socket_->state() != QAbstractSocket::ConnectedState) {
      closing_ = true;
      emit closed(socket_->errorString());
    }
  });
}

TcpStream::~TcpStream() {
  closing_ = true;
  socket_->abort();
}

void TcpStream::ConnectTo(const QString& host, quint16 port) {
  closing_ = false;
  socket_->connectToHost(host, port);
}

bool TcpStream::IsOpen() const { return socket_->state() == QAbstractSocket::ConnectedState; }

bool TcpStream::Write(const uint8_t* data, size_t n) {
  if (!IsOpen()) {
    bytes_dropped_ += n;
    return false;
  }
  return socket_->write(reinterpret_cast<const char*>(data), static_cast<qint64>(n)) ==
         static_cast<qint64>(n);
}

void TcpStream::Close() {
  closing_ = true;
  // Send what is queued (an AuthResult denied), then close.
  if (socket_->state() == QAbstractSocket::ConnectedState) socket_->flush();
  socket_->disconnectFromHost();
}

void TcpStream::Abort() {
  closing_ = true;
  socket_->abort();
}

qint64 TcpStream::BytesQueued() const { return socket_->bytesToWrite(); }

QString TcpStream::Describe() const {
  return QStringLiteral("tcp:%1:%2")
      .arg(socket_->peerAddress().toString())
      .arg(socket_->peerPort());
}

QString TcpStream::PeerAddress() const { return socket_->peerAddress().toString(); }

// ---------------------------------------------------------------------------
// PtyMasterStream

PtyMasterStream::PtyMasterStream(QObject* parent, qint64 max_queued)
    : ByteStream(parent), max_queued_(std::max<qint64>(0, max_queued)) {}

PtyMasterStream::~PtyMasterStream() { Close(); }

bool PtyMasterStream::Open(QString* error) {
  int master = -1;
  int slave = -1;
  char name[256] = {0};
  termios raw{};
  cfmakeraw(&raw);
  if (openpty(&master, &slave, name, &raw, nullptr) != 0) {
    if (error != nullptr) *error = QStringLiteral("openpty: %1").arg(strerror(errno));
    return false;
  }
  // Raw on both ends: no echo, no line editing, no CR/LF translation, all
  // 256 byte values pass (the link is binary).
  tcsetattr(slave, TCSANOW, &raw);
  tcsetattr(master, TCSANOW, &raw);
  fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  fcntl(master, F_SETFD, FD_CLOEXEC);
  fcntl(slave, F_SETFD, FD_CLOEXEC);
  master_fd_ = master;
  slave_fd_ = slave;
  slave_path_ = QString::fromLocal8Bit(name);
  notifier_ = new QSocketNotifier(master_fd_, QSocketNotifier::Read, this);
  connect(notifier_, &QSocketNotifier::activated, this, [this] { OnReadable(); });
  write_notifier_ = new QSocketNotifier(master_fd_, QSocketNotifier::Write, this);
  write_notifier_->setEnabled(false);
  connect(write_notifier_, &QSocketNotifier::activated, this, [this] { Flush(); });
  return true;
}

void PtyMasterStream::OnReadable() {
  QByteArray bytes;
  char buffer[4096];
  for (;;) {
    const ssize_t got = ::read(master_fd_, buffer, sizeof(buffer));
    if (got > 0) {
      bytes.append(buffer, static_cast<int>(got));
      continue;
    }
    if (got < 0 && errno == EINTR) continue;
    break;  // EAGAIN: drained. EIO cannot happen while slave_fd_ is open.
  }
  if (!bytes.isEmpty()) emit bytesReceived(bytes);
}

bool PtyMasterStream::Write(const uint8_t* data, size_t n) {
  if (master_fd_ < 0) {
    bytes_dropped_ += n;
    return false;
  }
  // Behind what is pending: the bytes go in order.
  if (!pending_.isEmpty()) Flush();
  size_t done = 0;
  while (pending_.isEmpty() && done < n) {
    const ssize_t put = ::write(master_fd_, data + done, n - done);
    if (put > 0) {
      done += static_cast<size_t>(put);
    } else if (put < 0 && errno == EINTR) {
      continue;
    } else {
      break;  // EAGAIN: the slave side is not reading; never block the agent.
    }
  }
  const size_t rest = n - done;
  if (rest == 0) return true;
  if (done == 0 && pending_.size() + static_cast<qint64>(rest) > max_queued_) {
    bytes_dropped_ += n;  // The whole write, never a part of it.
    return false;
  }
  // A write begun is finished, even past the bound (by one write at most).
  pending_.append(reinterpret_cast<const char*>(data + done), static_cast<int>(rest));
  write_notifier_->setEnabled(true);
  return true;
}

void PtyMasterStream::Flush() {
  qsizetype done = 0;
  while (done < pending_.size()) {
    const ssize_t put = ::write(master_fd_, pending_.constData() + done,
                                static_cast<size_t>(pending_.size() - done));
    if (put > 0) {
      done += put;
    } else if (put < 0 && errno == EINTR) {
      continue;
    } else {
      if (put < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
        // Not a full buffer but a failing pty: what waits cannot go (and
        // the write notifier would fire at once, again and again).
        bytes_dropped_ += static_cast<uint64_t>(pending_.size() - done);
        done = pending_.size();
      }
      break;
    }
  }
  pending_.remove(0, static_cast<int>(done));
  if (write_notifier_ != nullptr) write_notifier_->setEnabled(!pending_.isEmpty());
}

qint64 PtyMasterStream::DiscardQueued() {
  const qint64 queued = pending_.size();
  pending_.clear();
  if (write_notifier_ != nullptr) write_notifier_->setEnabled(false);
  bytes_dropped_ += static_cast<uint64_t>(queued);
  return queued;
}

void PtyMasterStream::Close() {
  for (QSocketNotifier** notifier : {&notifier_, &write_notifier_}) {
    if (*notifier == nullptr) continue;
    (*notifier)->setEnabled(false);
    delete *notifier;
    *notifier = nullptr;
  }
  bytes_dropped_ += static_cast<uint64_t>(pending_.size());
  pending_.clear();
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  master_fd_ = slave_fd_ = -1;
}

// ---------------------------------------------------------------------------
// Addresses and keys.

QString LinkAddress::ToString() const {
  if (kind == Kind::kTcp) return QStringLiteral("tcp:%1:%2").arg(host).arg(port);
  return QStringLiteral("serial:%1@%2").arg(serial_port).arg(baud);
}

bool ParseLinkAddress(const QString& text, LinkAddress* address, QString* error) {
  auto fail = [&](const QString& why) {
    if (error != nullptr) *error = QStringLiteral("link address '%1': %2").arg(text, why);
    return false;
  };
  LinkAddress result;
  QString rest = text;
  if (rest.startsWith(QStringLiteral("serial:"))) {
    result.kind = LinkAddress::Kind::kSerial;
    rest = rest.mid(7);
    const int at = rest.lastIndexOf('@');
    if (at >= 0) {
      bool ok = false;
      result.baud = rest.mid(at + 1).toInt(&ok);
      if (!ok || result.baud <= 0) return fail(QStringLiteral("bad baud rate"));
      rest = rest.left(at);
    }
    if (rest.isEmpty()) return fail(QStringLiteral("no serial port"));
    result.serial_port = rest;
    *address = result;
    return true;
  }
  if (rest.startsWith(QStringLiteral("tcp:"))) rest = rest.mid(4);
  const int colon = rest.lastIndexOf(':');
  if (colon <= 0) return fail(QStringLiteral("expected HOST:PORT"));
  bool ok = false;
  const int port = rest.mid(colon + 1).toInt(&ok);
  if (!ok || port < 0 || port > 65535) return fail(QStringLiteral("bad port"));
  result.kind = LinkAddress::Kind::kTcp;
  result.host = rest.left(colon);
  if (result.host.startsWith('[') && result.host.endsWith(']')) {
    result.host = result.host.mid(1, result.host.size() - 2);  // [::1]:5600
  }
  result.port = static_cast<quint16>(port);
  *address = result;
  return true;
}

QString KeyFileAccessOfOthers(unsigned mode) {
  // "read", "written", "executed" for one class's three bits, joined.
  const auto rights = [](unsigned bits) {
    QStringList what;
    if ((bits & 4) != 0) what << QStringLiteral("read");
    if ((bits & 2) != 0) what << QStringLiteral("written");
    if ((bits & 1) != 0) what << QStringLiteral("executed");
    const QString last = what.takeLast();
    return what.isEmpty() ? last : what.join(QStringLiteral(", ")) + QStringLiteral(" and ") + last;
  };
  const unsigned group = (mode >> 3) & 7;
  const unsigned others = mode & 7;
  if (group == 0 && others == 0) return QString();
  if (group == others)
    return QStringLiteral("can be %1 by its group and others").arg(rights(group));
  QStringList parts;
  if (group != 0) parts << QStringLiteral("%1 by its group").arg(rights(group));
  if (others != 0) parts << QStringLiteral("%1 by others").arg(rights(others));
  return QStringLiteral("can be ") + parts.join(QStringLiteral(", and "));
}

bool ReadKeyFile(const QString& path, std::vector<uint8_t>* key, QString* error,
                 KeyFilePermissions permissions, QString* warning) {
  auto fail = [&](const QString& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  struct stat st;
  if (::stat(QFile::encodeName(path).constData(), &st) != 0) {
    return fail(QStringLiteral("key file %1: %2").arg(path, QString::fromLocal8Bit(std::strerror(errno))));
  }
  if (S_ISDIR(st.st_mode)) return fail(QStringLiteral("key file %1 is a folder").arg(path));
  if (st.st_size > kMaxKeyFileBytes) {
    return fail(QStringLiteral("key file %1 is %2 bytes; key files over %3 bytes are refused")
                    .arg(path)
                    .arg(static_cast<qint64>(st.st_size))
                    .arg(kMaxKeyFileBytes));
  }
  if ((st.st_mode & 077) != 0 && permissions != KeyFilePermissions::kAny) {
    const QString message =
        QStringLiteral("key file %1 %2 (mode %3); only its owner may have access: chmod 600 %1")
            .arg(path, KeyFileAccessOfOthers(st.st_mode))
            .arg(static_cast<unsigned>(st.st_mode & 0777), 4, 8, QLatin1Char('0'));
    if (permissions == KeyFilePermissions::kOwnerOnly) return fail(message);
    if (warning != nullptr) *warning = message;
  }
  QFile file(path);
  if (!file.open(QIODevice::ReadOnly)) {
    return fail(QStringLiteral("key file %1: %2").arg(path, file.errorString()));
  }
  QByteArray bytes = file.read(kMaxKeyFileBytes + 1);
  if (bytes.size() > kMaxKeyFileBytes) {
    return fail(QStringLiteral("key file %1 is over %2 bytes; refused").arg(path).arg(kMaxKeyFileBytes));
  }
  // One trailing line end, LF or CR LF, and nothing else (docs/protocol.md,
  // "The key"): a lone CR is a key byte, which a random key may end with.
  if (bytes.endsWith('\n')) {
    bytes.chop(1);
    if (bytes.endsWith('\r')) bytes.chop(1);
  }
  if (bytes.isEmpty()) return fail(QStringLiteral("key file %1 is empty").arg(path));
  key->assign(bytes.begin(), bytes.end());
  return true;
}

}  // namespace hardware
}  // namespace sweepscan
