#include "hardware/codecs/x4_codec.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/common/rounding.h"

namespace sweepscan {
namespace hardware {
namespace {

constexpr double kPi = 3.14159265358979323846;
// A revolution that grows past this many samples without a ring-start packet
// is abandoned (at 5 kHz and the slowest rated 5 Hz a revolution has ~1000).
constexpr size_t kMaxSamplesPerScan = 20000;

Duration SecondsToDuration(double seconds) {
  return Duration(RoundHalfAway(seconds * 1e9));
}

}  // namespace

// ---------------------------------------------------------------------------
// Commands.

std::vector<uint8_t> EncodeX4Command(uint8_t cmd) { return {kX4CommandSync, cmd}; }

std::vector<uint8_t> EncodeX4CommandWithPayload(uint8_t cmd, const std::vector<uint8_t>& payload) {
  const size_t size = std::min<size_t>(payload.size(), 255);
  std::vector<uint8_t> out;
  out.reserve(size + 4);
  out.push_back(kX4CommandSync);
  out.push_back(static_cast<uint8_t>(cmd | 0x80));
  out.push_back(static_cast<uint8_t>(size));
  out.insert(out.end(), payload.begin(), payload.begin() + static_cast<std::ptrdiff_t>(size));
  uint8_t x = 0;
  for (uint8_t b : out) x ^= b;
  out.push_back(x);
  return out;
}

// ---------------------------------------------------------------------------
// Angle math.

double X4AngleCorrectionDeg(double distance_mm) {
  if (!(distance_mm > 0)) return 0.0;
  return std::atan(kX4CorrectionK * (kX4CorrectionD0 - distance_mm) /
                   (kX4CorrectionD0 * distance_mm)) *
         180.0 / kPi;
}

double WrapDegrees360(double deg) {
  if (!std::isfinite(deg)) return 0.0;
  double w = std::fmod(deg, 360.0);
  if (w < 0) w += 360.0;
  // fmod of a tiny negative number plus 360 can round to exactly 360.
  if (w >= 360.0) w = 0.0;
  return w;
}

uint16_t X4DegreesToField(double deg) {
  // 360 deg = 23040 units of 1/64 deg; the rounded value wraps to 0.
  long units = std::lround(WrapDegrees360(deg) * 64.0);
  if (units >= 360 * 64) units -= 360 * 64;
  return static_cast<uint16_t>((units << 1) | 1);
}

uint16_t X4CheckCode(uint8_t ct, uint8_t lsn, uint16_t fsa, uint16_t lsa, const uint8_t* samples_le,
                     size_t sample_count) {
  uint16_t cs = kX4PacketHeader ^ fsa ^ lsa ^ static_cast<uint16_t>((lsn << 8) | ct);
  for (size_t i = 0; i < sample_count; ++i) cs ^= ReadU16Le(samples_le + 2 * i);
  return cs;
}

std::string X4DeviceInfo::SerialString() const {
  static const char kHex[] = "0123456789ABCDEF";
  std::string s;
  for (uint8_t b : serial) {
    if (b >= 16) s.push_back(kHex[b >> 4]);
    s.push_back(kHex[b & 0xF]);
  }
  return s;
}

bool X4DecoderOptions::IsValid(std::string* error) const {
  auto fail = [error](const char* msg) {
    if (error != nullptr) *error = msg;
    return false;
  };
  if (!(sample_rate_hz > 0) || !std::isfinite(sample_rate_hz)) {
    return fail("sample_rate_hz must be > 0");
  }
  if (!std::isfinite(baud_rate)) return fail("baud_rate must be finite");
  if (max_samples_per_packet < 1 || max_samples_per_packet > kX4MaxSamplesPerPacket) {
    return fail("max_samples_per_packet must be in [1, 255]");
  }
  return true;
}

// ---------------------------------------------------------------------------
// Decoder.

X4Decoder::X4Decoder(const X4DecoderOptions& options) : options_(options) {
  // Invalid options are clamped rather than trusted: a decoder never crashes.
  if (!(options_.sample_rate_hz > 0) || !std::isfinite(options_.sample_rate_hz)) {
    options_.sample_rate_hz = 5000.0;
  }
  if (!std::isfinite(options_.baud_rate)) options_.baud_rate = 0;
  options_.max_samples_per_packet =
      std::clamp<size_t>(options_.max_samples_per_packet, 1, kX4MaxSamplesPerPacket);
}

void X4Decoder::Reset() {
  buffer_.Clear();
  line_known_ = false;
  scan_open_ = false;
  current_scan_ = X4Scan();
}

void X4Decoder::NoteError() {
  if (scan_open_) current_scan_.had_errors = true;
  // Bytes were lost or garbled: the next packet may not follow the last one.
  line_known_ = false;
}

void X4Decoder::Feed(const uint8_t* data, size_t n, Time receive_time) {
  if (data == nullptr) n = 0;
  stats_.bytes_in += n;
  buffer_.Append(data, n);
  while (buffer_.size() > 0) {
    const uint8_t* p = buffer_.data();
    const size_t avail = buffer_.size();
    Parse result = Parse::kRejected;
    bool candidate = false;
    if (p[0] == kX4ResponseSync1 || p[0] == kX4PacketSync1) {
      if (avail < 2) break;  // Cannot tell yet whether this is a header.
      if (p[0] == kX4ResponseSync1 && p[1] == kX4ResponseSync2) {
        candidate = true;
        result = TryResponse(p, avail, receive_time);
      } else if (p[0] == kX4PacketSync1 && p[1] == kX4PacketSync2) {
        candidate = true;
        result = TryPacket(p, avail, receive_time);
      }
    }
    if (!candidate) {
      // Skip to the next byte that could start a header.
      size_t k = 1;
      while (k < avail && p[k] != kX4ResponseSync1 && p[k] != kX4PacketSync1) ++k;
      buffer_.Consume(k);
      stats_.bytes_skipped += k;
      NoteError();
      continue;
    }
    if (result == Parse::kNeedMore) break;
    if (result == Parse::kRejected) {
      // Restart the search one byte later: a good frame may begin inside this one.
      buffer_.Consume(1);
      stats_.bytes_skipped += 1;
      NoteError();
    }
  }
  buffer_.Compact();
}

X4Decoder::Parse X4Decoder::TryResponse(const uint8_t* p, size_t n, Time receive_time) {
  if (n < kX4ResponseHeaderSize) return Parse::kNeedMore;
  const uint32_t size = ReadU32Le(p + 2) & 0x3FFFFFFFu;
  const uint8_t type = p[6];
  if (type == kX4ResponseTypeScan && size == kX4ScanResponseSize) {
    // The packet stream follows; its packets carry their own framing.
    buffer_.Consume(kX4ResponseHeaderSize);
    stats_.bytes_in_frames += kX4ResponseHeaderSize;
    ++stats_.frames_ok;
    ++scan_start_headers_;
    // A new scan session: a revolution in progress belongs to the old one.
    scan_open_ = false;
    line_known_ = false;
    current_scan_ = X4Scan();
    return Parse::kConsumed;
  }
  if (type == kX4ResponseTypeDeviceInfo && size == kX4DeviceInfoSize) {
    const size_t total = kX4ResponseHeaderSize + kX4DeviceInfoSize;
    if (n < total) return Parse::kNeedMore;
    const uint8_t* q = p + kX4ResponseHeaderSize;
    X4DeviceInfo info;
    info.model = q[0];
    info.firmware = ReadU16Le(q + 1);
    info.hardware = q[3];
    std::copy(q + 4, q + 20, info.serial.begin());
    info.receive_time = receive_time;
    device_infos_.push_back(info);
    line_known_ = false;  // The sample stream was interrupted.
    buffer_.Consume(total);
    stats_.bytes_in_frames += total;
    ++stats_.frames_ok;
    return Parse::kConsumed;
  }
  if (type == kX4ResponseTypeHealth && size == kX4HealthSize) {
    const size_t total = kX4ResponseHeaderSize + kX4HealthSize;
    if (n < total) return Parse::kNeedMore;
    const uint8_t* q = p + kX4ResponseHeaderSize;
    X4Health health;
    health.status = q[0];
    health.error_code = ReadU16Le(q + 1);
    health.receive_time = receive_time;
    health_.push_back(health);
    line_known_ = false;  // The sample stream was interrupted.
    buffer_.Consume(total);
    stats_.bytes_in_frames += total;
    ++stats_.frames_ok;
    return Parse::kConsumed;
  }
  ++stats_.framing_errors;
  return Parse::kRejected;
}

X4Decoder::Parse X4Decoder::TryPacket(const uint8_t* p, size_t n, Time receive_time) {
  if (n < kX4PacketHeaderSize) return Parse::kNeedMore;
  const size_t lsn = p[3];
  if (lsn == 0 || lsn > options_.max_samples_per_packet) {
    ++stats_.length_errors;
    return Parse::kRejected;
  }
  const size_t total = kX4PacketHeaderSize + 2 * lsn;
  if (n < total) return Parse::kNeedMore;
  const uint16_t cs =
      X4CheckCode(p[2], p[3], ReadU16Le(p + 4), ReadU16Le(p + 6), p + kX4PacketHeaderSize, lsn);
  if (cs != ReadU16Le(p + 8)) {
    ++stats_.checksum_errors;
    return Parse::kRejected;
  }
  X4Packet packet;
  const Time t_last = LastSampleTime(lsn, total, receive_time);
  DecodePacket(p, lsn, receive_time, t_last, &packet);
  buffer_.Consume(total);
  stats_.bytes_in_frames += total;
  ++stats_.frames_ok;
  AddToScan(packet);
  if (options_.keep_packets) packets_.push_back(std::move(packet));
  return Parse::kConsumed;
}

Time X4Decoder::LastSampleTime(size_t lsn, size_t packet_bytes, Time receive_time) {
  const Time received = receive_time - options_.latency;
  if (!(options_.baud_rate > 0)) return received;
  const Duration tx = SerialTransmissionTime(static_cast<double>(packet_bytes), options_.baud_rate);
  // e_k = max(R_k - latency, e_{k-1} + tx_k).
  Time end = received;
  if (line_known_) end = std::max(end, line_end_ + tx);
  const Time begin = end - tx;  // b_k
  Time t_last = begin;
  if (line_known_ && begin <= line_end_) {
    // Queued behind packet k-1: the samples followed its samples at the
    // sample rate, and were all taken before the transmission began.
    const Time by_clock = previous_last_sample_ +
                          SecondsToDuration(static_cast<double>(lsn) / options_.sample_rate_hz);
    t_last = std::min(begin, by_clock);
  }
  line_known_ = true;
  line_end_ = end;
  previous_last_sample_ = t_last;
  return t_last;
}

void X4Decoder::DecodePacket(const uint8_t* p, size_t lsn, Time receive_time, Time t_last,
                             X4Packet* packet) const {
  packet->ct = p[2];
  packet->ring_start = (p[2] & 0x01) != 0;
  packet->scan_frequency_hz = (p[2] >> 1) * 0.1;
  packet->fsa = ReadU16Le(p + 4);
  packet->lsa = ReadU16Le(p + 6);
  packet->receive_time = receive_time;
  // First level: A_i = A_FSA + diff * i / (LSN - 1), diff = A_LSA - A_FSA (+360 if < 0).
  const double a_fsa = X4FieldToDegrees(packet->fsa);
  const double a_lsa = X4FieldToDegrees(packet->lsa);
  packet->first_level_start_deg = a_fsa;
  packet->first_level_end_deg = a_lsa;
  double diff = a_lsa - a_fsa;
  if (diff < 0) diff += 360.0;
  // Times: t_i = t_last - (LSN-1-i) * period.
  const double period_s = 1.0 / options_.sample_rate_hz;

  packet->samples.resize(lsn);
  for (size_t i = 0; i < lsn; ++i) {
    X4Sample& s = packet->samples[i];
    s.raw = ReadU16Le(p + kX4PacketHeaderSize + 2 * i);
    s.interference = static_cast<uint8_t>(s.raw & 0x03);
    s.distance_mm = static_cast<double>(s.raw >> 2);
    s.valid = s.distance_mm > 0;
    double a =
        lsn > 1 ? a_fsa + diff * static_cast<double>(i) / static_cast<double>(lsn - 1) : a_fsa;
    // Second level, only for valid samples.
    if (s.valid) a += X4AngleCorrectionDeg(s.distance_mm);
    s.angle_deg = WrapDegrees360(a);
    s.time = t_last - SecondsToDuration(static_cast<double>(lsn - 1 - i) * period_s);
  }
}

void X4Decoder::AddToScan(const X4Packet& packet) {
  if (packet.ring_start) {
    if (scan_open_ && !current_scan_.samples.empty()) {
      current_scan_.index = next_scan_index_++;
      current_scan_.end_time = current_scan_.samples.back().time;
      if (!(options_.drop_scans_with_errors && current_scan_.had_errors)) {
        scans_.push_back(std::move(current_scan_));
      }
    }
    current_scan_ = X4Scan();
    current_scan_.scan_frequency_hz = packet.scan_frequency_hz;
    scan_open_ = true;
  }
  if (!scan_open_) {
    samples_before_first_ring_ += packet.samples.size();
    return;
  }
  if (current_scan_.samples.size() + packet.samples.size() > kMaxSamplesPerScan) {
    // Ring-start packets are being lost; give up on this revolution.
    scan_open_ = false;
    current_scan_ = X4Scan();
    return;
  }
  if (current_scan_.samples.empty() && !packet.samples.empty()) {
    current_scan_.start_time = packet.samples.front().time;
  }
  current_scan_.samples.insert(current_scan_.samples.end(), packet.samples.begin(),
                               packet.samples.end());
  ++current_scan_.packet_count;
}

std::vector<X4Packet> X4Decoder::TakePackets() { return std::exchange(packets_, {}); }
std::vector<X4Scan> X4Decoder::TakeScans() { return std::exchange(scans_, {}); }
std::vector<X4DeviceInfo> X4Decoder::TakeDeviceInfos() { return std::exchange(device_infos_, {}); }
std::vector<X4Health> X4Decoder::TakeHealth() { return std::exchange(health_, {}); }

// ---------------------------------------------------------------------------
// Encoders.

std::vector<uint8_t> EncodeX4ScanStartHeader() {
  return {0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81};
}

std::vector<uint8_t> EncodeX4DeviceInfo(const X4DeviceInfo& info) {
  std::vector<uint8_t> out = {0xA5, 0x5A, 0x14, 0x00, 0x00, 0x00, kX4ResponseTypeDeviceInfo};
  out.push_back(info.model);
  AppendU16Le(info.firmware, &out);
  out.push_back(info.hardware);
  out.insert(out.end(), info.serial.begin(), info.serial.end());
  return out;
}

std::vector<uint8_t> EncodeX4Health(const X4Health& health) {
  std::vector<uint8_t> out = {0xA5, 0x5A, 0x03, 0x00, 0x00, 0x00, kX4ResponseTypeHealth};
  out.push_back(health.status);
  AppendU16Le(health.error_code, &out);
  return out;
}

bool EncodeX4ScanPacket(const X4PacketToEncode& packet, std::vector<uint8_t>* out) {
  const size_t lsn = packet.distances_mm.size();
  if (out == nullptr || lsn == 0 || lsn > kX4MaxSamplesPerPacket) return false;

  std::vector<uint8_t> samples;
  samples.reserve(2 * lsn);
  for (size_t i = 0; i < lsn; ++i) {
    const uint16_t d =
        std::min<uint16_t>(SaturatingRound<uint16_t>(packet.distances_mm[i]), kX4MaxDistanceMm);
    const uint8_t flags = i < packet.interference.size() ? (packet.interference[i] & 0x03) : 0;
    AppendU16Le(static_cast<uint16_t>((d << 2) | flags), &samples);
  }
  // Invert the second level with the distances the decoder will see
  // (integer mm): A_first_level = A_corrected - correction(d).
  const double d_first = static_cast<double>(ReadU16Le(samples.data()) >> 2);
  const double d_last = static_cast<double>(ReadU16Le(samples.data() + 2 * (lsn - 1)) >> 2);
  const uint16_t fsa = X4DegreesToField(packet.first_angle_deg - X4AngleCorrectionDeg(d_first));
  const uint16_t lsa =
      lsn == 1 ? fsa : X4DegreesToField(packet.last_angle_deg - X4AngleCorrectionDeg(d_last));
  uint8_t ct = 0;
  if (packet.ring_start) {
    const uint8_t freq =
        std::min<uint8_t>(SaturatingRound<uint8_t>(packet.scan_frequency_hz * 10.0), 127);
    ct = static_cast<uint8_t>((freq << 1) | 1);
  }
  const uint16_t cs = X4CheckCode(ct, static_cast<uint8_t>(lsn), fsa, lsa, samples.data(), lsn);

  out->reserve(out->size() + kX4PacketHeaderSize + samples.size());
  out->push_back(kX4PacketSync1);
  out->push_back(kX4PacketSync2);
  out->push_back(ct);
  out->push_back(static_cast<uint8_t>(lsn));
  AppendU16Le(fsa, out);
  AppendU16Le(lsa, out);
  AppendU16Le(cs, out);
  out->insert(out->end(), samples.begin(), samples.end());
  return true;
}

}  // namespace hardware
}  // namespace sweepscan
