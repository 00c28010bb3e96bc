#include "hardware/link/link_protocol.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/common/crc32c.h"

namespace sweepscan {
namespace hardware {
namespace {

using Bytes = std::vector<uint8_t>;

const Time kT0 = TimeFromNanoseconds(1234567890123);

void ExpectAccounting(const LinkDecoder& d) {
  const DecoderStats& s = d.stats().codec;
  EXPECT_EQ(s.bytes_in, s.bytes_in_frames + s.bytes_skipped + d.BufferedBytes())
      << d.stats().ToString();
}

Bytes PayloadBytes(const LinkPayload& p) {
  Bytes b;
  EncodeLinkPayload(p, &b);
  return b;
}

// One message of every type, with non-default values in every field.
std::vector<LinkPayload> AllMessages() {
  std::vector<LinkPayload> out;
  Hello hello;
  hello.protocol_version = 1;
  hello.auth_required = true;
  hello.name = "sweepscan-robotd 0.1.0 (robot-1)";
  hello.devices = {{1, "YDLIDAR X4 /dev/ttyUSB0 @128000"}, {2, "HI219 /dev/ttyUSB1"}, {3, ""}};
  out.push_back(hello);
  AuthChallenge challenge;
  for (size_t i = 0; i < challenge.nonce.size(); ++i) challenge.nonce[i] = uint8_t(i * 7 + 1);
  out.push_back(challenge);
  AuthResponse response;
  for (size_t i = 0; i < response.mac.size(); ++i) response.mac[i] = uint8_t(255 - i);
  for (size_t i = 0; i < response.client_nonce.size(); ++i) response.client_nonce[i] = uint8_t(i);
  out.push_back(response);
  out.push_back(AuthResult{AuthOutcome::kOk, ""});
  out.push_back(AuthResult{AuthOutcome::kDenied, "wrong key"});
  out.push_back(DriveCommand{0.25, -0.5});
  out.push_back(Stop{});
  out.push_back(EmergencyStop{});
  out.push_back(ClearEmergencyStop{});
  out.push_back(Heartbeat{});
  out.push_back(LidarMotor{true});
  out.push_back(LidarMotor{false});
  out.push_back(CommandAck{77, uint8_t(LinkMessageType::kDriveCommand),
                           AckResult::kEmergencyStopLatched, TimeFromNanoseconds(-5)});
  LinkStatus st;
  st.battery_voltage_v = 12.25f;
  st.fault_bits = kFaultImuSilent | kFaultLowBattery;
  st.watchdog = WatchdogState::kTripped;
  st.emergency_stop_latched = true;
  st.client_authenticated = true;
  st.lidar_motor_on = true;
  st.commanded_v_mps = 0.3;
  st.commanded_w_radps = -0.1;
  st.applied_v_mps = 0.2;
  st.applied_w_radps = -0.05;
  st.frames_received = 1000;
  st.frames_rejected = 3;
  st.commands_refused = 2;
  st.watchdog_trips = 1;
  st.device_bytes = {123456789012ull, 42, 7};
  out.push_back(st);
  Telemetry tel;
  tel.device = uint8_t(LinkDevice::kImu);
  tel.receive_time = TimeFromNanoseconds(987654321);
  tel.bytes = {0x5A, 0xA5, 0x01, 0x02, 0xE7, 0x5C};  // Sync bytes inside a payload are harmless.
  out.push_back(tel);
  out.push_back(Telemetry{uint8_t(LinkDevice::kLidar), kT0, {}});
  out.push_back(Telemetry{uint8_t(LinkDevice::kMotorBoard), kT0, {9}, kTelemetryLate | kTelemetryBreak});
  TelemetryResume resume;
  resume.devices[0] = {true, TimeFromNanoseconds(5000000123), 7};
  resume.devices[2] = {true, TimeFromNanoseconds(-1), 0};
  out.push_back(resume);
  RecorderEvent lost;
  lost.kind = RecorderEventKind::kLinkLost;
  lost.epoch = 2;
  lost.workstation_time = TimeFromNanoseconds(77);
  lost.robot_time = TimeFromNanoseconds(88);
  lost.reason = "no frame for 2.0 s";
  out.push_back(lost);
  RecorderEvent restored;
  restored.kind = RecorderEventKind::kLinkRestored;
  restored.new_clock_epoch = true;
  restored.resumed = true;
  restored.epoch = 3;
  restored.outage = std::chrono::seconds(20);
  restored.robot_time_shift = Duration(-123456789);
  restored.tie_uncertainty = Duration(250000);
  restored.attempts = 9;
  out.push_back(restored);
  out.push_back(UnknownMessage{0x7F, {1, 2, 3}});
  return out;
}

Bytes EncodeAll(uint32_t first_sequence, std::vector<LinkPayload>* payloads) {
  *payloads = AllMessages();
  LinkEncoder enc(LinkSender::kAgent, first_sequence);
  Bytes stream;
  for (size_t i = 0; i < payloads->size(); ++i) {
    const Bytes f = enc.Encode(kT0 + std::chrono::milliseconds(i), (*payloads)[i]);
    stream.insert(stream.end(), f.begin(), f.end());
  }
  return stream;
}

// Equality by value: same wire type and the same payload bytes (every field
// is on the wire, so this compares every field).
void ExpectSameMessages(const std::vector<LinkMessage>& a, const std::vector<LinkMessage>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].header.type, b[i].header.type) << i;
    EXPECT_EQ(a[i].header.sequence, b[i].header.sequence) << i;
    EXPECT_EQ(a[i].header.time, b[i].header.time) << i;
    EXPECT_EQ(PayloadBytes(a[i].payload), PayloadBytes(b[i].payload)) << i;
  }
}

