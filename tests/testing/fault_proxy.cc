#include "tests/testing/fault_proxy.h"

#include <QHostAddress>
#include <QTcpSocket>
#include <algorithm>
#include <utility>

namespace sweepscan::testing {

// One relayed connection. Side 0 is the client's socket, side 1 the proxy's
// own socket to the target (null for a connection black-holed from the
// start). Direction d flows from sock[d] to sock[1 - d]; held[d] is what the
// proxy holds in that direction.
struct FaultProxy::Link : public QObject {
  explicit Link(QObject* parent) : QObject(parent) {}

  QTcpSocket* sock[2] = {nullptr, nullptr};
  QByteArray held[2];
  bool gone[2] = {false, false};      // That side's socket has closed.
  bool fin_sent[2] = {false, false};  // Direction d's close was passed on.
  bool target_connected = false;
  bool black_hole = false;
  bool dead = false;  // Killed or removed: handlers do nothing.
};

namespace {
constexpr int kClient = 0;
constexpr int kTarget = 1;
}  // namespace

FaultProxy::FaultProxy(const QString& target_host, quint16 target_port, quint16 listen_port,
                       QObject* parent)
    : QObject(parent), target_host_(target_host), target_port_(target_port), port_(listen_port) {
  stall_timer_.setSingleShot(true);
  stall_timer_.setTimerType(Qt::PreciseTimer);
  connect(&stall_timer_, &QTimer::timeout, this, &FaultProxy::Resume);
  refuse_timer_.setSingleShot(true);
  refuse_timer_.setTimerType(Qt::PreciseTimer);
  connect(&refuse_timer_, &QTimer::timeout, this, &FaultProxy::StopRefusing);
  burst_timer_.setTimerType(Qt::PreciseTimer);
  connect(&burst_timer_, &QTimer::timeout, this, [this] {
    if (!stalled_) FlushAll();
  });
  connect(&server_, &QTcpServer::newConnection, this, &FaultProxy::OnNewConnection);
  Listen();
}

FaultProxy::FaultProxy(quint16 target_port, QObject* parent)
    : FaultProxy(QStringLiteral("127.0.0.1"), target_port, 0, parent) {}

FaultProxy::~FaultProxy() {
  std::vector<Link*> links;
  links.swap(links_);
  for (Link* link : links) {
    link->dead = true;
    for (QTcpSocket* s : link->sock) {
      if (s != nullptr) s->abort();
    }
    delete link;
  }
  server_.close();
}

void FaultProxy::Listen() {
  listening_ = server_.listen(QHostAddress::LocalHost, port_);
  if (listening_) {
    port_ = server_.serverPort();
    error_.clear();
  } else {
    error_ = server_.errorString();
  }
}

void FaultProxy::SetTarget(quint16 port) { target_port_ = port; }

void FaultProxy::SetTarget(const QString& host, quint16 port) {
  target_host_ = host;
  target_port_ = port;
}

void FaultProxy::OnNewConnection() {
  while (QTcpSocket* client = server_.nextPendingConnection()) {
    if (refusing_) {
      ++refused_;
      client->abort();
      client->deleteLater();
      continue;
    }
    ++accepted_;
    auto* link = new Link(this);
    client->setParent(link);
    client->setSocketOption(QAbstractSocket::LowDelayOption, 1);
    link->sock[kClient] = client;
    links_.push_back(link);
    connect(client, &QTcpSocket::readyRead, link, [this, link] { OnReadable(link, kUp); });
    connect(client, &QTcpSocket::disconnected, link, [this, link] { OnSourceClosed(link, kClient); });
    connect(client, &QAbstractSocket::errorOccurred, link, [this, link] {
      if (link->sock[kClient]->state() == QAbstractSocket::UnconnectedState) {
        OnSourceClosed(link, kClient);
      }
    });
    if (vanished_) {
      link->black_hole = true;
      ++black_holed_;
    } else {
      auto* target = new QTcpSocket(link);
      link->sock[kTarget] = target;
      connect(target, &QTcpSocket::connected, link, [this, link] { OnTargetConnected(link); });
      connect(target, &QTcpSocket::readyRead, link, [this, link] { OnReadable(link, kDown); });
      connect(target, &QTcpSocket::disconnected, link,
              [this, link] { OnSourceClosed(link, kTarget); });
      connect(target, &QAbstractSocket::errorOccurred, link, [this, link] {
        if (!link->target_connected) {
          OnTargetFailed(link);
        } else if (link->sock[kTarget]->state() == QAbstractSocket::UnconnectedState) {
          OnSourceClosed(link, kTarget);
        }
      });
      target->connectToHost(target_host_, target_port_);
    }
    emit connectionsChanged(Connections());
  }
}

void FaultProxy::OnTargetConnected(Link* link) {
  if (link->dead) return;
  link->target_connected = true;
  link->sock[kTarget]->setSocketOption(QAbstractSocket::LowDelayOption, 1);
  if (!Holding()) Flush(link, kUp);
}

void FaultProxy::OnTargetFailed(Link* link) {
  if (link->dead) return;
  ++failed_;
  Kill(link);
}

void FaultProxy::OnReadable(Link* link, int d) {
  if (link->dead) return;
  QTcpSocket* src = link->sock[d];
  if (src->bytesAvailable() <= 0) return;
  QByteArray data = src->readAll();
  const int to = 1 - d;
  if (link->black_hole || link->gone[to]) {
    dropped_[d] += data.size();
    return;
  }
  if (link->held[d].isEmpty()) {
    link->held[d] = std::move(data);
  } else {
    link->held[d].append(data);
  }
  if (!Holding()) Flush(link, d);
}

void FaultProxy::OnSourceClosed(Link* link, int side) {
  if (link->dead || link->gone[side]) return;
  OnReadable(link, side);  // Whatever came with the close.
  link->gone[side] = true;
  // Held bytes towards the closed side can no longer be delivered.
  const int towards = 1 - side;
  dropped_[towards] += link->held[towards].size();
  link->held[towards].clear();
  // Pass the close on after the bytes before it (now, or when released).
  if (!link->black_hole && !Holding()) Flush(link, side);
  MaybeRemove(link);
}

void FaultProxy::Flush(Link* link, int d) {
  if (link->dead || link->black_hole) return;
  const int to = 1 - d;
  QTcpSocket* dst = link->sock[to];
  if (dst == nullptr) return;
  if (to == kTarget && !link->target_connected) return;  // Sent on connect.
  if (link->gone[to]) {
    dropped_[d] += link->held[d].size();
    link->held[d].clear();
    return;
  }
  if (!link->held[d].isEmpty()) {
    const QByteArray data = std::move(link->held[d]);
    link->held[d] = QByteArray();
    dst->write(data);
    relayed_[d] += data.size();
  }
  if (link->gone[d] && !link->fin_sent[d]) {
    link->fin_sent[d] = true;
    dst->disconnectFromHost();  // After the bytes written; may close at once.
  }
}

void FaultProxy::Inject(Direction d, const QByteArray& bytes) {
  const std::vector<Link*> links = links_;  // Flush may remove links.
  for (Link* link : links) {
    if (link->dead || link->black_hole) continue;
    link->held[d].append(bytes);
    if (!Holding()) Flush(link, d);
  }
}

void FaultProxy::FlushAll() {
  const std::vector<Link*> links = links_;  // Flush may remove links.
  for (Link* link : links) {
    for (int d = 0; d < 2; ++d) Flush(link, d);
  }
}

void FaultProxy::DropHeld(Link* link) {
  for (int d = 0; d < 2; ++d) {
    dropped_[d] += link->held[d].size();
    link->held[d].clear();
  }
}

void FaultProxy::MaybeRemove(Link* link) {
  if (link->dead) return;
  for (int side = 0; side < 2; ++side) {
    if (link->sock[side] != nullptr && !link->gone[side]) return;
  }
  link->dead = true;
  links_.erase(std::remove(links_.begin(), links_.end(), link), links_.end());
  link->deleteLater();
  emit connectionsChanged(Connections());
}

void FaultProxy::Kill(Link* link) {
  if (link->dead) return;
  link->dead = true;  // abort() below emits disconnected(): ignored.
  DropHeld(link);
  for (QTcpSocket* s : link->sock) {
    if (s != nullptr) s->abort();
  }
  links_.erase(std::remove(links_.begin(), links_.end(), link), links_.end());
  link->deleteLater();
  emit connectionsChanged(Connections());
}

void FaultProxy::Stall(int ms) {
  stalled_ = true;
  stall_timer_.start(std::max(0, ms));
}

void FaultProxy::Stall() {
  stalled_ = true;
  stall_timer_.stop();
}

void FaultProxy::Resume() {
  stall_timer_.stop();
  if (!stalled_) return;
  stalled_ = false;
  FlushAll();
}

void FaultProxy::Cut() {
  const std::vector<Link*> links = links_;
  for (Link* link : links) {
    ++cut_;
    Kill(link);
  }
}

void FaultProxy::Refuse(RefuseMode mode) {
  refusing_ = true;
  refuse_mode_ = mode;
  refuse_timer_.stop();
  if (mode == RefuseMode::kClosed) {
    server_.close();  // Pending connections too.
    listening_ = false;
  } else if (!server_.isListening()) {
    Listen();
  }
}

void FaultProxy::RefuseFor(int ms, RefuseMode mode) {
  Refuse(mode);
  refuse_timer_.start(std::max(0, ms));
}

void FaultProxy::StopRefusing() {
  refuse_timer_.stop();
  refusing_ = false;
  if (!server_.isListening()) Listen();  // Same port as before.
}

void FaultProxy::CutFor(int ms, RefuseMode mode) {
  Cut();
  RefuseFor(ms, mode);
}

void FaultProxy::Vanish() {
  vanished_ = true;
  for (Link* link : links_) {
    if (link->black_hole) continue;
    link->black_hole = true;
    ++black_holed_;
    DropHeld(link);
  }
}

void FaultProxy::Restore() { vanished_ = false; }

void FaultProxy::SetBursts(int period_ms) {
  burst_period_ms_ = std::max(0, period_ms);
  if (burst_period_ms_ > 0) {
    burst_timer_.start(burst_period_ms_);
  } else {
    burst_timer_.stop();
    if (!stalled_) FlushAll();
  }
}

qint64 FaultProxy::BytesHeld(Direction d) const {
  qint64 n = 0;
  for (const Link* link : links_) n += link->held[d].size();
  return n;
}

}  // namespace sweepscan::testing
