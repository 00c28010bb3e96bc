#include "hardware/emulation/simulate_session.h"

#include <memory>
#include <variant>

#include "core/scenario/scenario.h"
#include "hardware/agent/agent_core.h"
#include "hardware/emulation/sim_devices.h"

namespace sweepscan::hardware {

Status SimulateSession(const sim::SimConfig& config, const std::string& session_dir,
                       const SimulateSessionOptions& options, SimulateSessionReport* report) {
  *report = SimulateSessionReport();
  if (options.step <= Duration::zero()) return Status::Error("simulate: step must be positive");
  std::string error;
  if (!config.IsValid(&error)) return Status::Error("scenario: " + error);

  SessionMeta meta;
  meta.geometry = config.geometry;
  meta.lidar_angle_convention = config.lidar.angle_convention;
  meta.link = "simulated (in-process, scenario '" + config.name + "')";
  meta.notes = options.notes;
  meta.agent = "sweepscan-sim (in-process)";
  meta.settings["scenario"] = ScenarioToJson(config);
  SessionWriterOptions writer_options;
  writer_options.overwrite = options.overwrite;
  std::unique_ptr<SessionWriter> writer;
  Status s = SessionWriter::Create(session_dir, meta, writer_options, &writer);
  if (!s.ok()) return s;

  SimDevices devices(config, SimDevices::Mode::kScripted);
  // A serial link (no authentication, as on a cable to the robot).
  AgentOptions agent_options;
  agent_options.name = meta.agent;
  agent_options.require_auth = false;
  AgentCore agent(agent_options);
  LinkEncoder client(LinkSender::kClient);
  LinkDecoderOptions decoder_options;
  decoder_options.keep_raw_frames = true;
  LinkDecoder workstation(decoder_options);

  // Robot time starts at 0; the world's path starts at SimWorld::kStartTimeS,
  // which leaves the agent time to query the lidar and start it scanning.
  Time now = TimeFromSeconds(0.0);
  const Time end = devices.world().end_time() + options.tail;
  // Workstation receive times are informational (docs/session-format.md):
  // a fixed epoch plus the robot time keeps the file deterministic.
  const int64_t epoch_ns = 1'790'000'000'000'000'000LL;

  AgentOutput out;
  std::vector<TimedBytes> chunks;
  std::vector<LinkMessage> messages;
  auto deliver = [&](Time t) -> Status {
    for (size_t d = 0; d < out.to_device.size(); ++d) {
      if (!out.to_device[d].empty()) {
        devices.WriteToDevice(static_cast<LinkDevice>(d + 1), out.to_device[d], t);
      }
    }
    if (!out.to_client.empty()) {
      messages.clear();
      workstation.Feed(out.to_client.data(), out.to_client.size(), &messages);
      for (const LinkMessage& m : messages) {
        Status st = writer->Append(m.raw, epoch_ns + ToNanoseconds(t));
        if (!st.ok()) return st;
        ++report->frames_recorded;
        report->bytes_recorded += m.raw.size();
        if (std::holds_alternative<Telemetry>(m.payload)) ++report->telemetry_frames;
      }
    }
    out.Clear();
    return Status::Ok();
  };

  agent.Start(now, &out);
  agent.OnClientConnected(now, &out);
  {
    std::vector<uint8_t> hello = client.Encode(now, Hello{kLinkProtocolVersion, false, "sweepscan-cli simulate", {}});
    std::vector<uint8_t> lidar_on = client.Encode(now, LidarMotor{true});
    hello.insert(hello.end(), lidar_on.begin(), lidar_on.end());
    agent.OnClientBytes(hello.data(), hello.size(), now, &out);
  }
  if (!(s = deliver(now)).ok()) return s;
  Time last_heartbeat = now;
  Time last_progress = now;
  while (now < end) {
    now += options.step;
    if (options.progress && now - last_progress >= std::chrono::seconds(1)) {
      options.progress(ToSeconds(now) / ToSeconds(end));
      last_progress = now;
    }
    chunks.clear();
    devices.AdvanceTo(now, &chunks);
    for (const TimedBytes& c : chunks) {
      agent.OnDeviceBytes(c.device, c.bytes.data(), c.bytes.size(), c.time, &out);
    }
    if (now - last_heartbeat >= std::chrono::milliseconds(100)) {
      const std::vector<uint8_t> hb = client.EncodeHeartbeat(now);
      agent.OnClientBytes(hb.data(), hb.size(), now, &out);
      last_heartbeat = now;
    }
    agent.Tick(now, &out);
    if (!(s = deliver(now)).ok()) return s;
  }
  report->link = workstation.stats();
  report->simulated_s = ToSeconds(now);
  return writer->Close();
}

}  // namespace sweepscan::hardware
