// testing::FaultProxy (tests/testing/fault_proxy.h, issue 31) between plain
// QTcpSocket clients and a QTcpServer (echoing, or only recording), each end
// recording when its bytes arrive: a plain relay keeps bytes in order both
// ways and passes closes on; a stall holds every byte (both ways) and
// delivers them in order after it and not before; a cut resets both ends;
// refusing makes reconnects fail for the stated time; a vanished link
// delivers nothing and closes nothing; bursts arrive in clumps at the period;
// SetTarget redirects new connections.
//
// One thread with a QCoreApplication; waits pump the event loop. Timing
// bounds are wide (a loaded 2-core machine): lower bounds lean on the QTimer
// never firing early, upper bounds are seconds.
#include "tests/testing/fault_proxy.h"

#include <gtest/gtest.h>

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QHostAddress>
#include <QTcpServer>
#include <QTcpSocket>
#include <algorithm>
#include <memory>
#include <vector>

#include "tests/testing/qt_wait.h"

namespace sweepscan::testing {
namespace {

qint64 NowMs() {
  static const QElapsedTimer clock = [] {
    QElapsedTimer t;
    t.start();
    return t;
  }();
  return clock.elapsed();
}

struct Arrival {
  qint64 t_ms;
  int offset;  // Into everything received.
  int size;
};

// One end of a connection: records what arrives and when; echoes if asked.
class Peer : public QObject {
 public:
  Peer(QTcpSocket* socket, bool echo) : socket(socket), echo_(echo) {
    socket->setParent(this);
    connect(socket, &QTcpSocket::readyRead, this, [this] { Read(); });
    connect(socket, &QTcpSocket::disconnected, this, [this] {
      Read();
      closed = true;
      received_at_close = received.size();
    });
    connect(socket, &QAbstractSocket::errorOccurred, this,
            [this](QAbstractSocket::SocketError e) { errors.push_back(e); });
  }

  bool connected() const { return socket->state() == QAbstractSocket::ConnectedState; }
  bool failed() const { return !errors.empty() || closed; }
  void Write(const QByteArray& data) { socket->write(data); }

  QTcpSocket* socket;
  QByteArray received;
  std::vector<Arrival> arrivals;
  bool closed = false;
  int received_at_close = -1;
  std::vector<QAbstractSocket::SocketError> errors;

 private:
  void Read() {
    const QByteArray data = socket->readAll();
    if (data.isEmpty()) return;
    arrivals.push_back({NowMs(), static_cast<int>(received.size()), static_cast<int>(data.size())});
    received += data;
    if (echo_) socket->write(data);
  }
  bool echo_;
};

// A QTcpServer on 127.0.0.1 that keeps a Peer per accepted connection.
class TestServer : public QObject {
 public:
  explicit TestServer(bool echo) : echo_(echo) {
    connect(&server_, &QTcpServer::newConnection, this, [this] {
      while (QTcpSocket* s = server_.nextPendingConnection()) {
        peers.push_back(std::make_unique<Peer>(s, echo_));
      }
    });
    EXPECT_TRUE(server_.listen(QHostAddress::LocalHost, 0)) << server_.errorString().toStdString();
  }
  quint16 port() const { return server_.serverPort(); }

  std::vector<std::unique_ptr<Peer>> peers;

