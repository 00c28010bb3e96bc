// Message payloads of the robot link: encoding and strict parsing, one
// message family at a time (docs/protocol.md, "Message types"). Frames
// (header, CRCs, tags) and the stream decoder are in link_protocol.cc.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {
namespace {

constexpr size_t kCommandAckSize = 16;
constexpr size_t kStatusSize = 84;
constexpr size_t kDriveSize = 16;
constexpr size_t kResumeSize = 48;
constexpr size_t kRecorderEventFixedSize = 52;  // Before the reason string.

void AppendString(const std::string& s, std::vector<uint8_t>* out) {
  const size_t n = std::min(s.size(), kLinkMaxStringSize);
  out->push_back(static_cast<uint8_t>(n));
  out->insert(out->end(), s.begin(), s.begin() + static_cast<std::ptrdiff_t>(n));
}


// Bounds-checked reader over one payload: every Read*() checks the remaining
// size first and latches a failure, so parsers read fields unconditionally and
// check ok() once at the end.
class Reader {
 public:
  Reader(const uint8_t* p, size_t n) : p_(p), n_(n) {}
  bool Need(size_t k) {
    if (!ok_ || n_ - pos_ < k) ok_ = false;
    return ok_;
  }
  uint8_t U8() { return Need(1) ? p_[pos_++] : 0; }
  uint16_t U16() { return Need(2) ? Advance(2, ReadU16Le(p_ + pos_)) : 0; }
  uint32_t U32() { return Need(4) ? Advance(4, ReadU32Le(p_ + pos_)) : 0; }
  uint64_t U64() { return Need(8) ? Advance(8, ReadU64Le(p_ + pos_)) : 0; }
  int64_t I64() { return static_cast<int64_t>(U64()); }
  float F32() { return Need(4) ? Advance(4, ReadF32Le(p_ + pos_)) : 0.0f; }
  double F64() { return Need(8) ? Advance(8, ReadF64Le(p_ + pos_)) : 0.0; }
  std::string String() {
    const size_t len = U8();
    if (!Need(len)) return std::string();
    std::string s(reinterpret_cast<const char*>(p_ + pos_), len);
    pos_ += len;
    return s;
  }
  void Bytes(uint8_t* dst, size_t k) {
    if (!Need(k)) return;
    std::memcpy(dst, p_ + pos_, k);
    pos_ += k;
  }
  bool ok() const { return ok_; }
  bool AtEnd() const { return ok_ && pos_ == n_; }
  size_t remaining() const { return n_ - pos_; }
  const uint8_t* here() const { return p_ + pos_; }

 private:
  template <typename T>
  T Advance(size_t k, T v) {
    pos_ += k;
    return v;
  }
  const uint8_t* p_;
  size_t n_;
  size_t pos_ = 0;
  bool ok_ = true;
};

struct PayloadWriter {
  std::vector<uint8_t>* out;

