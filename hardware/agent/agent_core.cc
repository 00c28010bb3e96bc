#include "hardware/agent/agent_core.h"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <variant>

#include "hardware/codecs/x4_codec.h"

namespace sweepscan {
namespace hardware {
namespace {

double Clamp(double x, double limit) { return std::max(-limit, std::min(limit, x)); }

// Moves `value` toward `target` by at most `step` (step >= 0).
double StepToward(double value, double target, double step) {
  if (value < target) return std::min(target, value + step);
  if (value > target) return std::max(target, value - step);
  return value;
}

bool PositiveFinite(double x) { return std::isfinite(x) && x > 0.0; }

LinkDecoderOptions ClientDecoderOptions(const AgentOptions& options) {
  LinkDecoderOptions decoder_options;
  decoder_options.max_payload = options.max_client_payload;
  decoder_options.max_work_per_feed = options.max_client_work_per_call;
  return decoder_options;
}

void Append(const std::vector<uint8_t>& bytes, std::vector<uint8_t>* out) {
  out->insert(out->end(), bytes.begin(), bytes.end());
}

std::string OldVersionReason(uint8_t version) {
  return "protocol version " + std::to_string(version) +
         " is not supported: this agent speaks version " +
         std::to_string(kLinkProtocolVersion) + "; update the workstation";
}

}  // namespace

std::vector<uint8_t> EncodeOldVersionRefusal(Time now, uint8_t version, const std::string& reason) {
  std::vector<uint8_t> body;
  EncodeLinkPayload(AuthResult{AuthOutcome::kDenied, reason}, &body);
  std::vector<uint8_t> out;
  AppendRawLinkFrame(LinkSender::kAgent, 0, now, static_cast<uint8_t>(LinkMessageType::kAuthResult),
                     body.data(), body.size(), &out, nullptr, version);
  return out;
}

// ---------------------------------------------------------------------------
// AgentHandshake

AgentHandshake::AgentHandshake(const AgentOptions& options, Time now, std::vector<uint8_t>* out)
    : options_(options), decoder_(ClientDecoderOptions(options)), connected_at_(now) {
  Hello hello;
  hello.auth_required = true;
  hello.name = options_.name;
  hello.devices = options_.devices;
  Append(encoder_.Encode(now, hello), out);
  const auto& source = options_.random_source;
  const bool nonce_ok =
      source ? source(nonce_.data(), nonce_.size()) : FillRandomBytes(nonce_.data(), nonce_.size());
  if (!nonce_ok) {
    // Never fall back to a guessable nonce: a replayed response would pass.
    Deny(now, "agent has no random source", out);
    return;
  }
  AuthChallenge challenge;
  challenge.nonce = nonce_;
  Append(encoder_.Encode(now, challenge), out);
}

void AgentHandshake::Deny(Time now, const std::string& reason, std::vector<uint8_t>* out,
                          uint8_t version) {
  state_ = State::kDenied;
  denial_ = reason;
  if (version == kLinkProtocolVersion) {
    Append(encoder_.Encode(now, AuthResult{AuthOutcome::kDenied, reason}), out);
  } else {
    Append(EncodeOldVersionRefusal(now, version, reason), out);
  }
}

AgentHandshake::State AgentHandshake::OnBytes(const uint8_t* data, size_t n, Time now,
                                              std::vector<uint8_t>* out) {
  if (state_ != State::kPending) return state_;
  std::vector<LinkMessage> messages;
  decoder_.Feed(data, n, &messages);
  for (size_t i = 0; i < messages.size(); ++i) {
    const LinkMessage& m = messages[i];
    if (m.header.sender != LinkSender::kClient) continue;
    if (m.header.version < kLinkProtocolVersion) {
      Deny(now, OldVersionReason(m.header.version), out, m.header.version);
      return state_;
    }
    if (const auto* hello = std::get_if<Hello>(&m.payload)) {
      client_name_ = hello->name;
      if (hello->protocol_version < kLinkProtocolVersion) {
        Deny(now, OldVersionReason(static_cast<uint8_t>(hello->protocol_version)), out);
        return state_;
      }
    } else if (const auto* response = std::get_if<AuthResponse>(&m.payload)) {
      const Sha256Digest expected = LinkAuthMac(options_.key, nonce_, response->client_nonce);
      if (!ConstantTimeEqual(expected.data(), response->mac.data(), kLinkMacSize)) {
        auth_failure_ = true;
        Deny(now, "authentication failed", out);
        return state_;
      }
      session_key_ = LinkDeriveSessionKey(options_.key, nonce_, response->client_nonce);
      last_client_sequence_ = m.header.sequence;
      state_ = State::kAuthenticated;
      pending_.assign(std::make_move_iterator(messages.begin() + static_cast<std::ptrdiff_t>(i) + 1),
                      std::make_move_iterator(messages.end()));
      return state_;
    } else if (std::holds_alternative<EmergencyStop>(m.payload)) {
      estop_ = true;  // Stopping is always allowed; no ack before authentication.
    }
    // Anything else before authentication: no effect and no answer.
  }
  if (decoder_.BufferedBytes() > options_.max_client_backlog) Deny(now, "input flood", out);
  return state_;
}

AgentHandshake::State AgentHandshake::Tick(Time now, std::vector<uint8_t>* out) {
  if (state_ == State::kPending && now - connected_at_ >= options_.auth_timeout) {
    Deny(now, "authentication timeout", out);
  }
  return state_;
}

// ---------------------------------------------------------------------------
// AgentCore

bool AgentOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (require_auth && key.empty()) return fail("authentication required but the key is empty");
  if (name.size() > kLinkMaxStringSize) return fail("name longer than 255 bytes");
  if (watchdog < kAgentMinWatchdog || watchdog > kAgentMaxWatchdog) {
    return fail("watchdog period must be within 100..5000 ms");
  }
  if (stale_drive_after <= Duration::zero()) return fail("stale_drive_after must be positive");
  if (!PositiveFinite(v_max_mps)) return fail("v_max must be positive and finite");
  if (!PositiveFinite(w_max_radps)) return fail("w_max must be positive and finite");
  if (!PositiveFinite(accel_max_mps2)) return fail("accel_max must be positive and finite");
  if (!PositiveFinite(alpha_max_radps2)) return fail("alpha_max must be positive and finite");
  // The motor board's wire format saturates at 32.767 m/s and rad/s.
  if (v_max_mps > 32.0 || w_max_radps > 32.0)
    return fail("v_max / w_max beyond the motor board's range");
  if (motor_period <= Duration::zero()) return fail("motor period must be positive");
  if (motor_period >= watchdog) {
    return fail("motor period must be shorter than the watchdog period");
  }
  if (status_period <= Duration::zero()) return fail("status period must be positive");
  if (device_silent_after <= Duration::zero()) return fail("device silence limit must be positive");
  if (auth_timeout <= Duration::zero()) return fail("auth timeout must be positive");
  if (!std::isfinite(low_battery_v) || low_battery_v < 0.0) {
    return fail("low battery threshold must be >= 0");
  }
  if (lidar_request_spacing < Duration::zero()) return fail("lidar request spacing must be >= 0");
  if (telemetry_buffer < Duration::zero() || telemetry_buffer > std::chrono::seconds(60)) {
    return fail("telemetry buffer must be within 0..60 s");
  }
  if (resume_wait <= Duration::zero()) return fail("resume wait must be positive");
  if (lidar_idle_off < Duration::zero() ||
      (lidar_idle_off > Duration::zero() && lidar_idle_off < telemetry_buffer + resume_wait)) {
    return fail("lidar idle time must be 0 (never) or at least the telemetry buffer's time plus "
                "the resume wait (a returning client's resend needs the lidar's bytes)");
  }
  if (max_client_payload < kLinkNonceSize + kLinkMacSize || max_client_payload > kLinkMaxPayload) {
    return fail("max client payload must be within [64, 65536]");
  }
  if (max_client_backlog < 2 * (max_client_payload + kLinkMaxFrameSize - kLinkMaxPayload)) {
    return fail("max client backlog must hold two client frames");
  }
  return true;
}

void AgentOutput::Clear() {
  to_client.clear();
  for (auto& bytes : to_device) bytes.clear();
  lidar_dtr.reset();
  close_client = false;
  close_reason.clear();
  auth_failure = false;
  log.clear();
}

AgentCore::AgentCore(const AgentOptions& options)
    : options_(options),
      decoder_(ClientDecoderOptions(options)),
      buffer_(options.telemetry_buffer, options.telemetry_buffer_max_bytes, Time()) {}

void AgentCore::Start(Time now, AgentOutput* out) {
  if (started_) return;
  started_ = true;
  start_time_ = now;
  // Nothing read before now was kept: a resume from before it is a break.
  buffer_ = TelemetryBuffer(options_.telemetry_buffer, options_.telemetry_buffer_max_bytes, now);
  BeginLidarStartup(now, out);
  out->lidar_dtr = false;  // Its motor off until a client asks for it.
  // A zero command so a board that kept the last velocity of a crashed agent stops.
  SendMotorCommand(now, out);
  Tick(now, out);
  lidar_startup_in_output_ = true;
}

void AgentCore::OnClientConnected(Time now, AgentOutput* out) {
  ++counters_.connections;
  client_connected_ = true;
  closing_ = false;
  authenticated_ = !options_.require_auth;
  frame_auth_ = false;
  auth_attempted_ = false;
  client_name_.clear();
  connected_at_ = now;
  last_client_frame_ = now;
  have_transit_ = false;
  have_late_read_ = false;
  decoder_ = LinkDecoder(ClientDecoderOptions(options_));
  encoder_ = LinkEncoder(LinkSender::kAgent);  // Each connection numbers from 0.
  have_status_time_ = false;
  handshake_.reset();
  if (options_.require_auth) {
    handshake_ = std::make_unique<AgentHandshake>(options_, now, &out->to_client);
    HandleHandshakeState(handshake_->state(), now, out);
    return;
  }
  HoldTelemetry(now);
  SendGreeting(now, out);
}

bool AgentCore::AdoptClient(AgentHandshake* handshake, Time now, AgentOutput* out) {
  if (client_connected_ || handshake->state() != AgentHandshake::State::kAuthenticated) {
    return false;
  }
  ++counters_.connections;
  client_connected_ = true;
  closing_ = false;
  authenticated_ = true;
  auth_attempted_ = true;
  frame_auth_ = true;
  session_key_ = handshake->session_key();
  last_client_sequence_ = handshake->last_client_sequence();
  client_name_ = handshake->client_name();
  connected_at_ = now;
  last_client_frame_ = now;
  have_transit_ = false;
  have_late_read_ = false;
  decoder_ = std::move(handshake->decoder());
  encoder_ = LinkEncoder(LinkSender::kAgent, handshake->next_agent_sequence());
  have_status_time_ = false;
  ++counters_.auth_ok;
  Send(now, AuthResult{AuthOutcome::kOk, ""}, out);
  SendStatus(now, out);
  HoldTelemetry(now);
  std::vector<LinkMessage> pending = std::move(handshake->pending_messages());
  for (const LinkMessage& message : pending) {
    if (closing_) break;
    HandleMessage(message, now, out);
  }
  return true;
}

void AgentCore::NoteDeniedHandshake(const AgentHandshake& handshake) {
  ++counters_.auth_denied;
  if (handshake.denial().rfind("protocol version", 0) == 0) ++counters_.old_protocol_refused;
  if (handshake.denial() == "input flood") ++counters_.input_floods;
}

void AgentCore::HandleHandshakeState(AgentHandshake::State state, Time now, AgentOutput* out) {
  if (handshake_ == nullptr) return;
  if (handshake_->TakeEmergencyStop()) EmergencyStopFromUnauthenticated(now, out);
  if (state == AgentHandshake::State::kDenied) {
    NoteDeniedHandshake(*handshake_);
    closing_ = true;
    out->close_client = true;
    out->close_reason = handshake_->denial();
    out->auth_failure = handshake_->auth_failure();
    handshake_.reset();
  } else if (state == AgentHandshake::State::kAuthenticated) {
    std::unique_ptr<AgentHandshake> done = std::move(handshake_);
    client_connected_ = false;  // AdoptClient takes the slot ...
    --counters_.connections;    // ... and counts it (OnClientConnected did already).
    AdoptClient(done.get(), now, out);
  }
}

void AgentCore::EmergencyStopFromUnauthenticated(Time now, AgentOutput* out) {
  const bool was_latched = estop_latched_;
  estop_latched_ = true;
  HardStop(now, out);
  if (watchdog_ == WatchdogState::kArmed) watchdog_ = WatchdogState::kIdle;
  if (!was_latched && client_authenticated()) SendStatus(now, out);
}

bool AgentCore::client_work_pending() const {
  if (!client_connected_ || closing_) return false;
  return handshake_ != nullptr ? handshake_->work_pending() : decoder_.work_pending();
}

void AgentCore::SendGreeting(Time now, AgentOutput* out) {
  // Only without authentication (serial links); AgentHandshake greets otherwise.
  Hello hello;
  hello.auth_required = options_.require_auth;
  hello.name = options_.name;
  hello.devices = options_.devices;
  Send(now, hello, out);
  SendStatus(now, out);
}

void AgentCore::OnClientDisconnected(Time now, AgentOutput* out) {
  if (!client_connected_) return;
  client_connected_ = false;
  closing_ = false;
  const bool was_authenticated = authenticated_;
  authenticated_ = false;
  frame_auth_ = false;
  telemetry_held_ = false;
  handshake_.reset();
  decoder_.Reset();
  // A dropped connection trips the watchdog at once (docs/protocol.md).
  if (was_authenticated && MotionCommanded()) {
    ++watchdog_trips_;
    last_trip_ = now;
    stale_drive_logged_ = false;
    on_time_since_trip_ = false;
    watchdog_ = WatchdogState::kTripped;
    HardStop(now, out);
  }
}

void AgentCore::OnClientBytes(const uint8_t* data, size_t n, Time now, AgentOutput* out) {
  if (!client_connected_ || closing_) return;
  if (handshake_ != nullptr) {
    HandleHandshakeState(handshake_->OnBytes(data, n, now, &out->to_client), now, out);
    return;
  }
  std::vector<LinkMessage> messages;
  decoder_.Feed(data, n, &messages);
  for (const LinkMessage& message : messages) {
    if (closing_) break;
    HandleMessage(message, now, out);
  }
  if (!closing_ && decoder_.BufferedBytes() > options_.max_client_backlog) {
    ++counters_.input_floods;
    closing_ = true;
    out->close_client = true;
    out->close_reason = "input flood";
  }
}

bool AgentCore::FrameAuthentic(const LinkMessage& message) {
  if (!message.header.signed_frame) {
    ++counters_.frames_unsigned;
    return false;
  }
  if (!LinkFrameTagValid(session_key_, message)) {
    ++counters_.frames_bad_tag;
    return false;
  }
  // Strictly after the last accepted frame (mod 2^32, within half the range).
  const uint32_t delta = message.header.sequence - last_client_sequence_;
  if (delta == 0 || delta >= 0x80000000u) {
    ++counters_.frames_replayed;
    return false;
  }
  last_client_sequence_ = message.header.sequence;
  return true;
}

void AgentCore::HandleMessage(const LinkMessage& message, Time now, AgentOutput* out) {
  if (message.header.sender != LinkSender::kClient) {
    // Our own frames echoed back (a serial loop) or a confused peer.
    ++counters_.client_frames_from_wrong_sender;
    return;
  }
  if (message.header.version < kLinkProtocolVersion) {
    // An old client (serial links; TCP ones meet AgentHandshake first).
    ++counters_.old_protocol_refused;
    const auto refusal = EncodeOldVersionRefusal(now, message.header.version,
                                                 OldVersionReason(message.header.version));
    out->to_client.insert(out->to_client.end(), refusal.begin(), refusal.end());
    closing_ = true;
    out->close_client = true;
    out->close_reason = "old protocol version";
    return;
  }
  if (frame_auth_ && !FrameAuthentic(message)) {
    // Injected, replayed, reordered or unsigned: no effect, does not feed the
    // watchdog. Only stopping is allowed without a valid tag (no ack).
    if (std::holds_alternative<EmergencyStop>(message.payload)) {
      EmergencyStopFromUnauthenticated(now, out);
    }
    return;
  }
  ++frames_received_;
  if (authenticated_) last_client_frame_ = now;  // Any valid frame feeds the watchdog.
  const Duration late = NoteClientTransit(now, message.header.time);
  if (late > options_.stale_drive_after) {
    have_late_read_ = true;
    late_read_time_ = now;
  }
  // The same read as a late frame: the rest of a stall's burst, sent before
  // the client could know of a trip, however little late itself.
  const bool held =
      late > options_.stale_drive_after || (have_late_read_ && late_read_time_ == now);
  if (!held) on_time_since_trip_ = true;

  const LinkPayload& payload = message.payload;
  if (const auto* hello = std::get_if<Hello>(&payload)) {
    client_name_ = hello->name;
    if (hello->protocol_version < kLinkProtocolVersion) {
      Deny(now, OldVersionReason(static_cast<uint8_t>(hello->protocol_version)), out);
      return;
    }
    // Serial: the client may have opened the port after our Hello; say it
    // again. A Hello on a serial line is a client (re)starting: what was
    // sent while it was away (a radio link down) went nowhere, so hold
    // telemetry for its TelemetryResume as a new connection does.
    if (options_.hello_on_client_hello) {
      have_transit_ = false;  // Maybe another client, on another clock.
      SendGreeting(now, out);
      if (authenticated_) HoldTelemetry(now);
    }
    return;
  }
  if (const auto* response = std::get_if<AuthResponse>(&payload)) {
    HandleAuthResponse(*response, now, out);
    return;
  }

  const uint8_t type = message.header.type;
  const bool is_command =
      std::holds_alternative<DriveCommand>(payload) || std::holds_alternative<Stop>(payload) ||
      std::holds_alternative<EmergencyStop>(payload) ||
      std::holds_alternative<ClearEmergencyStop>(payload) ||
      std::holds_alternative<Heartbeat>(payload) || std::holds_alternative<LidarMotor>(payload) ||
      std::holds_alternative<TelemetryResume>(payload);
  if (!is_command) return;  // Agent-to-client types and unknown types: ignored.

  // Stopping is always allowed; nothing else before authentication (and
  // no answer: an unauthenticated peer gets nothing beyond the challenge).
  if (!authenticated_) {
    if (type == static_cast<uint8_t>(LinkMessageType::kEmergencyStop)) {
      EmergencyStopFromUnauthenticated(now, out);
    }
    return;
  }

  if (const auto* resume = std::get_if<TelemetryResume>(&payload)) {
    if (!telemetry_held_) {
      // Buffering off, or asked twice: live telemetry is already flowing.
      Ack(now, message, AckResult::kUnsupported, out);
      return;
    }
    ReleaseTelemetry(resume, now, out);
    Ack(now, message, AckResult::kAccepted, out);
    return;
  }
  // An emergency stop does not end the wait for the resume: one pressed as
  // the link came back (while authenticating) would otherwise take the
  // resume's place, and the outage's bytes be lost.
  if (telemetry_held_ && !std::holds_alternative<EmergencyStop>(payload)) {
    ReleaseTelemetry(nullptr, now, out);
  }

  if (const auto* drive = std::get_if<DriveCommand>(&payload)) {
    if (estop_latched_) {
      Ack(now, message, AckResult::kEmergencyStopLatched, out);
      return;
    }
    if (watchdog_ == WatchdogState::kTripped && held && !on_time_since_trip_) {
      // Held by the stall that tripped the watchdog: the robot stays stopped
      // until a drive the link delivers on time (the client's next one).
      // Once a frame has come on time, the stall is over: a drive delayed
      // later (at rest, tripped long ago) is judged as from rest.
      ++counters_.stale_drives;
      if (!stale_drive_logged_) {
        stale_drive_logged_ = true;
        out->log.push_back(
            "drive command delivered " +
            std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(late).count()) +
            " ms late after the watchdog trip (a stalled link): not applied");
      }
      Ack(now, message, AckResult::kInvalid, out);
      return;
    }
    if (!MotionCommanded()) {
      // From rest the ramp starts now, not at the last tick.
      have_ramp_time_ = true;
      last_ramp_time_ = now;
    }
    commanded_v_ = Clamp(drive->v_mps, options_.v_max_mps);
    commanded_w_ = Clamp(drive->w_radps, options_.w_max_radps);
    const WatchdogState before = watchdog_;
    watchdog_ = WatchdogState::kIdle;  // A Drive re-arms a tripped watchdog.
    UpdateWatchdogArming();
    if (motor_zero_sent_) have_motor_send_ = false;  // Starting from rest: send at the next tick.
    Ack(now, message, AckResult::kAccepted, out);
    if (watchdog_ != before) SendStatus(now, out);
  } else if (std::holds_alternative<Stop>(payload)) {
    commanded_v_ = 0.0;
    commanded_w_ = 0.0;
    Ack(now, message, AckResult::kAccepted, out);
  } else if (std::holds_alternative<EmergencyStop>(payload)) {
    const bool was_latched = estop_latched_;
    estop_latched_ = true;
    HardStop(now, out);
    if (watchdog_ == WatchdogState::kArmed) watchdog_ = WatchdogState::kIdle;
    Ack(now, message, AckResult::kAccepted, out);
    if (!was_latched && authenticated_) SendStatus(now, out);
  } else if (std::holds_alternative<ClearEmergencyStop>(payload)) {
    const bool was_latched = estop_latched_;
    estop_latched_ = false;
    commanded_v_ = 0.0;  // Still until the next Drive.
    commanded_w_ = 0.0;
    Ack(now, message, AckResult::kAccepted, out);
    if (was_latched) SendStatus(now, out);
  } else if (std::holds_alternative<Heartbeat>(payload)) {
    Ack(now, message, AckResult::kAccepted, out);
  } else if (const auto* lidar = std::get_if<LidarMotor>(&payload)) {
    // The motor (DTR) and the scan (A5 60 / A5 65) together; the DTR line
    // is set before the bytes are written, so the motor spins up first.
    auto& bytes = out->to_device[LinkDeviceIndex(LinkDevice::kLidar)];
    const auto command = EncodeX4Command(lidar->on ? kX4CmdScan : kX4CmdStop);
    bytes.insert(bytes.end(), command.begin(), command.end());
    out->lidar_dtr = lidar->on;
    if (lidar->on && !lidar_motor_on_) lidar_motor_on_since_ = now;
    lidar_motor_on_ = lidar->on;
    lidar_scan_after_startup_ = false;  // Said now.
    Ack(now, message, AckResult::kAccepted, out);
  }
}