// docs/protocol.md "Telemetry", "TelemetryResume" and docs/session-format.md
// "Recorder events", byte by byte.
TEST(LinkProtocolTest, TelemetryFlagsAndTelemetryResumeLayoutByHand) {
  Telemetry t{uint8_t(LinkDevice::kImu), TimeFromNanoseconds(0x0102030405060708), {0xAB},
              kTelemetryLate | kTelemetryBreak};
  EXPECT_EQ(PayloadBytes(t), (Bytes{0x02, 0x03, 0x00, 0x00, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03,
                                    0x02, 0x01, 0xAB}));
  TelemetryResume r;
  r.devices[1] = {true, TimeFromNanoseconds(0x1122334455667788), 0x01020304};
  const Bytes b = PayloadBytes(r);
  ASSERT_EQ(b.size(), 48u);
  EXPECT_EQ(Bytes(b.begin(), b.begin() + 16), Bytes(16, 0)) << "no lidar position: all zero";
  EXPECT_EQ(Bytes(b.begin() + 16, b.begin() + 32),
            (Bytes{0x01, 0, 0, 0, 0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11, 0x04, 0x03, 0x02,
                   0x01}));
  LinkPayload parsed;
  std::string error;
  ASSERT_TRUE(ParseLinkPayload(0x16, b.data(), b.size(), &parsed, &error)) << error;
  const auto& back = std::get<TelemetryResume>(parsed);
  EXPECT_FALSE(back.devices[0].have);
  EXPECT_TRUE(back.devices[1].have);
  EXPECT_EQ(back.devices[1].bytes_at_time, 0x01020304u);
  Bytes bad = b;
  bad[0] = 2;  // "have" is 0 or 1.
  EXPECT_FALSE(ParseLinkPayload(0x16, bad.data(), bad.size(), &parsed, &error));
  EXPECT_FALSE(ParseLinkPayload(0x16, b.data(), 47, &parsed, &error));
}