  void operator()(const Hello& m) const {
    AppendU16Le(m.protocol_version, out);
    out->push_back(m.auth_required ? 1 : 0);
    AppendString(m.name, out);
    const size_t count = std::min<size_t>(m.devices.size(), 255);
    out->push_back(static_cast<uint8_t>(count));
    for (size_t i = 0; i < count; ++i) {
      out->push_back(m.devices[i].device);
      AppendString(m.devices[i].description, out);
    }
  }
  void operator()(const AuthChallenge& m) const {
    out->insert(out->end(), m.nonce.begin(), m.nonce.end());
  }
  void operator()(const AuthResponse& m) const {
    out->insert(out->end(), m.client_nonce.begin(), m.client_nonce.end());
    out->insert(out->end(), m.mac.begin(), m.mac.end());
  }
  void operator()(const AuthResult& m) const {
    out->push_back(static_cast<uint8_t>(m.outcome));
    AppendString(m.reason, out);
  }
  void operator()(const DriveCommand& m) const {
    AppendF64Le(m.v_mps, out);
    AppendF64Le(m.w_radps, out);
  }
  void operator()(const Stop&) const {}
  void operator()(const EmergencyStop&) const {}
  void operator()(const ClearEmergencyStop&) const {}
  void operator()(const Heartbeat&) const {}
  void operator()(const LidarMotor& m) const { out->push_back(m.on ? 1 : 0); }
  void operator()(const TelemetryResume& m) const {
    for (const TelemetryResumePosition& d : m.devices) {
      out->push_back(d.have ? 1 : 0);
      out->push_back(0);
      AppendU16Le(0, out);
      AppendI64Le(d.have ? ToNanoseconds(d.after_time) : 0, out);
      AppendU32Le(d.have ? d.bytes_at_time : 0, out);
    }
  }
  void operator()(const RecorderEvent& m) const {
    out->push_back(static_cast<uint8_t>(m.kind));
    out->push_back(static_cast<uint8_t>((m.new_clock_epoch ? 1 : 0) | (m.resumed ? 2 : 0)));
    AppendU16Le(0, out);
    AppendU32Le(m.epoch, out);
    AppendI64Le(ToNanoseconds(m.workstation_time), out);
    AppendI64Le(ToNanoseconds(m.robot_time), out);
    AppendI64Le(m.outage.count(), out);
    AppendI64Le(m.robot_time_shift.count(), out);
    AppendI64Le(m.tie_uncertainty.count(), out);
    AppendU32Le(m.attempts, out);
    AppendString(m.reason, out);
  }
  void operator()(const CommandAck& m) const {
    AppendU32Le(m.acked_sequence, out);
    out->push_back(m.acked_type);
    out->push_back(static_cast<uint8_t>(m.result));
    AppendU16Le(0, out);
    AppendI64Le(ToNanoseconds(m.echo_time), out);
  }
  void operator()(const LinkStatus& m) const {
    AppendF32Le(m.battery_voltage_v, out);
    AppendU32Le(m.fault_bits, out);
    out->push_back(static_cast<uint8_t>(m.watchdog));
    out->push_back(static_cast<uint8_t>((m.emergency_stop_latched ? 1 : 0) |
                                        (m.client_authenticated ? 2 : 0) |
                                        (m.lidar_motor_on ? 4 : 0)));
    AppendU16Le(0, out);
    AppendF64Le(m.commanded_v_mps, out);
    AppendF64Le(m.commanded_w_radps, out);
    AppendF64Le(m.applied_v_mps, out);
    AppendF64Le(m.applied_w_radps, out);
    AppendU32Le(m.frames_received, out);
    AppendU32Le(m.frames_rejected, out);
    AppendU32Le(m.commands_refused, out);
    AppendU32Le(m.watchdog_trips, out);
    for (uint64_t b : m.device_bytes) AppendU64Le(b, out);
  }
  void operator()(const Telemetry& m) const {
    out->push_back(m.device);
    out->push_back(m.flags);
    out->push_back(0);
    out->push_back(0);
    AppendI64Le(ToNanoseconds(m.receive_time), out);
    const size_t n = std::min(m.bytes.size(), kLinkMaxTelemetryBytes);
    out->insert(out->end(), m.bytes.begin(), m.bytes.begin() + static_cast<std::ptrdiff_t>(n));
  }
  void operator()(const UnknownMessage& m) const {
    out->insert(out->end(), m.payload.begin(), m.payload.end());
  }
};

struct TypeOf {
  uint8_t operator()(const Hello&) const { return uint8_t(LinkMessageType::kHello); }
  uint8_t operator()(const AuthChallenge&) const {
    return uint8_t(LinkMessageType::kAuthChallenge);
  }
  uint8_t operator()(const AuthResponse&) const { return uint8_t(LinkMessageType::kAuthResponse); }
  uint8_t operator()(const AuthResult&) const { return uint8_t(LinkMessageType::kAuthResult); }
  uint8_t operator()(const DriveCommand&) const { return uint8_t(LinkMessageType::kDriveCommand); }
  uint8_t operator()(const Stop&) const { return uint8_t(LinkMessageType::kStop); }
  uint8_t operator()(const EmergencyStop&) const {
    return uint8_t(LinkMessageType::kEmergencyStop);
  }
  uint8_t operator()(const ClearEmergencyStop&) const {
    return uint8_t(LinkMessageType::kClearEmergencyStop);
  }
  uint8_t operator()(const Heartbeat&) const { return uint8_t(LinkMessageType::kHeartbeat); }
  uint8_t operator()(const LidarMotor&) const { return uint8_t(LinkMessageType::kLidarMotor); }
  uint8_t operator()(const TelemetryResume&) const {
    return uint8_t(LinkMessageType::kTelemetryResume);
  }
  uint8_t operator()(const RecorderEvent&) const {
    return uint8_t(LinkMessageType::kRecorderEvent);
  }
  uint8_t operator()(const CommandAck&) const { return uint8_t(LinkMessageType::kCommandAck); }
  uint8_t operator()(const LinkStatus&) const { return uint8_t(LinkMessageType::kStatus); }
  uint8_t operator()(const Telemetry&) const { return uint8_t(LinkMessageType::kTelemetry); }
  uint8_t operator()(const UnknownMessage& m) const { return m.type; }
};

bool Fail(const std::string& why, std::string* error) {
  if (error != nullptr) *error = why;
  return false;
}

// ParseLinkPayload, one message family at a time. Each parser gets the
// payload's reader (at its start) and size and fills *out or says why not.

// The payload of a fixed-size message must be exactly `size` bytes.
bool ExactPayloadSize(uint8_t type, size_t n, size_t size, std::string* error) {
  return n == size ? true
                   : Fail(std::string(LinkMessageTypeName(type)) + " payload must be " +
                              std::to_string(size) + " bytes, got " + std::to_string(n),
                          error);
}

// Hello: version, flags, name, then the devices (variable size).
bool ParseHello(Reader& r, LinkPayload* out, std::string* error) {
  Hello m;
  m.protocol_version = r.U16();
  const uint8_t flags = r.U8();
  m.auth_required = (flags & 1) != 0;
  m.name = r.String();
  const size_t count = r.U8();
  for (size_t i = 0; i < count && r.ok(); ++i) {
    HelloDevice d;
    d.device = r.U8();
    d.description = r.String();
    m.devices.push_back(std::move(d));
  }
  if (!r.AtEnd()) return Fail("Hello payload: fields do not fill the payload exactly", error);
  *out = std::move(m);
  return true;
}

// The authentication handshake: challenge (nonce), response (MAC), result.
bool ParseAuth(LinkMessageType type, Reader& r, size_t n, LinkPayload* out, std::string* error) {
  const uint8_t t = static_cast<uint8_t>(type);
  if (type == LinkMessageType::kAuthChallenge) {
    if (!ExactPayloadSize(t, n, kLinkNonceSize, error)) return false;
    AuthChallenge m;
    r.Bytes(m.nonce.data(), m.nonce.size());
    *out = m;
    return true;
  }
  if (type == LinkMessageType::kAuthResponse) {
    if (!ExactPayloadSize(t, n, kLinkNonceSize + kLinkMacSize, error)) return false;
    AuthResponse m;
    r.Bytes(m.client_nonce.data(), m.client_nonce.size());
    r.Bytes(m.mac.data(), m.mac.size());
    *out = m;
    return true;
  }
  AuthResult m;  // kAuthResult
  const uint8_t outcome = r.U8();
  m.reason = r.String();
  if (!r.AtEnd())
    return Fail("AuthResult payload: fields do not fill the payload exactly", error);
  if (outcome > 1) return Fail("AuthResult: outcome " + std::to_string(outcome), error);
  m.outcome = static_cast<AuthOutcome>(outcome);
  *out = std::move(m);
  return true;
}

// Commands to the robot: drive, the stops, heartbeat, lidar motor.
bool ParseCommand(LinkMessageType type, Reader& r, size_t n, LinkPayload* out,
                  std::string* error) {
  const uint8_t t = static_cast<uint8_t>(type);
  switch (type) {
    case LinkMessageType::kDriveCommand: {
      if (!ExactPayloadSize(t, n, kDriveSize, error)) return false;
      DriveCommand m;
      m.v_mps = r.F64();
      m.w_radps = r.F64();
      if (!std::isfinite(m.v_mps) || !std::isfinite(m.w_radps)) {
        return Fail("DriveCommand: non-finite velocity", error);
      }
      *out = m;
      return true;
    }
    case LinkMessageType::kStop:
      if (!ExactPayloadSize(t, n, 0, error)) return false;
      *out = Stop{};
      return true;
    case LinkMessageType::kEmergencyStop:
      if (!ExactPayloadSize(t, n, 0, error)) return false;
      *out = EmergencyStop{};
      return true;
    case LinkMessageType::kClearEmergencyStop:
      if (!ExactPayloadSize(t, n, 0, error)) return false;
      *out = ClearEmergencyStop{};
      return true;
    case LinkMessageType::kHeartbeat:
      if (!ExactPayloadSize(t, n, 0, error)) return false;
      *out = Heartbeat{};
      return true;
    default: {  // kLidarMotor
      if (!ExactPayloadSize(t, n, 1, error)) return false;
      const uint8_t on = r.U8();
      if (on > 1) return Fail("LidarMotor: value " + std::to_string(on) + " (0 or 1)", error);
      *out = LidarMotor{on == 1};
      return true;
    }
  }
}

bool ParseCommandAck(Reader& r, size_t n, LinkPayload* out, std::string* error) {
  if (!ExactPayloadSize(static_cast<uint8_t>(LinkMessageType::kCommandAck), n, kCommandAckSize,
                        error)) {
    return false;
  }
  CommandAck m;
  m.acked_sequence = r.U32();
  m.acked_type = r.U8();
  const uint8_t result = r.U8();
  r.U16();  // reserved
  m.echo_time = TimeFromNanoseconds(r.I64());
  if (result > static_cast<uint8_t>(AckResult::kUnsupported)) {
    return Fail("CommandAck: result " + std::to_string(result), error);
  }
  m.result = static_cast<AckResult>(result);
  *out = m;
  return true;
}

bool ParseStatus(Reader& r, size_t n, LinkPayload* out, std::string* error) {
  if (!ExactPayloadSize(static_cast<uint8_t>(LinkMessageType::kStatus), n, kStatusSize, error)) {
    return false;
  }
  LinkStatus m;
  m.battery_voltage_v = r.F32();
  m.fault_bits = r.U32();
  const uint8_t watchdog = r.U8();
  const uint8_t flags = r.U8();
  r.U16();  // reserved
  if (watchdog > static_cast<uint8_t>(WatchdogState::kTripped)) {
    return Fail("Status: watchdog state " + std::to_string(watchdog), error);
  }
  m.watchdog = static_cast<WatchdogState>(watchdog);
  m.emergency_stop_latched = (flags & 1) != 0;
  m.client_authenticated = (flags & 2) != 0;
  m.lidar_motor_on = (flags & 4) != 0;
  m.commanded_v_mps = r.F64();
  m.commanded_w_radps = r.F64();
  m.applied_v_mps = r.F64();
  m.applied_w_radps = r.F64();
  m.frames_received = r.U32();
  m.frames_rejected = r.U32();
  m.commands_refused = r.U32();
  m.watchdog_trips = r.U32();
  for (uint64_t& b : m.device_bytes) b = r.U64();
  *out = m;
  return true;
}

bool ParseTelemetry(Reader& r, size_t n, LinkPayload* out, std::string* error) {
  if (n < kTelemetryHeaderSize) {
    return Fail("Telemetry payload shorter than its 12-byte header: " + std::to_string(n), error);
  }
  Telemetry m;
  m.device = r.U8();
  m.flags = r.U8();
  r.U16();  // reserved
  m.receive_time = TimeFromNanoseconds(r.I64());
  m.bytes.assign(r.here(), r.here() + r.remaining());
  *out = std::move(m);
  return true;
}
bool ParseTelemetryResume(Reader& r, size_t n, LinkPayload* out, std::string* error) {
  if (!ExactPayloadSize(static_cast<uint8_t>(LinkMessageType::kTelemetryResume), n, kResumeSize,
                        error)) {
    return false;
  }
  TelemetryResume m;
  for (TelemetryResumePosition& d : m.devices) {
    const uint8_t have = r.U8();
    r.U8();
    r.U16();  // reserved
    const int64_t after_ns = r.I64();
    const uint32_t bytes = r.U32();
    if (have > 1) return Fail("TelemetryResume: have " + std::to_string(have) + " (0 or 1)", error);
    d.have = have == 1;
    if (d.have) {
      d.after_time = TimeFromNanoseconds(after_ns);
      d.bytes_at_time = bytes;
    }
  }
  *out = m;
  return true;
}

bool ParseRecorderEvent(Reader& r, size_t n, LinkPayload* out, std::string* error) {
  if (n < kRecorderEventFixedSize + 1) {
    return Fail("RecorderEvent payload: " + std::to_string(n) + " bytes, needs at least " +
                    std::to_string(kRecorderEventFixedSize + 1),
                error);
  }
  RecorderEvent m;
  const uint8_t kind = r.U8();
  const uint8_t flags = r.U8();
  r.U16();  // reserved
  if (kind < 1 || kind > 2) return Fail("RecorderEvent: kind " + std::to_string(kind), error);
  m.kind = static_cast<RecorderEventKind>(kind);
  m.new_clock_epoch = (flags & 1) != 0;
  m.resumed = (flags & 2) != 0;
  m.epoch = r.U32();
  m.workstation_time = TimeFromNanoseconds(r.I64());
  m.robot_time = TimeFromNanoseconds(r.I64());
  m.outage = Duration(r.I64());
  m.robot_time_shift = Duration(r.I64());
  m.tie_uncertainty = Duration(r.I64());
  m.attempts = r.U32();
  m.reason = r.String();
  if (!r.AtEnd()) {
    return Fail("RecorderEvent payload: fields do not fill the payload exactly", error);
  }
  if (m.outage.count() < 0 || m.tie_uncertainty.count() < 0) {
    return Fail("RecorderEvent: negative outage or uncertainty", error);
  }
  *out = std::move(m);
  return true;
}
}  // namespace

