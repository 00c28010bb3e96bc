// Link round-trip latency on loopback TCP: the workstation sends a Heartbeat,
// the agent (RobotAgent, on its own thread as in sweepscan-robotd) answers
// with a CommandAck echoing the Heartbeat's time; round trip = now - echo
// time on the client's clock. Also the same with the agent streaming
// telemetry-sized traffic is left to the end-to-end tests.
//
//   agent_link_benchmark [ROUND_TRIPS]   (default 5000)
#include <QCoreApplication>
#include <QElapsedTimer>
#include <QTcpSocket>
#include <QThread>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "hardware/agent/robot_agent.h"
#include "hardware/link/hmac_sha256.h"
#include "hardware/link/link_protocol.h"

using namespace sweepscan;
using namespace sweepscan::hardware;

namespace {

Time SteadyNow() {
  return Time(
      std::chrono::duration_cast<Duration>(std::chrono::steady_clock::now().time_since_epoch()));
}

}  // namespace

int main(int argc, char** argv) {
  QCoreApplication app(argc, argv);
  const int round_trips = argc > 1 ? std::max(10, atoi(argv[1])) : 5000;
  const std::string key_text = "benchmark key";
  const std::vector<uint8_t> key(key_text.begin(), key_text.end());

  RobotAgentConfig config;
  config.listen_port = 0;
  config.agent.key = key;
  QThread agent_thread;
  agent_thread.start();
  auto* agent = new RobotAgent(config);
  agent->moveToThread(&agent_thread);
  quint16 port = 0;
  QString error;
  bool started = false;
  QMetaObject::invokeMethod(
      agent,
      [&] {
        started = agent->Start(&error);
        port = agent->tcp_port();
      },
      Qt::BlockingQueuedConnection);
  if (!started) {
    std::fprintf(stderr, "agent: %s\n", qPrintable(error));
    return 1;
  }

  QTcpSocket socket;
  socket.setSocketOption(QAbstractSocket::LowDelayOption, 1);
  socket.connectToHost(QStringLiteral("127.0.0.1"), port);
  if (!socket.waitForConnected(5000)) return 1;
  LinkEncoder encoder(LinkSender::kClient);
  LinkDecoder decoder;
  std::vector<LinkMessage> messages;
  auto send = [&](const LinkPayload& payload) {
    const auto frame = encoder.Encode(SteadyNow(), payload);
    socket.write(reinterpret_cast<const char*>(frame.data()), frame.size());
    socket.flush();
  };
  // Waits (blocking is fine in a benchmark client) for a message of type T.
  auto wait_for = [&](auto predicate) -> bool {
    for (;;) {
      for (size_t i = 0; i < messages.size(); ++i) {
        if (predicate(messages[i])) {
          messages.erase(messages.begin(), messages.begin() + i + 1);
          return true;
        }
      }
      messages.clear();
      if (!socket.waitForReadyRead(5000)) return false;
      const QByteArray bytes = socket.readAll();
      decoder.Feed(reinterpret_cast<const uint8_t*>(bytes.constData()), bytes.size(), &messages);
    }
  };
  AuthChallenge challenge;
  if (!wait_for([&](const LinkMessage& m) {
        if (const auto* c = std::get_if<AuthChallenge>(&m.payload)) challenge = *c;
        return std::holds_alternative<AuthChallenge>(m.payload);
      })) {
    return 1;
  }
  send(Hello{});
  AuthResponse response;
  LinkSessionKey session_key;
  if (!MakeLinkAuthResponse(key, challenge, &response, &session_key)) return 1;
  send(response);
  // Every frame after the response carries a tag (per-frame MAC, protocol v2).
  encoder.SetSigner(MakeLinkFrameSigner(session_key));
  if (!wait_for(
          [](const LinkMessage& m) { return std::holds_alternative<AuthResult>(m.payload); })) {
    return 1;
  }

  std::vector<double> rtt_us;
  rtt_us.reserve(round_trips);
  for (int i = 0; i < round_trips + 100; ++i) {
    const uint32_t sequence = encoder.next_sequence();
    send(Heartbeat{});
    Time echo;
    if (!wait_for([&](const LinkMessage& m) {
          const auto* ack = std::get_if<CommandAck>(&m.payload);
          if (ack == nullptr || ack->acked_sequence != sequence) return false;
          echo = ack->echo_time;
          return true;
        })) {
      std::fprintf(stderr, "no ack\n");
      return 1;
    }
    if (i >= 100) rtt_us.push_back(ToSeconds(SteadyNow() - echo) * 1e6);  // 100 warm-up.
  }
  std::sort(rtt_us.begin(), rtt_us.end());
  double sum = 0;
  for (double v : rtt_us) sum += v;
  auto pct = [&](double p) { return rtt_us[static_cast<size_t>(p * (rtt_us.size() - 1))]; };
  std::printf(
      "link round trip (Heartbeat -> CommandAck), loopback TCP, agent on its own thread, %zu "
      "samples:\n  min %.1f us  median %.1f us  mean %.1f us  p99 %.1f us  max %.1f us\n",
      rtt_us.size(), rtt_us.front(), pct(0.5), sum / rtt_us.size(), pct(0.99), rtt_us.back());

  QMetaObject::invokeMethod(
      agent,
      [&] {
        agent->Shutdown();
        delete agent;
      },
      Qt::BlockingQueuedConnection);
  agent_thread.quit();
  agent_thread.wait();
  return 0;
}