TEST(LinkProtocolTest, RecorderEventLayoutByHand) {
  RecorderEvent e;
  e.kind = RecorderEventKind::kLinkRestored;
  e.resumed = true;
  e.outage = std::chrono::seconds(3);
  e.tie_uncertainty = std::chrono::microseconds(300);
  e.attempts = 2;
  e.workstation_time = TimeFromNanoseconds(0x1111);
  e.robot_time = TimeFromNanoseconds(0x2222);
  const Bytes b = PayloadBytes(e);
  ASSERT_EQ(b.size(), 53u);
  EXPECT_EQ(Bytes(b.begin(), b.begin() + 8), (Bytes{0x02, 0x02, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Bytes(b.begin() + 24, b.begin() + 32),
            (Bytes{0x00, 0x5E, 0xD0, 0xB2, 0, 0, 0, 0}));  // 3e9 ns, as in session-format.md
  EXPECT_EQ(Bytes(b.begin() + 40, b.begin() + 53),
            (Bytes{0xE0, 0x93, 0x04, 0, 0, 0, 0, 0, 0x02, 0, 0, 0, 0x00}));
  // In a session: a client frame of type 0x40 with a 53-byte payload.
  Bytes frame;
  ASSERT_TRUE(AppendLinkFrame(LinkSender::kClient, 0, kT0, e, &frame));
  EXPECT_EQ(frame[3], 0x40);
  EXPECT_EQ(frame[4], 0x02);
  EXPECT_EQ(frame[20], 53);  // payload_size, header offset 20
  LinkMessage m;
  ASSERT_TRUE(ParseLinkFrame(frame.data(), frame.size(), &m).ok());
  const auto& back = std::get<RecorderEvent>(m.payload);
  EXPECT_EQ(back.outage, e.outage);
  EXPECT_EQ(back.attempts, 2u);
  EXPECT_TRUE(back.resumed);
  EXPECT_FALSE(back.new_clock_epoch);
  Bytes bad = b;
  bad[0] = 3;  // kind 1 or 2
  LinkPayload parsed;
  std::string error;
  EXPECT_FALSE(ParseLinkPayload(0x40, bad.data(), bad.size(), &parsed, &error));
  EXPECT_FALSE(ParseLinkPayload(0x40, b.data(), 52, &parsed, &error));
}

TEST(Crc32cTest, CheckValueOfTheCatalogue) {
  const char* s = "123456789";
  const auto* p = reinterpret_cast<const uint8_t*>(s);
  EXPECT_EQ(Crc32c(p, 9), 0xE3069283u);
  EXPECT_EQ(Crc32cBitwise(p, 9), 0xE3069283u);
  EXPECT_EQ(kCrc32cCheck, 0xE3069283u);
  EXPECT_EQ(Crc32c(p, 0), 0u);
  // Continuation: CRC(a || b) == Crc32c(b, Crc32c(a)).
  EXPECT_EQ(Crc32c(p + 4, 5, Crc32c(p, 4)), 0xE3069283u);
  EXPECT_EQ(Crc32cTable(p + 4, 5, Crc32cTable(p, 4)), 0xE3069283u);
}

TEST(Crc32cTest, SlicingByEightMatchesBitwiseForAllLengthsAndAlignments) {
  std::mt19937 rng(5);
  Bytes data(300);
  for (auto& b : data) b = uint8_t(rng());
  for (size_t start = 0; start < 9; ++start) {
    for (size_t n = 0; start + n <= data.size(); n += 7) {
      ASSERT_EQ(Crc32c(data.data() + start, n), Crc32cBitwise(data.data() + start, n))
          << start << " " << n;
      // The portable tables too, where the CPU's instruction answers above.
      ASSERT_EQ(Crc32cTable(data.data() + start, n), Crc32cBitwise(data.data() + start, n))
          << start << " " << n;
    }
  }
}

TEST(LinkFrameTest, HeaderLayoutByHand) {
  // Heartbeat, agent, sequence 0x01020304, time 0x1122334455667788 ns.
  Bytes f;
  ASSERT_TRUE(AppendLinkFrame(LinkSender::kAgent, 0x01020304,
                              TimeFromNanoseconds(0x1122334455667788), Heartbeat{}, &f));
  ASSERT_EQ(f.size(), kLinkFrameOverhead);
  const Bytes header = {0xE7, 0x5C, 0x02, 0x14, 0x01, 0x00, 0x00, 0x00, 0x04, 0x03, 0x02, 0x01,
                        0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(Bytes(f.begin(), f.begin() + 24), header);
  const uint32_t header_crc = Crc32cBitwise(f.data(), 24);
  EXPECT_EQ(ReadU32Le(f.data() + 24), header_crc);
  EXPECT_EQ(ReadU32Le(f.data() + 28), Crc32cBitwise(f.data(), 28));
}

// The worked example of docs/protocol.md: DriveCommand v = 0.5 m/s,
// w = -0.25 rad/s from the client, sequence 7, time 1 s. CRCs computed
// independently (bitwise CRC-32C in Python) and by Crc32cBitwise below.
TEST(LinkFrameTest, WorkedExampleOfTheDocumentation) {
  Bytes f;
  ASSERT_TRUE(
      AppendLinkFrame(LinkSender::kClient, 7, TimeFromSeconds(1.0), DriveCommand{0.5, -0.25}, &f));
  const Bytes expected = {
      0xE7, 0x5C, 0x02, 0x10, 0x02, 0x00, 0x00, 0x00,  // sync, version 2, type, sender, flags
      0x07, 0x00, 0x00, 0x00,                          // sequence 7
      0x00, 0xCA, 0x9A, 0x3B, 0x00, 0x00, 0x00, 0x00,  // time 1e9 ns
      0x10, 0x00, 0x00, 0x00,                          // payload size 16
      0x8F, 0xA1, 0x11, 0x90,                          // header CRC-32C 0x9011A18F
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xE0, 0x3F,  // v = 0.5 (binary64 LE)
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xD0, 0xBF,  // w = -0.25
      0x3C, 0x59, 0x4A, 0xD2};                         // frame CRC-32C 0xD24A593C
  EXPECT_EQ(f, expected);
  EXPECT_EQ(ReadU32Le(f.data() + 24), Crc32cBitwise(f.data(), 24));
  EXPECT_EQ(ReadU32Le(f.data() + 44), Crc32cBitwise(f.data(), 44));
}

// The signed form of the same frame (docs/protocol.md, "Frame
// authentication"): flags bit 0, the 16-byte tag after the payload. The tag
// is computed by a stand-in signer here (the real one, HMAC-SHA256 under the
// session key, is checked against Python in hmac_sha256_test).
TEST(LinkFrameTest, SignedFrameLayout) {
  Bytes f;
  Bytes covered;
  const LinkFrameSigner signer = [&covered](const uint8_t* h, const uint8_t* p, size_t n) {
    covered.assign(h, h + kLinkSignedHeaderSize);
    covered.insert(covered.end(), p, p + n);
    LinkTag tag;
    for (size_t i = 0; i < tag.size(); ++i) tag[i] = static_cast<uint8_t>(0xA0 + i);
    return tag;
  };
  Bytes body;
  EncodeLinkPayload(DriveCommand{0.5, -0.25}, &body);
  ASSERT_TRUE(AppendRawLinkFrame(LinkSender::kClient, 7, TimeFromSeconds(1.0), 0x10, body.data(),
                                 body.size(), &f, signer));
  ASSERT_EQ(f.size(), 64u);
  EXPECT_EQ(f[5], kLinkFlagSigned);
  EXPECT_EQ(ReadU32Le(f.data() + 20), 16u);  // payload_size excludes the tag
  EXPECT_EQ(ReadU32Le(f.data() + 24), 0x292AED68u);
  EXPECT_EQ(Bytes(f.begin(), f.begin() + 24), Bytes(covered.begin(), covered.begin() + 24));
  EXPECT_EQ(Bytes(f.begin() + 28, f.begin() + 44), Bytes(covered.begin() + 24, covered.end()));
  EXPECT_EQ(f[44], 0xA0);
  EXPECT_EQ(ReadU32Le(f.data() + 60), Crc32cBitwise(f.data(), 60));
  LinkDecoder d;
  const auto out = d.Feed(f);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].header.signed_frame);
  EXPECT_EQ(out[0].tag[0], 0xA0);
  EXPECT_EQ(out[0].signed_bytes, covered);
  EXPECT_EQ(std::get<DriveCommand>(out[0].payload).v_mps, 0.5);
  LinkMessage parsed;
  EXPECT_TRUE(ParseLinkFrame(f.data(), f.size(), &parsed).ok());
  // Version 1 frames (old sessions, old peers) are still read.
  Bytes v1;
  ASSERT_TRUE(AppendRawLinkFrame(LinkSender::kClient, 7, TimeFromSeconds(1.0), 0x10, body.data(),
                                 body.size(), &v1, nullptr, 1));
  EXPECT_EQ(ReadU32Le(v1.data() + 24), 0x742F9253u);  // The version-1 worked example.
  ASSERT_TRUE(ParseLinkFrame(v1.data(), v1.size(), &parsed).ok());
  EXPECT_EQ(parsed.header.version, 1);
}

TEST(LinkFrameTest, EveryMessageTypeRoundTrips) {
  std::vector<LinkPayload> payloads;
  const Bytes stream = EncodeAll(100, &payloads);
  LinkDecoder d;
  const auto out = d.Feed(stream);
  ASSERT_EQ(out.size(), payloads.size());
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].header.type, LinkPayloadType(payloads[i])) << i;
    EXPECT_EQ(out[i].payload.index(), payloads[i].index()) << i;
    EXPECT_EQ(out[i].header.sequence, 100 + i);
    EXPECT_EQ(out[i].header.sender, LinkSender::kAgent);
    EXPECT_EQ(out[i].header.time, kT0 + std::chrono::milliseconds(i));
    EXPECT_EQ(PayloadBytes(out[i].payload), PayloadBytes(payloads[i])) << i;
  }
  // Spot checks of the parsed fields (not only the bytes).
  const auto& hello = std::get<Hello>(out[0].payload);
  EXPECT_TRUE(hello.auth_required);
  EXPECT_EQ(hello.name, "sweepscan-robotd 0.1.0 (robot-1)");
  ASSERT_EQ(hello.devices.size(), 3u);
  EXPECT_EQ(hello.devices[1].description, "HI219 /dev/ttyUSB1");
  EXPECT_EQ(std::get<AuthResult>(out[4].payload).reason, "wrong key");
  EXPECT_EQ(std::get<DriveCommand>(out[5].payload).v_mps, 0.25);
  EXPECT_EQ(std::get<DriveCommand>(out[5].payload).w_radps, -0.5);
  EXPECT_TRUE(std::get<LidarMotor>(out[10].payload).on);
  const auto& ack = std::get<CommandAck>(out[12].payload);
  EXPECT_EQ(ack.acked_sequence, 77u);
  EXPECT_EQ(ack.result, AckResult::kEmergencyStopLatched);
  EXPECT_EQ(ack.echo_time, TimeFromNanoseconds(-5));
  const auto& st = std::get<LinkStatus>(out[13].payload);
  EXPECT_EQ(st.battery_voltage_v, 12.25f);
  EXPECT_EQ(st.watchdog, WatchdogState::kTripped);
  EXPECT_TRUE(st.emergency_stop_latched && st.client_authenticated && st.lidar_motor_on);
  EXPECT_EQ(st.device_bytes[0], 123456789012ull);
  EXPECT_EQ(st.applied_w_radps, -0.05);
  const auto& tel = std::get<Telemetry>(out[14].payload);
  EXPECT_EQ(tel.device, uint8_t(LinkDevice::kImu));
  EXPECT_EQ(tel.receive_time, TimeFromNanoseconds(987654321));
  EXPECT_EQ(tel.bytes, (Bytes{0x5A, 0xA5, 0x01, 0x02, 0xE7, 0x5C}));
  EXPECT_EQ(std::get<UnknownMessage>(out.back().payload).type, 0x7F);
  EXPECT_EQ(d.stats().unknown_types, 1u);
  EXPECT_EQ(d.stats().codec.frames_ok, payloads.size());
  EXPECT_EQ(d.stats().codec.bytes_skipped, 0u);
  EXPECT_EQ(d.stats().sequence[0].gaps, 0u);
  ExpectAccounting(d);

  // ParseLinkFrame on each frame alone gives the same.
  size_t pos = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    const size_t size = kLinkFrameOverhead + out[i].header.payload_size;
    LinkMessage m;
    ASSERT_TRUE(ParseLinkFrame(stream.data() + pos, size, &m).ok()) << i;
    EXPECT_EQ(PayloadBytes(m.payload), PayloadBytes(payloads[i]));
    pos += size;
  }
  EXPECT_EQ(pos, stream.size());
}