const char* LinkMessageTypeName(uint8_t type) {
  switch (static_cast<LinkMessageType>(type)) {
    case LinkMessageType::kHello:
      return "Hello";
    case LinkMessageType::kAuthChallenge:
      return "AuthChallenge";
    case LinkMessageType::kAuthResponse:
      return "AuthResponse";
    case LinkMessageType::kAuthResult:
      return "AuthResult";
    case LinkMessageType::kDriveCommand:
      return "DriveCommand";
    case LinkMessageType::kStop:
      return "Stop";
    case LinkMessageType::kEmergencyStop:
      return "EmergencyStop";
    case LinkMessageType::kClearEmergencyStop:
      return "ClearEmergencyStop";
    case LinkMessageType::kHeartbeat:
      return "Heartbeat";
    case LinkMessageType::kLidarMotor:
      return "LidarMotor";
    case LinkMessageType::kTelemetryResume:
      return "TelemetryResume";
    case LinkMessageType::kRecorderEvent:
      return "RecorderEvent";
    case LinkMessageType::kCommandAck:
      return "CommandAck";
    case LinkMessageType::kStatus:
      return "Status";
    case LinkMessageType::kTelemetry:
      return "Telemetry";
  }
  return "unknown";
}

bool IsKnownLinkMessageType(uint8_t type) {
  return std::strcmp(LinkMessageTypeName(type), "unknown") != 0;
}

