#include "hardware/link/link_protocol.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include "core/common/crc32c.h"

namespace sweepscan {
namespace hardware {
namespace {

// Header field offsets (docs/protocol.md, "Frame").
constexpr size_t kOffVersion = 2;
constexpr size_t kOffType = 3;
constexpr size_t kOffSender = 4;
constexpr size_t kOffFlags = 5;
constexpr size_t kOffSequence = 8;
constexpr size_t kOffTime = 12;
constexpr size_t kOffPayloadSize = 20;
constexpr size_t kOffHeaderCrc = 24;

constexpr size_t kCommandAckSize = 16;
constexpr size_t kStatusSize = 84;
constexpr size_t kDriveSize = 16;
constexpr size_t kResumeSize = 48;
constexpr size_t kRecorderEventFixedSize = 52;  // Before the reason string.

void AppendU64Le(uint64_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xFF));
}
uint64_t ReadU64Le(const uint8_t* p) {
  return static_cast<uint64_t>(ReadU32Le(p)) | (static_cast<uint64_t>(ReadU32Le(p + 4)) << 32);
}
void AppendI64Le(int64_t v, std::vector<uint8_t>* out) {
  AppendU64Le(static_cast<uint64_t>(v), out);
}
int64_t ReadI64Le(const uint8_t* p) { return static_cast<int64_t>(ReadU64Le(p)); }
// IEEE 754 binary64, little-endian; memcpy is the defined way to reinterpret.
void AppendF64Le(double v, std::vector<uint8_t>* out) {
  static_assert(sizeof(double) == 8, "double must be IEEE 754 binary64");
  uint64_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  AppendU64Le(bits, out);
}
double ReadF64Le(const uint8_t* p) {
  const uint64_t bits = ReadU64Le(p);
  double v;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}
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

// Header fields of a frame whose first kLinkHeaderSize bytes are at p.
LinkHeader ReadHeader(const uint8_t* p) {
  LinkHeader h;
  h.version = p[kOffVersion];
  h.type = p[kOffType];
  h.sender = static_cast<LinkSender>(p[kOffSender]);
  h.signed_frame = (p[kOffFlags] & kLinkFlagSigned) != 0;
  h.sequence = ReadU32Le(p + kOffSequence);
  h.time = TimeFromNanoseconds(ReadI64Le(p + kOffTime));
  h.payload_size = ReadU32Le(p + kOffPayloadSize);
  return h;
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

bool AppendRawLinkFrame(LinkSender sender, uint32_t sequence, Time time, uint8_t type,
                        const uint8_t* payload, size_t n, std::vector<uint8_t>* out,
                        const LinkFrameSigner& signer, uint8_t version) {
  if (n > kLinkMaxPayload || (n > 0 && payload == nullptr)) return false;
  const bool sign = static_cast<bool>(signer) && version >= 2;
  const size_t start = out->size();
  out->reserve(start + n + kLinkFrameOverhead + (sign ? kLinkTagSize : 0));
  out->push_back(kLinkSync1);
  out->push_back(kLinkSync2);
  out->push_back(version);
  out->push_back(type);
  out->push_back(static_cast<uint8_t>(sender));
  out->push_back(sign ? kLinkFlagSigned : 0);  // flags
  AppendU16Le(0, out);                         // reserved
  AppendU32Le(sequence, out);
  AppendI64Le(ToNanoseconds(time), out);
  AppendU32Le(static_cast<uint32_t>(n), out);
  AppendU32Le(Crc32c(out->data() + start, kOffHeaderCrc), out);
  if (n > 0) out->insert(out->end(), payload, payload + n);
  if (sign) {
    const LinkTag tag = signer(out->data() + start, payload, n);
    out->insert(out->end(), tag.begin(), tag.end());
  }
  AppendU32Le(Crc32c(out->data() + start, out->size() - start), out);
  return true;
}

bool AppendLinkFrame(LinkSender sender, uint32_t sequence, Time time, const LinkPayload& payload,
                     std::vector<uint8_t>* out) {
  std::vector<uint8_t> body;
  EncodeLinkPayload(payload, &body);
  return AppendRawLinkFrame(sender, sequence, time, LinkPayloadType(payload), body.data(),
                            body.size(), out);
}

std::vector<uint8_t> LinkEncoder::Encode(Time time, const LinkPayload& payload) {
  std::vector<uint8_t> out;
  std::vector<uint8_t> body;
  EncodeLinkPayload(payload, &body);
  if (AppendRawLinkFrame(sender_, next_sequence_, time, LinkPayloadType(payload), body.data(),
                         body.size(), &out, signer_)) {
    ++next_sequence_;
  }
  return out;
}

std::vector<uint8_t> LinkEncoder::EncodeTelemetry(Time t, LinkDevice device, Time receive_time,
                                                  const uint8_t* bytes, size_t n,
                                                  uint8_t flags) {
  std::vector<uint8_t> out;
  size_t pos = 0;
  do {
    const size_t k = std::min(n - pos, kLinkMaxTelemetryBytes);
    Telemetry m;
    m.device = static_cast<uint8_t>(device);
    m.flags = pos == 0 ? flags : static_cast<uint8_t>(flags & ~kTelemetryBreak);
    m.receive_time = receive_time;
    if (k > 0) m.bytes.assign(bytes + pos, bytes + pos + k);
    std::vector<uint8_t> body;
    EncodeLinkPayload(m, &body);
    AppendRawLinkFrame(sender_, next_sequence_++, t, static_cast<uint8_t>(LinkMessageType::kTelemetry),
                       body.data(), body.size(), &out, signer_);
    pos += k;
  } while (pos < n);
  return out;
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

Status ParseLinkFrame(const uint8_t* data, size_t n, LinkMessage* out) {
  if (n < kLinkFrameOverhead || data == nullptr) {
    return Status::Error("link frame: " + std::to_string(n) + " bytes, shorter than the " +
                         std::to_string(kLinkFrameOverhead) + "-byte minimum");
  }
  if (data[0] != kLinkSync1 || data[1] != kLinkSync2) {
    return Status::Error("link frame: no E7 5C sync bytes at its start");
  }
  if (data[kOffVersion] < kLinkMinReadableVersion || data[kOffVersion] > kLinkProtocolVersion) {
    return Status::Error("link frame: unsupported protocol version " +
                         std::to_string(data[kOffVersion]));
  }
  if (Crc32c(data, kOffHeaderCrc) != ReadU32Le(data + kOffHeaderCrc)) {
    return Status::Error("link frame: header CRC mismatch");
  }
  const LinkHeader h = ReadHeader(data);
  if (h.payload_size > kLinkMaxPayload) {
    return Status::Error("link frame: payload size " + std::to_string(h.payload_size) +
                         " beyond the limit " + std::to_string(kLinkMaxPayload));
  }
  const size_t tag_size = h.signed_frame ? kLinkTagSize : 0;
  if (n != kLinkFrameOverhead + h.payload_size + tag_size) {
    return Status::Error("link frame: " + std::to_string(n) + " bytes, header announces " +
                         std::to_string(kLinkFrameOverhead + h.payload_size + tag_size));
  }
  const size_t crc_at = kLinkHeaderSize + h.payload_size + tag_size;
  if (Crc32c(data, crc_at) != ReadU32Le(data + crc_at)) {
    return Status::Error("link frame: frame CRC mismatch");
  }
  if (h.sender != LinkSender::kAgent && h.sender != LinkSender::kClient) {
    return Status::Error("link frame: unknown sender " + std::to_string(data[kOffSender]));
  }
  std::string error;
  LinkMessage m;
  m.header = h;
  if (!ParseLinkPayload(h.type, data + kLinkHeaderSize, h.payload_size, &m.payload, &error)) {
    return Status::Error("link frame: " + error);
  }
  *out = std::move(m);
  return Status::Ok();
}

uint64_t SequenceTracker::Observe(uint32_t sequence) {
  ++stats_.frames;
  uint64_t missing = 0;
  if (have_last_) {
    // Unsigned difference modulo 2^32: forward jumps of less than 2^31 are
    // losses; anything else (including a repeat) is a restart/reorder.
    const uint32_t delta = sequence - last_;
    if (delta == 1) {
    } else if (delta != 0 && delta < 0x80000000u) {
      missing = delta - 1;
      ++stats_.gaps;
      stats_.frames_missing += missing;
    } else {
      ++stats_.restarts;
    }
  }
  have_last_ = true;
  last_ = sequence;
  return missing;
}

std::string LinkDecoderStats::ToString() const {
  std::ostringstream s;
  s << codec.ToString() << " unknown_types=" << unknown_types;
  const char* names[2] = {"agent", "client"};
  for (int i = 0; i < 2; ++i) {
    s << " " << names[i] << "{frames=" << sequence[i].frames << " gaps=" << sequence[i].gaps
      << " missing=" << sequence[i].frames_missing << " restarts=" << sequence[i].restarts << "}";
  }
  return s.str();
}

LinkDecoder::LinkDecoder(const LinkDecoderOptions& options) : options_(options) {
  options_.max_payload = std::min(options_.max_payload, kLinkMaxPayload);
}

void LinkDecoder::Reset() {
  buffer_.Clear();
  for (SequenceTracker& t : trackers_) t.Reset();
}

LinkDecoder::Parse LinkDecoder::TryFrame(const uint8_t* p, size_t n,
                                         std::vector<LinkMessage>* out) {
  // p[0..1] are the sync bytes. Check what is available as early as possible
  // so a bad candidate is rejected without waiting for more bytes.
  if (n <= kOffVersion) return Parse::kNeedMore;
  if (p[kOffVersion] < kLinkMinReadableVersion || p[kOffVersion] > kLinkProtocolVersion) {
    ++stats_.codec.framing_errors;
    return Parse::kRejected;
  }
  if (n < kLinkHeaderSize) return Parse::kNeedMore;
  work_ += kOffHeaderCrc;
  if (Crc32c(p, kOffHeaderCrc) != ReadU32Le(p + kOffHeaderCrc)) {
    ++stats_.codec.checksum_errors;
    return Parse::kRejected;
  }
  const LinkHeader h = ReadHeader(p);
  if (h.payload_size > options_.max_payload) {
    ++stats_.codec.length_errors;
    return Parse::kRejected;
  }
  const size_t tag_size = h.signed_frame ? kLinkTagSize : 0;
  const size_t frame_size = kLinkFrameOverhead + h.payload_size + tag_size;
  if (n < frame_size) return Parse::kNeedMore;
  const size_t crc_at = kLinkHeaderSize + h.payload_size + tag_size;
  work_ += crc_at;
  if (Crc32c(p, crc_at) != ReadU32Le(p + crc_at)) {
    ++stats_.codec.checksum_errors;
    return Parse::kRejected;
  }
  // A genuine frame from here on: its bytes are consumed whatever its content.
  stats_.codec.bytes_in_frames += frame_size;
  const int sender_index = h.sender == LinkSender::kAgent    ? 0
                           : h.sender == LinkSender::kClient ? 1
                                                             : -1;
  LinkMessage m;
  m.header = h;
  std::string error;
  if (sender_index < 0 ||
      !ParseLinkPayload(h.type, p + kLinkHeaderSize, h.payload_size, &m.payload, &error)) {
    ++stats_.codec.payload_errors;
    return Parse::kConsumed;
  }
  trackers_[sender_index].Observe(h.sequence);
  stats_.sequence[sender_index] = trackers_[sender_index].stats();
  if (std::holds_alternative<UnknownMessage>(m.payload)) ++stats_.unknown_types;
  ++stats_.codec.frames_ok;
  if (options_.keep_raw_frames) m.raw.assign(p, p + frame_size);
  if (h.signed_frame) {
    std::copy(p + kLinkHeaderSize + h.payload_size, p + crc_at, m.tag.begin());
    m.signed_bytes.reserve(kLinkSignedHeaderSize + h.payload_size);
    m.signed_bytes.assign(p, p + kLinkSignedHeaderSize);
    m.signed_bytes.insert(m.signed_bytes.end(), p + kLinkHeaderSize,
                          p + kLinkHeaderSize + h.payload_size);
  }
  out->push_back(std::move(m));
  return Parse::kConsumed;
}

void LinkDecoder::Feed(const uint8_t* data, size_t n, std::vector<LinkMessage>* out) {
  if (data == nullptr) n = 0;
  stats_.codec.bytes_in += n;
  buffer_.Append(data, n);
  work_ = 0;
  work_pending_ = false;
  while (buffer_.size() > 0) {
    if (options_.max_work_per_feed > 0 && work_ >= options_.max_work_per_feed) {
      work_pending_ = true;  // The rest waits for the next Feed().
      break;
    }
    const uint8_t* p = buffer_.data();
    const size_t avail = buffer_.size();
    if (p[0] != kLinkSync1) {
      stats_.codec.bytes_skipped += buffer_.SkipToNext(kLinkSync1);
      continue;
    }
    if (avail < 2) break;
    if (p[1] != kLinkSync2) {
      ++stats_.codec.bytes_skipped;
      buffer_.Consume(1);
      continue;
    }
    const Parse r = TryFrame(p, avail, out);
    if (r == Parse::kNeedMore) break;
    if (r == Parse::kRejected) {
      ++stats_.codec.bytes_skipped;
      buffer_.Consume(1);
      continue;
    }
    const size_t frame_size = kLinkFrameOverhead + ReadU32Le(p + kOffPayloadSize) +
                              ((p[kOffFlags] & kLinkFlagSigned) != 0 ? kLinkTagSize : 0);
    buffer_.Consume(frame_size);
  }
  buffer_.Compact();
}

}  // namespace hardware
}  // namespace sweepscan