TEST(LinkDecoderTest, SplitAtEveryOffsetAndByteByByte) {
  std::vector<LinkPayload> payloads;
  const Bytes stream = EncodeAll(0, &payloads);
  LinkDecoder whole;
  const auto reference = whole.Feed(stream);
  ASSERT_EQ(reference.size(), payloads.size());
  for (size_t k = 0; k <= stream.size(); ++k) {
    LinkDecoder d;
    std::vector<LinkMessage> out;
    d.Feed(stream.data(), k, &out);
    d.Feed(stream.data() + k, stream.size() - k, &out);
    ExpectSameMessages(out, reference);
    EXPECT_EQ(d.BufferedBytes(), 0u);
    EXPECT_EQ(d.stats().codec.bytes_skipped, 0u) << k;
  }
  LinkDecoder bytewise;
  std::vector<LinkMessage> out;
  for (uint8_t b : stream) bytewise.Feed(&b, 1, &out);
  ExpectSameMessages(out, reference);
  ExpectAccounting(bytewise);
}

TEST(LinkDecoderTest, KeepsRawFramesForTheRecorder) {
  LinkEncoder enc(LinkSender::kAgent);
  const Bytes a = enc.EncodeDrive(kT0, 1, 2);
  const Bytes b = enc.EncodeHeartbeat(kT0);
  LinkDecoderOptions options;
  options.keep_raw_frames = true;
  LinkDecoder d(options);
  Bytes stream = a;
  stream.insert(stream.end(), b.begin(), b.end());
  const auto out = d.Feed(stream);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].raw, a);
  EXPECT_EQ(out[1].raw, b);
}

