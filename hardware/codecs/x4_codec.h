// YDLIDAR X4 serial protocol: command encoder, response/packet stream decoder
// with revolution assembly, and the encoders the device simulator uses to
// produce byte-exact lidar output. Byte formats: docs/device-codecs.md
// (source: YDLIDAR/YDLidar-SDK).
//
// Angle convention of every output here: raw X4 degrees in [0, 360), as the
// device reports them (clockwise seen from above the lidar's top cover, 0 at
// the device's forward mark). The mapping to the lidar frame belongs to the
// geometry code, not to the codec.
//
// Threading: X4Decoder is used from one thread at a time; the free functions
// are pure.
#ifndef SWEEPSCAN_HARDWARE_CODECS_X4_CODEC_H_
#define SWEEPSCAN_HARDWARE_CODECS_X4_CODEC_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/time.h"
#include "hardware/codecs/codec_common.h"

namespace sweepscan {
namespace hardware {

// ---------------------------------------------------------------------------
// Constants.

inline constexpr uint8_t kX4CommandSync = 0xA5;
inline constexpr uint8_t kX4CmdScan = 0x60;
inline constexpr uint8_t kX4CmdForceScan = 0x61;
inline constexpr uint8_t kX4CmdStop = 0x65;
inline constexpr uint8_t kX4CmdReset = 0x80;
inline constexpr uint8_t kX4CmdDeviceInfo = 0x90;
inline constexpr uint8_t kX4CmdHealth = 0x92;

inline constexpr uint8_t kX4ResponseSync1 = 0xA5;
inline constexpr uint8_t kX4ResponseSync2 = 0x5A;
inline constexpr size_t kX4ResponseHeaderSize = 7;
inline constexpr uint8_t kX4ResponseTypeScan = 0x81;
inline constexpr uint8_t kX4ResponseTypeDeviceInfo = 0x04;
inline constexpr uint8_t kX4ResponseTypeHealth = 0x06;
inline constexpr uint32_t kX4DeviceInfoSize = 20;
inline constexpr uint32_t kX4HealthSize = 3;
inline constexpr uint32_t kX4ScanResponseSize = 5;
inline constexpr uint8_t kX4ModelCode = 6;

// Scan packet: AA 55 CT LSN FSA(u16) LSA(u16) CS(u16) S[LSN](u16), little-endian.
inline constexpr uint8_t kX4PacketSync1 = 0xAA;
inline constexpr uint8_t kX4PacketSync2 = 0x55;
inline constexpr uint16_t kX4PacketHeader = 0x55AA;
inline constexpr size_t kX4PacketHeaderSize = 10;
inline constexpr size_t kX4MaxSamplesPerPacket = 255;  // LSN is a u8.

// Triangulation geometry of the second-level angle correction (SDK values):
// A += atan(kX4CorrectionK * (kX4CorrectionD0 - d) / (kX4CorrectionD0 * d)).
inline constexpr double kX4CorrectionK = 21.8;
inline constexpr double kX4CorrectionD0 = 155.3;
// FSA/LSA carry the angle as (angle_deg * 64) << 1 | check bit.
inline constexpr double kX4AngleUnitDeg = 1.0 / 64.0;
// Si carries distance_mm << 2 | interference flags; 14 bits of distance.
inline constexpr uint16_t kX4MaxDistanceMm = 0x3FFF;

// ---------------------------------------------------------------------------
// Commands, host to lidar.

// `A5 cmd`.
std::vector<uint8_t> EncodeX4Command(uint8_t cmd);
// `A5 (cmd|0x80) size payload xor`, xor over every byte before it. Payloads
// longer than 255 bytes are truncated to 255 (size is a u8).
std::vector<uint8_t> EncodeX4CommandWithPayload(uint8_t cmd, const std::vector<uint8_t>& payload);

// ---------------------------------------------------------------------------
// Angle math (pure, shared by decoder, encoder and simulator).

// Second-level correction in degrees for a sample at distance_mm (> 0):
// atan(21.8 * (155.3 - d) / (155.3 * d)) * 180 / pi. Returns 0 for d <= 0,
// where the decoder applies no correction.
double X4AngleCorrectionDeg(double distance_mm);
// Wraps any finite angle to [0, 360).
double WrapDegrees360(double deg);
// First-level angle (deg) of an FSA/LSA field: (field >> 1) / 64.
inline double X4FieldToDegrees(uint16_t field) { return (field >> 1) * kX4AngleUnitDeg; }
// Inverse of X4FieldToDegrees: round(wrap(deg) * 64) << 1 | 1 (check bit set,
// as the device sends it). Rounding error at most 1/128 deg.
uint16_t X4DegreesToField(double deg);

// ---------------------------------------------------------------------------
// Decoded records.

struct X4DeviceInfo {
  uint8_t model = 0;      // 6 for an X4.
  uint16_t firmware = 0;  // Major in the high byte, minor in the low byte.
  uint8_t hardware = 0;
  std::array<uint8_t, 16> serial{};
  Time receive_time;

