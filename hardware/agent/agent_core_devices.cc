// AgentCore, by concern: the devices (their bytes as Telemetry, the
// buffer across outages and the resume, port errors, what a port gets when
// it opens, the lidar's start-up requests and its idle stop). The rest of
// AgentCore is in agent_core.cc.
#include <algorithm>

#include "hardware/agent/agent_core.h"
#include "hardware/codecs/x4_codec.h"

namespace sweepscan {
namespace hardware {

void AgentCore::OnDeviceBytes(LinkDevice device, const uint8_t* data, size_t n, Time now,
                              AgentOutput* out) {
  const uint8_t id = static_cast<uint8_t>(device);
  if (id < 1 || id > 3 || n == 0) return;
  const size_t index = LinkDeviceIndex(device);
  device_bytes_[index] += n;
  have_device_bytes_[index] = true;
  last_device_bytes_[index] = now;
  if (device == LinkDevice::kMotorBoard) {
    // Only the battery voltage and stop flag matter here; the workstation
    // decodes the full feedback from the Telemetry.
    motor_feedback_.Feed(data, n, now);
    for (const MotorFeedback& feedback : motor_feedback_.TakeRecords()) {
      battery_v_ = static_cast<float>(feedback.voltage_v);
      motor_stop_flag_ = feedback.stop_flag != 0;
    }
  }
  const uint64_t serial = buffer_.Push(id, now, data, n, now);
  // No telemetry before auth; held ones wait in the buffer.
  if (!client_connected_ || !authenticated_ || closing_ || telemetry_held_) return;
  if (telemetry_paused_) {
    pending_break_[index] = true;
    ++counters_.telemetry_chunks_dropped;
    return;
  }
  TelemetryBuffer::Piece piece;
  piece.serial = serial;
  piece.device = id;
  piece.receive_time = now;
  piece.data = data;
  piece.size = n;
  SendTelemetryPiece(now, piece, out);
}

void AgentCore::SendTelemetryPiece(Time now, const TelemetryBuffer::Piece& piece,
                                   AgentOutput* out) {
  uint8_t flags = piece.flags;
  if (pending_break_[piece.device - 1]) {
    flags |= kTelemetryBreak;
    pending_break_[piece.device - 1] = false;
  }
  const std::vector<uint8_t> frames =
      encoder_.EncodeTelemetry(now, static_cast<LinkDevice>(piece.device), piece.receive_time,
                               piece.data, piece.size, flags);
  out->to_client.insert(out->to_client.end(), frames.begin(), frames.end());
  ++counters_.telemetry_frames_sent;
}

// A new client (a connection, or a serial client's Hello) gets each
// device's first chunk marked as a break unless its TelemetryResume joins
// what it is sent to what it holds (ReleaseTelemetry). Without a resume
// (no buffer, an older client, or a resume that came after resume_wait)
// the bytes read while the link was down never reach it, and the break is
// what tells its decoder to restart and its recording that they are lost:
// unmarked, a late resume lost the outage's data and the session said
// "no data lost". On a fresh client's first bytes a break costs nothing.
void AgentCore::HoldTelemetry(Time now) {
  pending_break_.fill(true);
  if (!buffer_.enabled()) return;  // No buffer: live from the start, as before.
  telemetry_held_ = true;
  held_from_serial_ = buffer_.next_serial();
  held_since_ = now;
}

void AgentCore::ReleaseTelemetry(const TelemetryResume* resume, Time now, AgentOutput* out) {
  telemetry_held_ = false;
  buffer_.Evict(now);
  if (resume == nullptr) {
    buffer_.CollectFrom(held_from_serial_, [&](const TelemetryBuffer::Piece& piece) {
      SendTelemetryPiece(now, piece, out);
    });
    return;
  }
  ++counters_.resumes;
  for (uint8_t d = 1; d <= 3; ++d) {
    if (resume->devices[d - 1].have && buffer_.LostAfter(d, resume->devices[d - 1])) {
      ++counters_.resume_breaks;
    }
  }
  // The resume says what the client holds: the breaks are CollectAfter's.
  pending_break_.fill(false);
  std::array<bool, 3> breaks{};
  buffer_.CollectAfter(*resume, held_from_serial_,
                       [&](const TelemetryBuffer::Piece& piece) {
                         if (piece.serial < held_from_serial_) {
                           ++counters_.chunks_resent;
                           counters_.bytes_resent += piece.size;
                         }
                         SendTelemetryPiece(now, piece, out);
                       },
                       &breaks);
  // A device with lost bytes but nothing kept: its next live chunk says so.
  for (int d = 0; d < 3; ++d) pending_break_[d] = breaks[d];
}

void AgentCore::SetDevicePortError(LinkDevice device, bool error, Time now, AgentOutput* out) {
  const uint8_t id = static_cast<uint8_t>(device);
  if (id < 1 || id > 3) return;
  const size_t index = LinkDeviceIndex(device);
  if (port_error_[index] == error) return;
  port_error_[index] = error;
  if (client_authenticated()) SendStatus(now, out);
}

void AgentCore::OnDevicePortOpened(LinkDevice device, Time now, AgentOutput* out) {
  if (device == LinkDevice::kMotorBoard && started_) SendMotorCommand(now, out);
  if (device == LinkDevice::kLidar) {
    out->lidar_dtr = lidar_motor_on_;
    // The start-up sequence went to a port that was not open (the X4
    // plugged in later) or to the X4 that was unplugged: this one has had
    // none. Start()'s own, still in the output, reaches it.
    if (started_ && !lidar_startup_in_output_) BeginLidarStartup(now, out);
  }
}

void AgentCore::BeginLidarStartup(Time now, AgentOutput* out) {
  // The lidar may still be scanning (a previous run of the agent, or an X4
  // that kept power): stop it, so that its replies to the requests are not
  // buried in scan packets.
  auto& lidar = out->to_device[LinkDeviceIndex(LinkDevice::kLidar)];
  const auto stop = EncodeX4Command(kX4CmdStop);
  lidar.insert(lidar.end(), stop.begin(), stop.end());
  lidar_startup_at_ = now;
  lidar_requests_sent_ = 0;
  lidar_scan_after_startup_ = lidar_motor_on_;
}

void AgentCore::TickLidar(Time now, AgentOutput* out) {
  if (!started_) return;
  auto& lidar = out->to_device[LinkDeviceIndex(LinkDevice::kLidar)];
  // Start-up requests, one at a time: the X4 answers one request at a time.
  if (lidar_requests_sent_ < 2 &&
      now - lidar_startup_at_ >= options_.lidar_request_spacing * (lidar_requests_sent_ + 1)) {
    const auto request =
        EncodeX4Command(lidar_requests_sent_ == 0 ? kX4CmdDeviceInfo : kX4CmdHealth);
    lidar.insert(lidar.end(), request.begin(), request.end());
    ++lidar_requests_sent_;
  }
  if (lidar_scan_after_startup_ && lidar_requests_sent_ == 2 &&
      now - lidar_startup_at_ >= options_.lidar_request_spacing * 3) {
    lidar_scan_after_startup_ = false;
    if (lidar_motor_on_) {
      const auto scan = EncodeX4Command(kX4CmdScan);
      lidar.insert(lidar.end(), scan.begin(), scan.end());
    }
  }
  // Nobody has asked for anything for lidar_idle_off: the workstation left
  // (or its link is half-open). last_client_frame_ is the last valid frame
  // of an authenticated client, and the motor only turns on at one's word.
  if (lidar_motor_on_ && options_.lidar_idle_off > Duration::zero() &&
      now - last_client_frame_ >= options_.lidar_idle_off) {
    lidar_motor_on_ = false;
    lidar_scan_after_startup_ = false;
    out->lidar_dtr = false;
    const auto stop = EncodeX4Command(kX4CmdStop);
    lidar.insert(lidar.end(), stop.begin(), stop.end());
    ++counters_.lidar_idle_stops;
    out->log.push_back("no client for " +
                       std::to_string(std::chrono::duration_cast<std::chrono::seconds>(
                                          options_.lidar_idle_off)
                                          .count()) +
                       " s: lidar motor off (a client's LidarMotor turns it on again)");
    SendStatus(now, out);  // A silent client still connected hears of it.
  }
}

}  // namespace hardware
}  // namespace sweepscan