TEST(LinkDecoderTest, GarbageAndCorruptFramesAreRejectedAndCountedGoodOnesSurvive) {
  std::mt19937 rng(11);
  LinkEncoder enc(LinkSender::kAgent);
  Bytes stream;
  std::vector<uint32_t> good_sequences;
  auto add_good = [&](int i) {
    const Bytes f = enc.EncodeDrive(kT0, 0.01 * i, -0.02 * i);
    good_sequences.push_back(enc.next_sequence() - 1);
    stream.insert(stream.end(), f.begin(), f.end());
  };
  // Frames from another encoder: corrupted in various ways, never counted as good.
  LinkEncoder bad_enc(LinkSender::kClient);
  for (int i = 0; i < 40; ++i) {
    add_good(i);
    switch (i % 8) {
      case 0: {  // Random garbage including sync bytes.
        for (int k = 0; k < 50; ++k) stream.push_back(k % 9 == 0 ? kLinkSync1 : uint8_t(rng()));
        break;
      }
      case 1: {  // A bit flip in the payload: frame CRC.
        Bytes f = bad_enc.EncodeDrive(kT0, 1, 1);
        f[30] ^= 0x10;
        stream.insert(stream.end(), f.begin(), f.end());
        break;
      }
      case 2: {  // A bit flip in the header: header CRC.
        Bytes f = bad_enc.EncodeDrive(kT0, 1, 1);
        f[9] ^= 0x01;
        stream.insert(stream.end(), f.begin(), f.end());
        break;
      }
      case 3: {  // A truncated frame (connection cut mid-frame), then the next good one.
        Bytes f = bad_enc.Encode(kT0, Telemetry{1, kT0, Bytes(100, 0xAA)});
        stream.insert(stream.end(), f.begin(), f.begin() + 60);
        break;
      }
      case 4: {  // Unknown version (3: newer than this code).
        Bytes f = bad_enc.EncodeHeartbeat(kT0);
        f[2] = 3;
        stream.insert(stream.end(), f.begin(), f.end());
        break;
      }
      case 5: {  // Oversized length with a valid header CRC: rejected without waiting.
        Bytes f = bad_enc.EncodeHeartbeat(kT0);
        f[20] = 0x01;
        f[21] = 0x00;
        f[22] = 0x01;  // 65537
        const uint32_t crc = Crc32c(f.data(), 24);
        for (int k = 0; k < 4; ++k) f[24 + k] = uint8_t(crc >> (8 * k));
        stream.insert(stream.end(), f.begin(), f.end());
        break;
      }
      case 6: {  // Only the sync bytes.
        stream.push_back(kLinkSync1);
        stream.push_back(kLinkSync2);
        break;
      }
      default:
        break;
    }
  }
  add_good(99);
  for (size_t chunk : {size_t(1), size_t(3), size_t(64), stream.size()}) {
    LinkDecoder d;
    std::vector<LinkMessage> out;
    for (size_t pos = 0; pos < stream.size(); pos += chunk) {
      d.Feed(stream.data() + pos, std::min(chunk, stream.size() - pos), &out);
    }
    ASSERT_EQ(out.size(), good_sequences.size()) << chunk << " " << d.stats().ToString();
    for (size_t i = 0; i < out.size(); ++i) {
      EXPECT_EQ(out[i].header.sequence, good_sequences[i]);
      EXPECT_EQ(out[i].header.sender, LinkSender::kAgent);
    }
    const LinkDecoderStats& s = d.stats();
    EXPECT_GE(s.codec.checksum_errors, 10u);
    EXPECT_GE(s.codec.length_errors, 5u);
    EXPECT_GE(s.codec.framing_errors, 5u);
    EXPECT_GT(s.codec.bytes_skipped, 0u);
    EXPECT_EQ(s.sequence[0].gaps, 0u);
    EXPECT_EQ(s.sequence[1].frames, 0u);
    ExpectAccounting(d);
  }
}