const char* LinkDeviceName(uint8_t device) {
  switch (static_cast<LinkDevice>(device)) {
    case LinkDevice::kLidar:
      return "lidar";
    case LinkDevice::kImu:
      return "imu";
    case LinkDevice::kMotorBoard:
      return "motor_board";
  }
  return "unknown";
}

uint8_t LinkPayloadType(const LinkPayload& payload) { return std::visit(TypeOf{}, payload); }

void EncodeLinkPayload(const LinkPayload& payload, std::vector<uint8_t>* out) {
  std::visit(PayloadWriter{out}, payload);
}

bool ParseLinkPayload(uint8_t type, const uint8_t* data, size_t n, LinkPayload* out,
                      std::string* error) {
  if (n > 0 && data == nullptr) return Fail("null payload", error);
  Reader r(data, n);
  const LinkMessageType t = static_cast<LinkMessageType>(type);
  switch (t) {
    case LinkMessageType::kHello:
      return ParseHello(r, out, error);
    case LinkMessageType::kAuthChallenge:
    case LinkMessageType::kAuthResponse:
    case LinkMessageType::kAuthResult:
      return ParseAuth(t, r, n, out, error);
    case LinkMessageType::kDriveCommand:
    case LinkMessageType::kStop:
    case LinkMessageType::kEmergencyStop:
    case LinkMessageType::kClearEmergencyStop:
    case LinkMessageType::kHeartbeat:
    case LinkMessageType::kLidarMotor:
      return ParseCommand(t, r, n, out, error);
    case LinkMessageType::kCommandAck:
      return ParseCommandAck(r, n, out, error);
    case LinkMessageType::kStatus:
      return ParseStatus(r, n, out, error);
    case LinkMessageType::kTelemetry:
      return ParseTelemetry(r, n, out, error);
    case LinkMessageType::kTelemetryResume:
      return ParseTelemetryResume(r, n, out, error);
    case LinkMessageType::kRecorderEvent:
      return ParseRecorderEvent(r, n, out, error);
  }
  UnknownMessage m;
  m.type = type;
  if (n > 0) m.payload.assign(data, data + n);
  *out = std::move(m);
  return true;
}

}  // namespace hardware
}  // namespace sweepscan