 private:
  QTcpServer server_;
  bool echo_;
};

std::unique_ptr<Peer> Dial(quint16 port) {
  auto* socket = new QTcpSocket;
  auto peer = std::make_unique<Peer>(socket, false);
  socket->connectToHost(QHostAddress::LocalHost, port);
  return peer;
}

// Connects through the proxy and waits for the far end's connection.
std::unique_ptr<Peer> DialThrough(const FaultProxy& proxy, const TestServer& server) {
  const size_t before = server.peers.size();
  auto client = Dial(proxy.port());
  EXPECT_TRUE(WaitFor([&] { return client->connected() && server.peers.size() > before; }, 5000));
  return client;
}

// A fresh connection that echoes "ping" (to an echoing server) within timeout_ms.
bool TryEcho(quint16 port, int timeout_ms) {
  auto client = Dial(port);
  client->Write("ping");
  WaitFor([&] { return client->received == "ping" || client->failed(); }, timeout_ms);
  return client->received == "ping";
}

QByteArray Pattern(int n) {
  QByteArray data(n, '\0');
  for (int i = 0; i < n; ++i) data[i] = static_cast<char>((i * 131 + i / 251) & 0xff);
  return data;
}

// Arrivals (from from_offset on) grouped where they are more than gap_ms apart;
// each group's first arrival time.
std::vector<qint64> Clumps(const std::vector<Arrival>& arrivals, int from_offset, qint64 gap_ms) {
  std::vector<qint64> starts;
  qint64 last = -1;
  for (const Arrival& a : arrivals) {
    if (a.offset < from_offset) continue;
    if (last < 0 || a.t_ms - last > gap_ms) starts.push_back(a.t_ms);
    last = a.t_ms;
  }
  return starts;
}

TEST(FaultProxyTest, RelaysBothWaysInOrderAndPassesClosesOn) {
  TestServer server(/*echo=*/true);
  FaultProxy proxy(server.port());
  ASSERT_TRUE(proxy.isListening()) << proxy.errorString().toStdString();
  ASSERT_NE(proxy.port(), 0);
  auto client = DialThrough(proxy, server);
  EXPECT_EQ(proxy.Connections(), 1);
  EXPECT_EQ(proxy.ConnectionsAccepted(), 1);

  const QByteArray data = Pattern(1 << 20);
  client->Write(data);
  ASSERT_TRUE(WaitFor([&] { return client->received.size() >= data.size(); }, 20000));
  EXPECT_TRUE(client->received == data);
  EXPECT_EQ(proxy.BytesRelayed(FaultProxy::kUp), data.size());
  EXPECT_EQ(proxy.BytesRelayed(FaultProxy::kDown), data.size());
  EXPECT_EQ(proxy.BytesDropped(FaultProxy::kUp), 0);
  EXPECT_EQ(proxy.BytesDropped(FaultProxy::kDown), 0);

  // The client closes: the far end sees the bytes, then the close.
  client->Write("last words");
  client->socket->disconnectFromHost();
  Peer& far = *server.peers[0];
  ASSERT_TRUE(WaitFor([&] { return far.closed; }, 5000));
  EXPECT_EQ(far.received_at_close, data.size() + 10);
  EXPECT_TRUE(WaitFor([&] { return proxy.Connections() == 0; }, 5000));

  // The server closes: the client sees it.
  auto second = DialThrough(proxy, server);
  server.peers[1]->socket->disconnectFromHost();
  EXPECT_TRUE(WaitFor([&] { return second->closed; }, 5000));
  EXPECT_TRUE(WaitFor([&] { return proxy.Connections() == 0; }, 5000));
  EXPECT_EQ(proxy.ConnectionsCut(), 0);
}

TEST(FaultProxyTest, StallHoldsBytesBothWaysAndDeliversThemInOrderAfterAndNotBefore) {
  TestServer server(/*echo=*/false);
  FaultProxy proxy(server.port());
  auto client = DialThrough(proxy, server);
  Peer& far = *server.peers[0];
  client->Write("hello");
  ASSERT_TRUE(WaitFor([&] { return far.received == "hello"; }, 5000));

  constexpr int kStallMs = 800;
  const qint64 t0 = NowMs();
  proxy.Stall(kStallMs);
  EXPECT_TRUE(proxy.stalled());
  QByteArray up, down;
  for (int i = 0; i < 10; ++i) {
    const QByteArray u = "up " + QByteArray::number(i) + ";";
    const QByteArray d = "down " + QByteArray::number(i) + ";" + Pattern(5000);
    client->Write(u);
    far.Write(d);
    up += u;
    down += d;
    Pump(30);
  }
  ASSERT_TRUE(WaitFor([&] { return far.received.size() == 5 + up.size() &&
                                   client->received.size() == down.size(); },
                      kStallMs + 10000));
  EXPECT_FALSE(proxy.stalled());
  EXPECT_TRUE(far.received == "hello" + up);
  EXPECT_TRUE(client->received == down);
  // Nothing held arrived before the stall's end, all of it soon after it.
  qint64 first = -1, last = -1;
  for (const Arrival& a : far.arrivals) {
    if (a.offset < 5) continue;
    if (first < 0) first = a.t_ms;
    last = a.t_ms;
  }
  for (const Arrival& a : client->arrivals) {
    first = std::min(first, a.t_ms);
    last = std::max(last, a.t_ms);
  }
  EXPECT_GE(first - t0, kStallMs - 20) << "bytes got through during the stall";
  EXPECT_LE(last - t0, kStallMs + 4000);
  // Both connections stayed up, and still relay.
  EXPECT_TRUE(client->connected());
  EXPECT_TRUE(far.connected());
  EXPECT_FALSE(client->closed || far.closed);
  client->Write("after");
  EXPECT_TRUE(WaitFor([&] { return far.received.endsWith("after"); }, 5000));
  EXPECT_EQ(proxy.BytesDropped(FaultProxy::kUp) + proxy.BytesDropped(FaultProxy::kDown), 0);
}

TEST(FaultProxyTest, OpenEndedStallHoldsUntilResumeAndHoldsTheCloseBehindTheBytes) {
  TestServer server(/*echo=*/false);
  FaultProxy proxy(server.port());
  auto client = DialThrough(proxy, server);
  Peer& far = *server.peers[0];

  proxy.Stall();
  const QByteArray data = Pattern(200000);
  client->Write(data);
  client->socket->disconnectFromHost();  // The close is held too.
  ASSERT_TRUE(WaitFor([&] { return proxy.BytesHeld(FaultProxy::kUp) == data.size(); }, 10000));
  Pump(300);
  EXPECT_TRUE(far.received.isEmpty());
  EXPECT_FALSE(far.closed);
  EXPECT_TRUE(far.connected());
  EXPECT_EQ(proxy.Connections(), 1);

  proxy.Resume();
  ASSERT_TRUE(WaitFor([&] { return far.closed; }, 10000));
  EXPECT_EQ(far.received_at_close, data.size());
  EXPECT_TRUE(far.received == data);
  EXPECT_EQ(proxy.BytesHeld(FaultProxy::kUp), 0);
  EXPECT_EQ(proxy.BytesRelayed(FaultProxy::kUp), data.size());
  EXPECT_TRUE(WaitFor([&] { return proxy.Connections() == 0; }, 5000));
}

TEST(FaultProxyTest, CutResetsBothEndsOfEveryConnection) {
  TestServer server(/*echo=*/true);
  FaultProxy proxy(server.port());
  auto a = DialThrough(proxy, server);
  auto b = DialThrough(proxy, server);
  a->Write("x");
  ASSERT_TRUE(WaitFor([&] { return a->received == "x"; }, 5000));
  ASSERT_EQ(proxy.Connections(), 2);

  proxy.Cut();
  EXPECT_EQ(proxy.Connections(), 0);
  EXPECT_EQ(proxy.ConnectionsCut(), 2);
  EXPECT_TRUE(WaitFor([&] {
    return a->closed && b->closed && server.peers[0]->closed && server.peers[1]->closed;
  }, 5000));
  EXPECT_FALSE(a->errors.empty());  // A reset, not a clean close.
  // Not refusing: a new connection relays at once.
  EXPECT_TRUE(TryEcho(proxy.port(), 5000));
}

TEST(FaultProxyTest, CutForMakesReconnectsFailForTheOutage) {
  TestServer server(/*echo=*/true);
  FaultProxy proxy(server.port());
  auto client = DialThrough(proxy, server);

  constexpr int kOutageMs = 1000;
  const qint64 t0 = NowMs();
  proxy.CutFor(kOutageMs);
  EXPECT_TRUE(proxy.refusing());
  EXPECT_TRUE(WaitFor([&] { return client->closed; }, 5000));
  int failed = 0;
  qint64 ok_at = -1;
  while (NowMs() - t0 < kOutageMs + 10000) {
    if (TryEcho(proxy.port(), 2000)) {
      ok_at = NowMs();
      break;
    }
    ++failed;
    Pump(50);
  }
  ASSERT_GE(ok_at, 0) << "never reconnected";
  EXPECT_GE(failed, 1);
  EXPECT_GE(proxy.ConnectionsRefused(), 1);
  EXPECT_GE(ok_at - t0, kOutageMs - 20) << "reconnected during the outage";
  EXPECT_LE(ok_at - t0, kOutageMs + 5000);
  EXPECT_FALSE(proxy.refusing());
  EXPECT_EQ(server.peers.size(), 2u);  // Refused attempts never reached it.
}

TEST(FaultProxyTest, RefuseClosedStopsListeningAndListensAgainOnTheSamePort) {
  TestServer server(/*echo=*/true);
  FaultProxy proxy(server.port());
  const quint16 port = proxy.port();

  constexpr int kOutageMs = 800;
  const qint64 t0 = NowMs();
  proxy.RefuseFor(kOutageMs, FaultProxy::RefuseMode::kClosed);
  EXPECT_FALSE(proxy.isListening());
  auto refused = Dial(port);
  ASSERT_TRUE(WaitFor([&] { return refused->failed(); }, 5000));
  ASSERT_FALSE(refused->errors.empty());
  EXPECT_EQ(refused->errors[0], QAbstractSocket::ConnectionRefusedError);
  EXPECT_FALSE(refused->connected());

  ASSERT_TRUE(WaitFor([&] { return proxy.isListening(); }, kOutageMs + 5000));
  EXPECT_GE(NowMs() - t0, kOutageMs - 20);
  EXPECT_EQ(proxy.port(), port);
  EXPECT_TRUE(TryEcho(port, 5000));
}

TEST(FaultProxyTest, VanishedLinkDeliversNothingClosesNothingAndBlackHolesNewConnections) {
  TestServer server(/*echo=*/false);
  FaultProxy proxy(server.port());
  auto client = DialThrough(proxy, server);
  Peer& far = *server.peers[0];
  client->Write("hi");
  ASSERT_TRUE(WaitFor([&] { return far.received == "hi"; }, 5000));

  proxy.Vanish();
  const QByteArray up = Pattern(1000), down = Pattern(3000);
  client->Write(up);
  far.Write(down);
  ASSERT_TRUE(WaitFor([&] {
    return proxy.BytesDropped(FaultProxy::kUp) == up.size() &&
           proxy.BytesDropped(FaultProxy::kDown) == down.size();
  }, 5000));
  // A close from one end is not passed on either.
  client->socket->disconnectFromHost();
  Pump(500);
  EXPECT_EQ(far.received, "hi");
  EXPECT_TRUE(client->received.isEmpty());
  EXPECT_TRUE(far.connected());
  EXPECT_FALSE(far.closed);
  EXPECT_EQ(proxy.Connections(), 1);  // Half-open: the far end's side lives on.

  // A new connection while vanished: accepted, never relayed.
  auto lost = Dial(proxy.port());
  ASSERT_TRUE(WaitFor([&] { return lost->connected(); }, 5000));
  lost->Write("anyone?");
  ASSERT_TRUE(WaitFor([&] { return proxy.BytesDropped(FaultProxy::kUp) == up.size() + 7; }, 5000));
  Pump(300);
  EXPECT_EQ(server.peers.size(), 1u);
  EXPECT_TRUE(lost->connected());
  EXPECT_EQ(proxy.ConnectionsBlackHoled(), 2);
  EXPECT_EQ(proxy.Connections(), 2);

  // Restored: new connections relay; the vanished ones stay dead, open.
  proxy.Restore();
  auto fresh = DialThrough(proxy, server);
  ASSERT_EQ(server.peers.size(), 2u);
  fresh->Write("back");
  EXPECT_TRUE(WaitFor([&] { return server.peers[1]->received == "back"; }, 5000));
  lost->Write("still?");
  Pump(300);
  EXPECT_EQ(server.peers.size(), 2u);
  EXPECT_TRUE(lost->connected());
  EXPECT_EQ(proxy.BytesRelayed(FaultProxy::kUp), 2 + 4);

  // A cut resets the leftovers (the returning host's RST).
  proxy.Cut();
  EXPECT_TRUE(WaitFor([&] { return far.closed && lost->closed && fresh->closed; }, 5000));
  EXPECT_EQ(proxy.Connections(), 0);
}

TEST(FaultProxyTest, BurstsArriveInClumpsAtThePeriod) {
  TestServer server(/*echo=*/true);
  FaultProxy proxy(server.port());
  auto client = DialThrough(proxy, server);
  Peer& far = *server.peers[0];
  client->Write("start");
  ASSERT_TRUE(WaitFor([&] { return client->received == "start"; }, 5000));

  constexpr int kPeriodMs = 300;
  proxy.SetBursts(kPeriodMs);
  EXPECT_EQ(proxy.burstPeriod(), kPeriodMs);
  const qint64 t0 = NowMs();
  QByteArray sent;
  int messages = 0;
  while (NowMs() - t0 < 2100) {
    const QByteArray m = "message " + QByteArray::number(messages++) + ";";
    client->Write(m);
    sent += m;
    Pump(20);
  }
  ASSERT_TRUE(WaitFor([&] { return client->received.size() == 5 + sent.size(); }, 10000));
  EXPECT_TRUE(far.received == "start" + sent);
  EXPECT_TRUE(client->received == "start" + sent);

  // Far fewer clumps than messages, about one per period, both ways.
  for (const Peer* end : {&far, client.get()}) {
    const std::vector<qint64> clumps = Clumps(end->arrivals, 5, kPeriodMs / 3);
    ASSERT_GE(clumps.size(), 3u);
    EXPECT_LE(clumps.size(), 12u);
    EXPECT_LE(static_cast<int>(clumps.size()) * 4, messages);
    std::vector<qint64> gaps;
    for (size_t i = 1; i < clumps.size(); ++i) gaps.push_back(clumps[i] - clumps[i - 1]);
    std::sort(gaps.begin(), gaps.end());
    const qint64 median = gaps[gaps.size() / 2];
    EXPECT_GE(median, kPeriodMs * 2 / 3);
    EXPECT_LE(median, kPeriodMs * 2);
    EXPECT_GE(clumps.front() - t0, 0);
  }

  // Off: released, and relayed as it comes.
  proxy.SetBursts(0);
  client->Write("tail");
  EXPECT_TRUE(WaitFor([&] { return client->received.endsWith("tail"); }, 5000));
  EXPECT_EQ(proxy.BytesHeld(FaultProxy::kUp) + proxy.BytesHeld(FaultProxy::kDown), 0);
}

TEST(FaultProxyTest, SetTargetRedirectsNewConnectionsOnly) {
  TestServer first(/*echo=*/true), second(/*echo=*/true);
  FaultProxy proxy(first.port());
  auto old_client = DialThrough(proxy, first);
  EXPECT_EQ(first.peers.size(), 1u);

  proxy.SetTarget(second.port());
  EXPECT_EQ(proxy.targetPort(), second.port());
  auto new_client = DialThrough(proxy, second);
  EXPECT_EQ(first.peers.size(), 1u);
  EXPECT_EQ(second.peers.size(), 1u);
  new_client->Write("new");
  old_client->Write("old");
  EXPECT_TRUE(WaitFor([&] { return new_client->received == "new" && old_client->received == "old"; },
                      5000));
  EXPECT_EQ(first.peers[0]->received, "old");
  EXPECT_EQ(second.peers[0]->received, "new");
}

TEST(FaultProxyTest, TargetDownResetsTheClient) {
  quint16 closed_port = 0;
  {
    QTcpServer probe;
    ASSERT_TRUE(probe.listen(QHostAddress::LocalHost, 0));
    closed_port = probe.serverPort();
  }
  FaultProxy proxy(closed_port);
  auto client = Dial(proxy.port());
  client->Write("hello?");
  EXPECT_TRUE(WaitFor([&] { return client->closed || !client->errors.empty(); }, 5000));
  EXPECT_TRUE(WaitFor([&] { return proxy.ConnectionsFailed() == 1; }, 5000));
  EXPECT_EQ(proxy.Connections(), 0);
  EXPECT_EQ(proxy.BytesRelayed(FaultProxy::kUp), 0);
}

}  // namespace
}  // namespace sweepscan::testing

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