TEST(LinkDecoderTest, OversizedLengthIsRejectedAtOnce) {
  Bytes f;
  AppendLinkFrame(LinkSender::kClient, 0, kT0, Heartbeat{}, &f);
  f[22] = 0x01;  // payload_size = 65536 + 0 -> 0x00010000: at the limit, allowed...
  f[23] = 0x01;  // ... 0x01010000: beyond it.
  const uint32_t crc = Crc32c(f.data(), 24);
  for (int k = 0; k < 4; ++k) f[24 + k] = uint8_t(crc >> (8 * k));
  LinkDecoder d;
  d.Feed(Bytes(f.begin(), f.begin() + 28));
  EXPECT_EQ(d.stats().codec.length_errors, 1u);
  EXPECT_EQ(d.BufferedBytes(), 0u);
  // A decoder with a lower limit (the agent) rejects smaller frames too.
  LinkDecoderOptions options;
  options.max_payload = 16;
  LinkDecoder small(options);
  LinkEncoder enc(LinkSender::kClient);
  EXPECT_EQ(small.Feed(enc.Encode(kT0, Telemetry{1, kT0, Bytes(10, 1)})).size(), 0u);
  EXPECT_EQ(small.stats().codec.length_errors, 1u);
  EXPECT_EQ(small.Feed(enc.EncodeDrive(kT0, 1, 0)).size(), 1u);
}

