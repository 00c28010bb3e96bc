// Writes the seed corpora of link_protocol_fuzz and session_loader_fuzz
// (tests/fuzz/corpus/link/, corpus/session/) from the real encoders and the
// session writer, so the fuzzers start from well-formed input.
// Usage: make_link_seed_corpus <corpus dir>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/session/session.h"
#include "hardware/link/link_protocol.h"
#include "tests/fuzz/seed_files.h"

namespace {

using sweepscan::fuzz::Bytes;
using namespace sweepscan;
using namespace sweepscan::hardware;

using sweepscan::fuzz::Append;
using sweepscan::fuzz::ReadFile;
using sweepscan::fuzz::WriteSeed;

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <corpus dir>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  const Time t = TimeFromSeconds(1.0);
  LinkEncoder agent(LinkSender::kAgent);
  LinkEncoder client(LinkSender::kClient);
  Bytes handshake = agent.Encode(t, Hello{1, true, "sweepscan-robotd", {{1, "X4"}, {2, "HI219"}}});
  Append(agent.Encode(t, AuthChallenge{}), &handshake);
  Append(client.Encode(t, Hello{1, false, "sweepscan", {}}), &handshake);
  Append(client.Encode(t, AuthResponse{}), &handshake);
  Append(agent.Encode(t, AuthResult{AuthOutcome::kOk, ""}), &handshake);
  WriteSeed(dir + "/link/handshake", 0, handshake);
  Bytes commands = client.EncodeDrive(t, 0.2, 0.1);
  for (const LinkPayload& p : std::vector<LinkPayload>{
           Stop{}, EmergencyStop{}, ClearEmergencyStop{}, Heartbeat{}, LidarMotor{true},
           TelemetryResume{{TelemetryResumePosition{true, t, 12}, TelemetryResumePosition{},
                            TelemetryResumePosition{true, t, 0}}}}) {
    Append(client.Encode(t, p), &commands);
  }
  WriteSeed(dir + "/link/commands", 7, commands);
  Bytes agent_out = agent.Encode(t, CommandAck{3, 0x10, AckResult::kAccepted, t});
  LinkStatus st;
  st.battery_voltage_v = 12.1f;
  st.watchdog = WatchdogState::kArmed;
  Append(agent.Encode(t, st), &agent_out);
  const Bytes raw = {0xAA, 0x55, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  Append(agent.EncodeTelemetry(t, LinkDevice::kLidar, t, raw.data(), raw.size()), &agent_out);
  // Resent after an outage (late, after a break), and the recorder's note.
  Append(agent.EncodeTelemetry(t, LinkDevice::kLidar, t, raw.data(), raw.size(),
                               kTelemetryLate | kTelemetryBreak),
         &agent_out);
  RecorderEvent event;
  event.kind = RecorderEventKind::kLinkRestored;
  event.outage = std::chrono::seconds(3);
  event.attempts = 2;
  event.reason = "no frame for 2.0 s";
  Append(client.Encode(t, event), &agent_out);
  WriteSeed(dir + "/link/agent", 64, agent_out);

  // Session: a small real session's frames.bin and meta.json.
  const std::string tmp = "/tmp/make_link_seed_corpus.sweepscan";
  SessionWriterOptions options;
  options.overwrite = true;
  std::unique_ptr<SessionWriter> w;
  Status s = SessionWriter::Create(tmp, SessionMeta(), options, &w);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  w->Append(handshake, 1);
  w->Append(commands, 2);
  w->Append(agent_out, 3);
  w->Close();
  WriteSeed(dir + "/session/frames", 0, ReadFile(tmp + "/frames.bin"));
  WriteSeed(dir + "/session/meta", 1, ReadFile(tmp + "/meta.json"));
  Bytes torn = ReadFile(tmp + "/frames.bin");
  torn.resize(torn.size() - 7);
  WriteSeed(dir + "/session/frames_torn", 2, torn);
  return 0;
}
