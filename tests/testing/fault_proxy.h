// A fault-injecting TCP relay for tests (issue 31: "Scanning over a real
// Wi-Fi link"). Put it between the workstation (RobotConnection, a TCP
// client) and the robot agent (RobotAgent, a TCP server): the client
// connects to 127.0.0.1:port(), and for each accepted connection the proxy
// opens its own connection to the target host:port and relays bytes both
// ways. On command it injects the faults of a real Wi-Fi link:
//
//   Stall(ms) / StallFor(ms), Stall() + Resume()
//       The robot drives behind a wall and comes back: every byte in both
//       directions is held (buffered in the proxy; both TCP connections stay
//       open, nothing is closed or reset), and when the stall ends everything
//       held is delivered at once, in order. A close (FIN) from one side
//       during a stall is held too, and delivered after the held bytes.
//       New connections are accepted during a stall (the handshake is not
//       stalled), their bytes are held like the others'.
//
//   Cut(), CutFor(ms), RefuseFor(ms) / Refuse() + StopRefusing()
//       The link drops: Cut() aborts both sockets of every current connection
//       (QTcpSocket::abort, an RST to each end); bytes held at that moment are
//       lost (counted as dropped). While refusing, reconnect attempts fail:
//       in RefuseMode::kReset (the default) a new connection is accepted and
//       at once aborted (the client may see "connected", then a reset);
//       in RefuseMode::kClosed the proxy stops listening, so connects are
//       refused by the kernel, and listens again on the same port after.
//       CutFor(ms) = Cut() + RefuseFor(ms): an outage of ms milliseconds.
//
//   Vanish() ... Restore()
//       The far host vanishes without a FIN (power loss, out of range for
//       good): a half-open link. Relaying stops in both directions, neither
//       side is closed, and whatever arrives (and whatever was held) is
//       dropped and counted. A close from either end is not passed on either.
//       New connections while vanished are accepted and never relayed (a
//       black hole: no connection is made to the target). Restore() makes new
//       connections relay again; connections that were vanished stay black
//       holes for good (their bytes are gone and TCP has no gaps): the
//       endpoints' own timeouts must give up on them, or Cut() resets them,
//       as the returning host's stack would answer them with an RST.
//
//   SetBursts(period_ms)
//       Wi-Fi aggregation and retransmission delays: bytes in each direction
//       are held and released all at once every period_ms (one timer for the
//       proxy, so both directions and all connections release together).
//       0 turns it off (and releases what is held). A stall overrides it.
//
//   SetTarget(port) / SetTarget(host, port)
//       The agent restarted on a new port: new connections go there; current
//       ones stay with the old target.
//
// TCP semantics kept: bytes are delivered in order, without duplication, and
// none is lost except by Vanish (and on a vanished connection) or by Cut
// (what was held at the cut), or when the receiving side has already closed.
// A close (FIN) is passed on after the bytes before it. Qt has no half-close,
// so once one end closes, the other end's unsent bytes towards it are lost,
// as with the usual close() of a real peer.
//
// Counters: per direction (kUp: client -> target, kDown: target -> client)
// bytes relayed (handed to the receiving socket) and bytes dropped; per proxy
// connections accepted (relayed or black-holed), refused, cut (by Cut()),
// black-holed, failed (the target refused the proxy's own connect: the
// client's connection is then aborted), and Connections(), the connections
// open now.
//
// One thread: everything runs on the owning thread's event loop (a
// QCoreApplication); all timing is by QTimer; no threads. Memory is not
// bounded (tests only), bytes are not copied needlessly (held data is
// QByteArray, implicitly shared).
#ifndef SWEEPSCAN_TESTS_TESTING_FAULT_PROXY_H_
#define SWEEPSCAN_TESTS_TESTING_FAULT_PROXY_H_

#include <QByteArray>
#include <QObject>
#include <QString>
#include <QTcpServer>
#include <QTimer>
#include <QtGlobal>
#include <memory>
#include <vector>

class QTcpSocket;

namespace sweepscan::testing {

class FaultProxy : public QObject {
  Q_OBJECT

 public:
  enum Direction { kUp = 0, kDown = 1 };  // kUp: client -> target.
  enum class RefuseMode { kReset, kClosed };