TEST(LinkDecoderTest, BadPayloadsAreConsumedAndCounted) {
  LinkDecoder d;
  Bytes stream;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  AppendLinkFrame(LinkSender::kClient, 0, kT0, DriveCommand{nan, 0}, &stream);
  AppendLinkFrame(LinkSender::kClient, 1, kT0, DriveCommand{0, INFINITY}, &stream);
  const uint8_t one = 1, two = 2;
  AppendRawLinkFrame(LinkSender::kClient, 2, kT0, uint8_t(LinkMessageType::kStop), &one, 1,
                     &stream);  // Stop with a payload byte.
  AppendRawLinkFrame(LinkSender::kClient, 3, kT0, uint8_t(LinkMessageType::kLidarMotor), &two, 1,
                     &stream);                  // LidarMotor 2.
  const Bytes short_hello = {1, 0, 0, 5, 'a'};  // Name announced 5 bytes, 1 present.
  AppendRawLinkFrame(LinkSender::kClient, 4, kT0, uint8_t(LinkMessageType::kHello),
                     short_hello.data(), short_hello.size(), &stream);
  AppendRawLinkFrame(static_cast<LinkSender>(9), 5, kT0, uint8_t(LinkMessageType::kHeartbeat),
                     nullptr, 0, &stream);  // Unknown sender.
  AppendLinkFrame(LinkSender::kClient, 6, kT0, Heartbeat{}, &stream);
  const auto out = d.Feed(stream);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].header.sequence, 6u);
  EXPECT_EQ(d.stats().codec.payload_errors, 6u);
  EXPECT_EQ(d.stats().codec.bytes_skipped, 0u);
  ExpectAccounting(d);

  LinkMessage m;
  Bytes nan_frame;
  AppendLinkFrame(LinkSender::kClient, 0, kT0, DriveCommand{nan, 0}, &nan_frame);
  const sweepscan::Status s = ParseLinkFrame(nan_frame.data(), nan_frame.size(), &m);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("non-finite"), std::string::npos) << s.message();
}