  // Each serial byte as hex without padding (the SDK prints the 16 bytes as
  // digits 0..9 this way).
  std::string SerialString() const;
};

struct X4Health {
  uint8_t status = 0;  // 0 good, 1 warning, 2 error.
  uint16_t error_code = 0;
  Time receive_time;
};

struct X4Sample {
  double angle_deg = 0;      // Corrected (first + second level), wrapped to [0, 360).
  double distance_mm = 0;    // Si >> 2; 0 when invalid.
  uint16_t raw = 0;          // Si as received.
  uint8_t interference = 0;  // Si & 3.
  bool valid = false;        // distance_mm > 0.
  Time time;                 // See X4DecoderOptions for the rule.
};

struct X4Packet {
  bool ring_start = false;       // CT bit 0.
  double scan_frequency_hz = 0;  // CT bits 1..7 * 0.1 Hz; meaningful on ring-start packets.
  uint8_t ct = 0;
  uint16_t fsa = 0;
  uint16_t lsa = 0;
  double first_level_start_deg = 0;  // (FSA >> 1) / 64.
  double first_level_end_deg = 0;    // (LSA >> 1) / 64.
  std::vector<X4Sample> samples;
  Time receive_time;  // Receive time of the Feed() chunk holding the packet's last byte.
};

// One revolution: the samples of a ring-start packet and of every packet up
// to (not including) the next ring-start packet.
struct X4Scan {
  uint64_t index = 0;            // 0 for the first complete revolution since construction.
  double scan_frequency_hz = 0;  // As reported by this revolution's ring-start packet.
  Time start_time;               // Time of the first sample.
  Time end_time;                 // Time of the last sample.
  size_t packet_count = 0;
  // True when a decode error (bad check code, length error, skipped garbage)
  // happened while this revolution was being assembled: a packet is missing.
  bool had_errors = false;
  std::vector<X4Sample> samples;
};

struct X4DecoderOptions {
  // Time-stamp rule (docs/device-codecs.md, "Time stamps on a busy line").
  // The X4 samples at a fixed rate, so within packet k (n_k = LSN samples)
  //   t_i = t_k - (n_k - 1 - i) / sample_rate_hz,
  // where t_k is the time of its last sample. The line carries one byte at a
  // time (8N1: tx_k = bytes_k * 10 / baud_rate), so packet k's transmission
  // ended at
  //   e_k = max(R_k - latency,  e_{k-1} + tx_k)
  // (R_k: receive time of the chunk holding its last byte; e_{k-1} + tx_k:
  // it cannot have finished before the previous packet finished plus its
  // own transmission), and its transmission began at b_k = e_k - tx_k. A packet
  // is sent once its last sample is taken, unless the line is still busy
  // with the previous one: then it waits and b_k = e_{k-1}, which only
  // bounds t_k from above; the sample clock gives it:
  //   idle   (b_k > e_{k-1}):  t_k = b_k
  //   queued (b_k = e_{k-1}):  t_k = min(b_k, t_{k-1} + n_k / sample_rate_hz)
  // The previous packet counts only while the stream is contiguous (no
  // bytes skipped, no response, no Reset() since); otherwise t_k = b_k.
  // baud_rate <= 0 drops the transmission terms and the busy-line rule:
  // t_k = R_k - latency.
  double sample_rate_hz = 5000.0;
  Duration latency{0};
  double baud_rate = 128000.0;
  // Candidate packets with LSN = 0 or LSN > max_samples_per_packet are
  // rejected as length errors (an X4 sends 40 per packet, 1 on ring start).
  size_t max_samples_per_packet = 128;
  // Keep individual packets for TakePackets(); switch off when only
  // revolutions are wanted so the packet queue does not grow.
  bool keep_packets = true;
  // Drop the samples of revolutions that had decode errors instead of emitting them.
  bool drop_scans_with_errors = false;

  bool IsValid(std::string* error) const;
};

// Streaming decoder of everything the lidar sends: response headers
// (`A5 5A ...`) with their payloads, and the scan packet stream (`AA 55 ...`),
// mixed with garbage, split into chunks of any size.
//
// Resync: at each position the decoder looks for `A5 5A` or `AA 55`; other
// bytes are skipped (counted in bytes_skipped). A packet candidate with an
// impossible LSN or a bad check code is rejected and the search restarts one
// byte after its first byte, so a good packet that began inside a bad one is
// still found. A response header whose (size, type) is not one of scan start
// (5, 0x81), device info (20, 0x04) or health (3, 0x06) counts as a framing
// error and is skipped the same way.
class X4Decoder {
 public:
  explicit X4Decoder(const X4DecoderOptions& options = X4DecoderOptions());