void AgentCore::HandleAuthResponse(const AuthResponse&, Time now, AgentOutput* out) {
  if (!options_.require_auth) {
    // Nothing to check on an open link; tell the client it may proceed.
    Send(now, AuthResult{AuthOutcome::kOk, "authentication not required"}, out);
    return;
  }
  // Authentication is AgentHandshake's; a second response is refused.
  Deny(now, "one attempt per connection", out);
}

void AgentCore::Deny(Time now, const std::string& reason, AgentOutput* out) {
  ++counters_.auth_denied;
  authenticated_ = false;
  Send(now, AuthResult{AuthOutcome::kDenied, reason}, out);
  closing_ = true;
  out->close_client = true;
  out->close_reason = reason;
}

void AgentCore::Tick(Time now, AgentOutput* out) {
  lidar_startup_in_output_ = false;
  TickLidar(now, out);

  if (client_connected_ && !closing_ && handshake_ != nullptr) {
    HandleHandshakeState(handshake_->Tick(now, &out->to_client), now, out);
  }
  // A client that never asks (an older workstation): live after resume_wait,
  // or half the buffer's time if shorter (held bytes wait in the buffer).
  if (telemetry_held_ && client_authenticated() && !closing_ &&
      now - held_since_ >= std::min(options_.resume_wait, options_.telemetry_buffer / 2)) {
    ReleaseTelemetry(nullptr, now, out);
  }

  // Watchdog first, so a quiet link never gets one more ramp step.
  if (watchdog_ == WatchdogState::kArmed && now - last_client_frame_ >= options_.watchdog) {
    ++watchdog_trips_;
    last_trip_ = now;
    stale_drive_logged_ = false;
    on_time_since_trip_ = false;
    watchdog_ = WatchdogState::kTripped;
    HardStop(now, out);
    if (client_authenticated()) SendStatus(now, out);
  }

  UpdateRamp(now);
  const bool moving = MotionCommanded();
  if (moving) {
    if (!have_motor_send_ || now - last_motor_send_ >= options_.motor_period) {
      SendMotorCommand(now, out);
    }
  } else if (!motor_zero_sent_) {
    SendMotorCommand(now, out);  // The ramp reached zero: say so once.
  }
  const WatchdogState before = watchdog_;
  UpdateWatchdogArming();
  if (before != watchdog_ && client_authenticated()) SendStatus(now, out);

  if (client_authenticated() && !closing_ &&
      (!have_status_time_ || now - last_status_ >= options_.status_period)) {
    SendStatus(now, out);
  }
}

