// Shared pieces of the vendor byte codecs (X4 lidar, HI219 IMU, motor board):
// decoder counters, a small reassembly buffer and bounds-checked field readers.
//
// Every decoder here is a plain object used from one thread at a time (the
// processing thread, or the simulator's device thread). No Qt.
#ifndef SWEEPSCAN_HARDWARE_CODECS_CODEC_COMMON_H_
#define SWEEPSCAN_HARDWARE_CODECS_CODEC_COMMON_H_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "core/common/time.h"

namespace sweepscan {
namespace hardware {

// Counters every streaming decoder keeps. Accounting rule, checked by the
// tests: bytes_in == bytes_in_frames + bytes_skipped + bytes still buffered
// (see each decoder's BufferedBytes()).
struct DecoderStats {
  uint64_t bytes_in = 0;         // Every byte passed to Feed().
  uint64_t bytes_in_frames = 0;  // Bytes of accepted frames (headers, packets, payloads).
  uint64_t frames_ok = 0;        // Frames that passed every check and were decoded.
  uint64_t bytes_skipped = 0;    // Bytes dropped while searching for a header (garbage and
                                 // the first byte of every rejected frame candidate).
  uint64_t checksum_errors = 0;  // Candidates with a bad CRC / XOR / check code.
  uint64_t length_errors = 0;    // Candidates with an impossible length field.
  uint64_t framing_errors = 0;   // Candidates with a wrong tail byte or an unknown header.
  uint64_t payload_errors = 0;   // Good checksum, but the content could not be fully parsed.

  std::string ToString() const;
};

// Growable byte buffer with a read cursor. Feed() appends, the frame parser
// advances the cursor, Compact() drops consumed bytes once per Feed() so the
// cost stays O(bytes) however the stream is chunked.
class StreamBuffer {
 public:
  void Append(const uint8_t* data, size_t n) {
    if (n > 0 && data != nullptr) bytes_.insert(bytes_.end(), data, data + n);
  }
  const uint8_t* data() const { return bytes_.data() + pos_; }
  size_t size() const { return bytes_.size() - pos_; }
  void Consume(size_t n) { pos_ += (n < size() ? n : size()); }
  // Resync: drops the first byte and everything up to the next `sync` byte
  // (or all that is buffered); returns how many bytes were dropped, which
  // the decoders count as skipped. memchr makes long garbage cheap.
  size_t SkipToNext(uint8_t sync) {
    const uint8_t* p = data();
    const size_t avail = size();
    if (avail == 0) return 0;
    const void* next = std::memchr(p + 1, sync, avail - 1);
    const size_t skip = next ? static_cast<size_t>(static_cast<const uint8_t*>(next) - p) : avail;
    Consume(skip);
    return skip;
  }
  void Compact() {
    bytes_.erase(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(pos_));
    pos_ = 0;
  }
  void Clear() {
    bytes_.clear();
    pos_ = 0;
  }

 private:
  std::vector<uint8_t> bytes_;
  size_t pos_ = 0;
};

// Field readers; callers check the length first.
inline uint16_t ReadU16Le(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (static_cast<uint16_t>(p[1]) << 8));
}
inline uint32_t ReadU32Le(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
inline uint16_t ReadU16Be(const uint8_t* p) {
  return static_cast<uint16_t>((static_cast<uint16_t>(p[0]) << 8) | p[1]);
}
inline int16_t ReadI16Le(const uint8_t* p) { return static_cast<int16_t>(ReadU16Le(p)); }
inline int16_t ReadI16Be(const uint8_t* p) { return static_cast<int16_t>(ReadU16Be(p)); }
float ReadF32Le(const uint8_t* p);

inline void AppendU16Le(uint16_t v, std::vector<uint8_t>* out) {
  out->push_back(static_cast<uint8_t>(v & 0xFF));
  out->push_back(static_cast<uint8_t>(v >> 8));
}
inline void AppendU32Le(uint32_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xFF));
}
inline void AppendU16Be(uint16_t v, std::vector<uint8_t>* out) {
  out->push_back(static_cast<uint8_t>(v >> 8));
  out->push_back(static_cast<uint8_t>(v & 0xFF));
}
void AppendF32Le(float v, std::vector<uint8_t>* out);
inline void AppendU64Le(uint64_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xFF));
}
inline uint64_t ReadU64Le(const uint8_t* p) {
  return static_cast<uint64_t>(ReadU32Le(p)) | (static_cast<uint64_t>(ReadU32Le(p + 4)) << 32);
}
inline void AppendI64Le(int64_t v, std::vector<uint8_t>* out) {
  AppendU64Le(static_cast<uint64_t>(v), out);
}
inline int64_t ReadI64Le(const uint8_t* p) { return static_cast<int64_t>(ReadU64Le(p)); }
// IEEE 754 binary64, little-endian; memcpy is the defined way to reinterpret.
inline void AppendF64Le(double v, std::vector<uint8_t>* out) {
  static_assert(sizeof(double) == 8, "double must be IEEE 754 binary64");
  uint64_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  AppendU64Le(bits, out);
}
inline double ReadF64Le(const uint8_t* p) {
  const uint64_t bits = ReadU64Le(p);
  double v;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

// Rounds to nearest (halves away from zero) and saturates to the integer
// type's range; NaN becomes 0. Used by every encoder so out-of-range inputs
// never wrap around.
template <typename Int>
Int SaturatingRound(double value) {
  if (!(value == value)) return 0;  // NaN
  const double lo = static_cast<double>(std::numeric_limits<Int>::min());
  const double hi = static_cast<double>(std::numeric_limits<Int>::max());
  const double r = value >= 0 ? value + 0.5 : value - 0.5;
  if (r <= lo) return std::numeric_limits<Int>::min();
  if (r >= hi) return std::numeric_limits<Int>::max();
  return static_cast<Int>(r);  // Truncation toward zero after the +-0.5 shift.
}

// Serial transmission time of `bytes` bytes on an 8N1 line (start bit, 8
// data bits, stop bit: 10 bits a byte) at `baud` bits per second:
// bytes * 10 / baud, rounded to the nearest ns. 0 when baud <= 0 or is not
// finite (no transmission term). E.g. an 82-byte HI219 0x91 frame at 115200
// baud: 7 118 056 ns; a 24-byte motor feedback frame: 2 083 333 ns; a
// 90-byte X4 packet (40 samples) at 128000 baud: 7 031 250 ns.
inline Duration SerialTransmissionTime(double bytes, double baud) {
  if (!(baud > 0) || !std::isfinite(baud)) return Duration(0);
  return Duration(static_cast<int64_t>(std::llround(bytes * 10.0 / baud * 1e9)));
}

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_CODECS_CODEC_COMMON_H_