TEST(LinkDecoderTest, SequenceGapsAreCountedPerSender) {
  Bytes stream;
  for (uint32_t seq : {0u, 1u, 2u, 5u, 6u, 10u}) {
    AppendLinkFrame(LinkSender::kAgent, seq, kT0, Heartbeat{}, &stream);
  }
  // The client's own numbering, interleaved, wrapping at 2^32 without a gap.
  for (uint32_t seq : {0xFFFFFFFEu, 0xFFFFFFFFu, 0u, 1u}) {
    AppendLinkFrame(LinkSender::kClient, seq, kT0, Heartbeat{}, &stream);
  }
  AppendLinkFrame(LinkSender::kAgent, 0, kT0, Heartbeat{}, &stream);  // Agent restarted.
  AppendLinkFrame(LinkSender::kAgent, 1, kT0, Heartbeat{}, &stream);
  LinkDecoder d;
  EXPECT_EQ(d.Feed(stream).size(), 12u);
  const auto& agent = d.stats().sequence[0];
  const auto& client = d.stats().sequence[1];
  EXPECT_EQ(agent.frames, 8u);
  EXPECT_EQ(agent.gaps, 2u);
  EXPECT_EQ(agent.frames_missing, 2u + 3u);
  EXPECT_EQ(agent.restarts, 1u);
  EXPECT_EQ(client.frames, 4u);
  EXPECT_EQ(client.gaps, 0u);
  EXPECT_EQ(client.restarts, 0u);
}

TEST(LinkEncoderTest, LongTelemetryIsSplitIntoFramesWithinTheLimit) {
  LinkEncoder enc(LinkSender::kAgent, 5);
  Bytes big(kLinkMaxTelemetryBytes * 2 + 10);
  for (size_t i = 0; i < big.size(); ++i) big[i] = uint8_t(i * 31);
  const Bytes frames = enc.EncodeTelemetry(kT0, LinkDevice::kLidar, kT0, big.data(), big.size());
  EXPECT_EQ(enc.next_sequence(), 8u);
  LinkDecoder d;
  const auto out = d.Feed(frames);
  ASSERT_EQ(out.size(), 3u);
  Bytes joined;
  for (const auto& m : out) {
    const auto& t = std::get<Telemetry>(m.payload);
    EXPECT_EQ(t.device, uint8_t(LinkDevice::kLidar));
    joined.insert(joined.end(), t.bytes.begin(), t.bytes.end());
  }
  EXPECT_EQ(joined, big);
  Bytes too_big;
  EXPECT_FALSE(AppendLinkFrame(LinkSender::kAgent, 0, kT0,
                               UnknownMessage{0x77, Bytes(kLinkMaxPayload + 1)}, &too_big));
  EXPECT_TRUE(too_big.empty());
}

TEST(ParseLinkFrameTest, RefusesWithAReason) {
  Bytes f;
  AppendLinkFrame(LinkSender::kAgent, 1, kT0, DriveCommand{1, 2}, &f);
  LinkMessage m;
  ASSERT_TRUE(ParseLinkFrame(f.data(), f.size(), &m).ok());
  auto expect_error = [&](Bytes bytes, const std::string& what) {
    const sweepscan::Status s = ParseLinkFrame(bytes.data(), bytes.size(), &m);
    EXPECT_FALSE(s.ok()) << what;
    EXPECT_NE(s.message().find(what), std::string::npos) << s.message();
  };
  expect_error(Bytes(f.begin(), f.begin() + 10), "shorter than");
  Bytes b = f;
  b[0] = 0;
  expect_error(b, "sync");
  b = f;
  b[2] = 9;
  expect_error(b, "version 9");
  b = f;
  b[13] ^= 1;
  expect_error(b, "header CRC");
  b = f;
  b[35] ^= 1;
  expect_error(b, "frame CRC");
  b = f;
  b.push_back(0);
  expect_error(b, "header announces");
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