bool AgentCore::MotionCommanded() const {
  return commanded_v_ != 0.0 || commanded_w_ != 0.0 || applied_v_ != 0.0 || applied_w_ != 0.0;
}

Duration AgentCore::NoteClientTransit(Time now, Time sent) {
  // The two clocks are unrelated, so a transit is the offset between them
  // plus the delay; the least one is the offset plus the fastest delay, and
  // the excess over it is how long the link held the frame. Windows of 5 s,
  // so that the clocks' drift (1e-4 s/s at worst) and a lasting change of
  // route do not accumulate.
  constexpr Duration kWindow = std::chrono::seconds(5);
  // Saturated: the sender's time is whatever the client put there.
  const auto minus = [](Duration a, Duration b) {
    Duration::rep ns = 0;
    if (!__builtin_sub_overflow(a.count(), b.count(), &ns)) return Duration(ns);
    return b < a ? Duration::max() : Duration::min();
  };
  const Duration transit = minus(now.time_since_epoch(), sent.time_since_epoch());
  if (!have_transit_ || now - transit_window_start_ >= kWindow) {
    least_transit_before_ = have_transit_ && now - transit_window_start_ < 2 * kWindow
                                ? least_transit_now_
                                : Duration::max();
    least_transit_now_ = Duration::max();
    transit_window_start_ = now;
    have_transit_ = true;
  }
  least_transit_now_ = std::min(least_transit_now_, transit);
  return minus(transit, std::min(least_transit_now_, least_transit_before_));
}