  void Feed(const uint8_t* data, size_t n, Time receive_time);
  void Feed(const std::vector<uint8_t>& bytes, Time receive_time) {
    Feed(bytes.data(), bytes.size(), receive_time);
  }

  // Each Take*() returns everything decoded since the previous call, oldest first.
  std::vector<X4Packet> TakePackets();
  std::vector<X4Scan> TakeScans();
  std::vector<X4DeviceInfo> TakeDeviceInfos();
  std::vector<X4Health> TakeHealth();

  const DecoderStats& stats() const { return stats_; }
  uint64_t scan_start_headers() const { return scan_start_headers_; }
  uint64_t scans_completed() const { return next_scan_index_; }
  // Samples seen before the first ring-start packet (never part of a revolution).
  uint64_t samples_before_first_ring() const { return samples_before_first_ring_; }
  size_t BufferedBytes() const { return buffer_.size(); }

  // Forgets buffered bytes and the revolution in progress (e.g. after the
  // port was reopened). Counters are kept.
  void Reset();

 private:
  enum class Parse { kNeedMore, kConsumed, kRejected };
  Parse TryResponse(const uint8_t* p, size_t n, Time receive_time);
  Parse TryPacket(const uint8_t* p, size_t n, Time receive_time);
  // `t_last`: the time of the packet's last sample (the time-stamp rule).
  void DecodePacket(const uint8_t* p, size_t lsn, Time receive_time, Time t_last,
                    X4Packet* packet) const;
  // The time-stamp rule of X4DecoderOptions for a packet of `packet_bytes`
  // bytes and `lsn` samples; advances the busy-line state.
  Time LastSampleTime(size_t lsn, size_t packet_bytes, Time receive_time);
  void AddToScan(const X4Packet& packet);
  void NoteError();

  X4DecoderOptions options_;
  StreamBuffer buffer_;
  DecoderStats stats_;
  uint64_t scan_start_headers_ = 0;
  uint64_t samples_before_first_ring_ = 0;

  // Busy-line state: the previous packet's end of transmission e_{k-1} and
  // last-sample time t_{k-1}, while the stream has been contiguous since it.
  bool line_known_ = false;
  Time line_end_;
  Time previous_last_sample_;

  bool scan_open_ = false;  // A ring-start packet has been seen.
  X4Scan current_scan_;
  uint64_t next_scan_index_ = 0;

  std::vector<X4Packet> packets_;
  std::vector<X4Scan> scans_;
  std::vector<X4DeviceInfo> device_infos_;
  std::vector<X4Health> health_;
};

// ---------------------------------------------------------------------------
// Encoders (lidar to host), for the simulator and the tests.

// `A5 5A 05 00 00 40 81`.
std::vector<uint8_t> EncodeX4ScanStartHeader();
// `A5 5A 14 00 00 00 04` + model, firmware (u16 LE), hardware, serial[16].
std::vector<uint8_t> EncodeX4DeviceInfo(const X4DeviceInfo& info);
// `A5 5A 03 00 00 00 06` + status, error_code (u16 LE).
std::vector<uint8_t> EncodeX4Health(const X4Health& health);

struct X4PacketToEncode {
  bool ring_start = false;
  // Written into CT bits 1..7 as round(f * 10), saturated to 0..127 (12.7 Hz).
  // The X4 reports it on ring-start packets; 0 elsewhere.
  double scan_frequency_hz = 0;
  // Desired CORRECTED angles (what the decoder outputs) of the first and the
  // last sample. The encoder removes each end sample's second-level
  // correction to get the first-level angles, then rounds them to the 1/64
  // deg field resolution, so the decoder reproduces them within 1/128 deg
  // (plus floating-point noise). Samples in between get the first-level
  // angles the decoder interpolates linearly, plus their own correction: a
  // simulator wanting exact in-between angles must choose distances for the
  // angles the decoder will produce (see X4AngleCorrectionDeg).
  double first_angle_deg = 0;
  double last_angle_deg = 0;
  // Distances in mm, rounded to integer mm and saturated to [0, 16383];
  // 0 encodes an invalid sample.
  std::vector<double> distances_mm;
  // Optional interference flags (2 low bits of Si), one per sample; missing
  // entries are 0.
  std::vector<uint8_t> interference;
};

// Appends one scan packet to *out. Returns false (and appends nothing) when
// there are no samples or more than 255.
bool EncodeX4ScanPacket(const X4PacketToEncode& packet, std::vector<uint8_t>* out);

// Check code of a packet whose header fields and samples are given:
// 0x55AA ^ FSA ^ LSA ^ (LSN << 8 | CT) ^ S_1 ^ ... ^ S_LSN.
uint16_t X4CheckCode(uint8_t ct, uint8_t lsn, uint16_t fsa, uint16_t lsa, const uint8_t* samples_le,
                     size_t sample_count);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_CODECS_X4_CODEC_H_