  // Listens on 127.0.0.1:listen_port (0: any free port) and relays to
  // target_host:target_port. isListening() says whether it could.
  FaultProxy(const QString& target_host, quint16 target_port, quint16 listen_port = 0,
             QObject* parent = nullptr);
  // Target on 127.0.0.1.
  explicit FaultProxy(quint16 target_port, QObject* parent = nullptr);
  ~FaultProxy() override;

  bool isListening() const { return listening_; }
  QString errorString() const { return error_; }
  quint16 port() const { return port_; }
  QString targetHost() const { return target_host_; }
  quint16 targetPort() const { return target_port_; }

  // New connections go to host:port (current ones keep their target).
  void SetTarget(quint16 port);
  void SetTarget(const QString& host, quint16 port);

  // Stall: hold every byte both ways for ms, then deliver them in order.
  void Stall(int ms);
  void StallFor(int ms) { Stall(ms); }
  void Stall();   // Until Resume().
  void Resume();  // Ends a stall (timed or not); delivers what was held.
  bool stalled() const { return stalled_; }

  // Aborts both sides of every current connection (RST both ways).
  void Cut();
  // New connections fail for ms (kReset: accepted and aborted; kClosed: not
  // listening, connects refused). Does not touch current connections.
  void RefuseFor(int ms, RefuseMode mode = RefuseMode::kReset);
  void Refuse(RefuseMode mode = RefuseMode::kReset);  // Until StopRefusing().
  void StopRefusing();
  bool refusing() const { return refusing_; }
  // Cut() + RefuseFor(ms): a link down for ms.
  void CutFor(int ms, RefuseMode mode = RefuseMode::kReset);

  // Half-open: current connections become black holes (nothing relayed or
  // closed, everything dropped), and so do new ones until Restore().
  void Vanish();
  void Restore();
  bool vanished() const { return vanished_; }

  // Bytes held and released every period_ms, both directions; 0: off.
  void SetBursts(int period_ms);
  int burstPeriod() const { return burst_period_ms_; }

  // Bytes of our own into direction d of every current connection, as
  // someone on the path would put them there: behind what that direction
  // holds, delivered now unless bytes are held. Counted as relayed.
  void Inject(Direction d, const QByteArray& bytes);

  // Counters.
  qint64 BytesRelayed(Direction d) const { return relayed_[d]; }
  qint64 BytesDropped(Direction d) const { return dropped_[d]; }
  qint64 BytesHeld(Direction d) const;  // Held in the proxy now.
  int ConnectionsAccepted() const { return accepted_; }
  int ConnectionsRefused() const { return refused_; }
  int ConnectionsCut() const { return cut_; }
  int ConnectionsBlackHoled() const { return black_holed_; }
  int ConnectionsFailed() const { return failed_; }
  int Connections() const { return static_cast<int>(links_.size()); }

 signals:
  // A connection was accepted (relayed or black-holed) or one ended.
  void connectionsChanged(int connections);

 private:
  struct Link;

  void OnNewConnection();
  void OnReadable(Link* link, int d);
  void OnSourceClosed(Link* link, int d);
  void OnTargetConnected(Link* link);
  void OnTargetFailed(Link* link);
  void Flush(Link* link, int d);
  void FlushAll();
  void DropHeld(Link* link);
  void Kill(Link* link);  // Aborts both sockets and removes the link.
  void MaybeRemove(Link* link);
  bool Holding() const { return stalled_ || burst_period_ms_ > 0; }
  void Listen();

  QTcpServer server_;
  QString target_host_;
  quint16 target_port_ = 0;
  quint16 port_ = 0;
  bool listening_ = false;
  QString error_;

  std::vector<Link*> links_;  // Owned (QObject children of this).

  bool stalled_ = false;
  QTimer stall_timer_;
  bool refusing_ = false;
  RefuseMode refuse_mode_ = RefuseMode::kReset;
  QTimer refuse_timer_;
  bool vanished_ = false;
  int burst_period_ms_ = 0;
  QTimer burst_timer_;

  qint64 relayed_[2] = {0, 0};
  qint64 dropped_[2] = {0, 0};
  int accepted_ = 0;
  int refused_ = 0;
  int cut_ = 0;
  int black_holed_ = 0;
  int failed_ = 0;
};

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_FAULT_PROXY_H_