void AgentCore::UpdateWatchdogArming() {
  if (watchdog_ == WatchdogState::kTripped) return;  // Until the next Drive.
  watchdog_ = MotionCommanded() ? WatchdogState::kArmed : WatchdogState::kIdle;
}

void AgentCore::UpdateRamp(Time now) {
  if (!have_ramp_time_) {
    have_ramp_time_ = true;
    last_ramp_time_ = now;
    return;
  }
  const double dt = std::max(0.0, ToSeconds(now - last_ramp_time_));
  last_ramp_time_ = now;
  applied_v_ = StepToward(applied_v_, commanded_v_, options_.accel_max_mps2 * dt);
  applied_w_ = StepToward(applied_w_, commanded_w_, options_.alpha_max_radps2 * dt);
}

void AgentCore::HardStop(Time now, AgentOutput* out) {
  commanded_v_ = commanded_w_ = 0.0;
  applied_v_ = applied_w_ = 0.0;
  SendMotorCommand(now, out);
}

void AgentCore::SendMotorCommand(Time now, AgentOutput* out) {
  MotorCommand command;
  command.vx_mps = applied_v_;
  command.wz_radps = applied_w_;
  const auto bytes = EncodeMotorCommand(command);
  auto& motor = out->to_device[LinkDeviceIndex(LinkDevice::kMotorBoard)];
  motor.insert(motor.end(), bytes.begin(), bytes.end());
  motor_zero_sent_ = applied_v_ == 0.0 && applied_w_ == 0.0;
  have_motor_send_ = true;
  last_motor_send_ = now;
  ++counters_.motor_commands_sent;
}

