// Frames of the robot link (header, CRCs, tags), the encoder and the stream
// decoder (docs/protocol.md, "Frame"); the payloads are in link_payload.cc.
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

}  // namespace

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