void AgentCore::Send(Time now, const LinkPayload& payload, AgentOutput* out) {
  const std::vector<uint8_t> frame = encoder_.Encode(now, payload);
  out->to_client.insert(out->to_client.end(), frame.begin(), frame.end());
}

void AgentCore::Ack(Time now, const LinkMessage& message, AckResult result, AgentOutput* out) {
  if (result != AckResult::kAccepted) ++commands_refused_;
  CommandAck ack;
  ack.acked_sequence = message.header.sequence;
  ack.acked_type = message.header.type;
  ack.result = result;
  ack.echo_time = message.header.time;
  Send(now, ack, out);
}

void AgentCore::SendStatus(Time now, AgentOutput* out) {
  if (!client_connected_ || !authenticated_ || closing_) return;  // Nothing before auth.
  Send(now, status(now), out);
  have_status_time_ = true;
  last_status_ = now;
  ++counters_.status_frames_sent;
}

LinkStatus AgentCore::status(Time now) const {
  LinkStatus s;
  s.battery_voltage_v = battery_v_;
  auto silent = [&](LinkDevice device) {
    const size_t i = LinkDeviceIndex(device);
    const Time since = have_device_bytes_[i] ? last_device_bytes_[i] : start_time_;
    return started_ && now - since > options_.device_silent_after;
  };
  if (lidar_motor_on_ && now - lidar_motor_on_since_ > options_.device_silent_after &&
      silent(LinkDevice::kLidar)) {
    s.fault_bits |= kFaultLidarSilent;
  }
  if (silent(LinkDevice::kImu)) s.fault_bits |= kFaultImuSilent;
  if (silent(LinkDevice::kMotorBoard)) s.fault_bits |= kFaultMotorBoardSilent;
  if (options_.low_battery_v > 0.0 && have_device_bytes_[2] &&
      battery_v_ < options_.low_battery_v) {
    s.fault_bits |= kFaultLowBattery;
  }
  if (motor_stop_flag_) s.fault_bits |= kFaultMotorBoardStop;
  if (port_error_[0] || port_error_[1] || port_error_[2]) s.fault_bits |= kFaultDevicePortError;
  s.watchdog = watchdog_;
  s.emergency_stop_latched = estop_latched_;
  s.client_authenticated = client_connected_ && authenticated_;
  s.lidar_motor_on = lidar_motor_on_;
  s.commanded_v_mps = commanded_v_;
  s.commanded_w_radps = commanded_w_;
  s.applied_v_mps = applied_v_;
  s.applied_w_radps = applied_w_;
  s.frames_received = frames_received_;
  const DecoderStats& codec = decoder_.stats().codec;
  s.frames_rejected =
      static_cast<uint32_t>(codec.checksum_errors + codec.length_errors + codec.framing_errors);
  s.commands_refused = commands_refused_;
  s.watchdog_trips = watchdog_trips_;
  s.device_bytes = device_bytes_;
  return s;
}

}  // namespace hardware
}  // namespace sweepscan
