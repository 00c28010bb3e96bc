// HiPNUC HI219 IMU serial protocol: frame decoder (0x91 packet and the legacy
// tagged items 0x90, 0xA0, 0xB0, 0xC0, 0xD0, 0xD1, 0xF0) and encoders for the
// simulator. Byte formats: docs/device-codecs.md (source: hipnuc/products,
// drivers/hipnuc_dec.c).
//
// Frame: 5A A5 | LEN u16 LE (payload bytes, 1..256) | CRC u16 LE | payload.
// CRC-16/XMODEM (poly 0x1021, init 0, MSB first) over bytes 0..3, then the
// payload; the CRC field itself is skipped.
//
// Threading: Hi219Decoder is used from one thread at a time; the free
// functions are pure.
#ifndef SWEEPSCAN_HARDWARE_CODECS_HI219_CODEC_H_
#define SWEEPSCAN_HARDWARE_CODECS_HI219_CODEC_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/time.h"
#include "hardware/codecs/codec_common.h"

namespace sweepscan {
namespace hardware {

inline constexpr uint8_t kHi219Sync1 = 0x5A;
inline constexpr uint8_t kHi219Sync2 = 0xA5;
inline constexpr size_t kHi219HeaderSize = 6;
inline constexpr size_t kHi219MaxPayload = 256;

inline constexpr uint8_t kHi219TagUserId = 0x90;
inline constexpr uint8_t kHi219TagAcc = 0xA0;
inline constexpr uint8_t kHi219TagGyro = 0xB0;
inline constexpr uint8_t kHi219TagMag = 0xC0;
inline constexpr uint8_t kHi219TagEuler = 0xD0;
inline constexpr uint8_t kHi219TagQuat = 0xD1;
inline constexpr uint8_t kHi219TagPressure = 0xF0;
inline constexpr uint8_t kHi219Tag91 = 0x91;
inline constexpr size_t kHi219Packet91Size = 76;  // Including the tag.

inline constexpr double kStandardGravity = 9.80665;  // m/s^2 per g.

// Bits of ImuSample::fields.
enum ImuField : uint32_t {
  kImuUserId = 1u << 0,
  kImuAcc = 1u << 1,
  kImuGyro = 1u << 2,
  kImuMag = 1u << 3,
  kImuEuler = 1u << 4,
  kImuQuat = 1u << 5,
  kImuPressure = 1u << 6,
  kImuSystemTime = 1u << 7,
  kImuTemperature = 1u << 8,
  kImuMainStatus = 1u << 9,
};

// One decoded frame. The device's own units are kept as float, exactly as
// the 0x91 packet carries them (so re-encoding is byte-exact); SI copies are
// derived from them. Fields whose bit is not set in `fields` are zero.
struct ImuSample {
  Time receive_time;  // Receive time of the Feed() chunk holding the frame's last byte.
  // Bytes of the whole frame (header + LEN), 0 when not decoded from bytes:
  // what the frame's serial transmission time is computed from (the 0x91
  // frame is 82 bytes, legacy frames vary with their items).
  size_t frame_bytes = 0;
  uint32_t fields = 0;
  bool Has(ImuField f) const { return (fields & f) != 0; }

  uint8_t user_id = 0;
  uint16_t main_status = 0;
  int8_t temperature_c = 0;
  float pressure_pa = 0;  // As the device reports it (Pa).
  uint32_t system_time_ms = 0;

  std::array<float, 3> acc_g{};
  std::array<float, 3> gyro_dps{};
  std::array<float, 3> mag_ut{};
  float roll_deg = 0;
  float pitch_deg = 0;
  float yaw_deg = 0;
  std::array<float, 4> quat_wxyz{};

  // Derived: acc * 9.80665, gyro and Euler * pi / 180.
  std::array<double, 3> acc_mps2{};
  std::array<double, 3> gyro_radps{};
  double roll_rad = 0;
  double pitch_rad = 0;
  double yaw_rad = 0;

  // Recomputes the derived SI fields from the device-unit ones.
  void UpdateDerived();
};

// CRC-16/XMODEM, continuing from `crc` (0 to start).
uint16_t Crc16Xmodem(const uint8_t* data, size_t n, uint16_t crc = 0);

// Parses a frame payload (tagged items) into *sample, setting its field bits.
// Returns false when an unknown tag or a truncated item stops the walk; the
// items before it are kept.
bool ParseHi219Payload(const uint8_t* payload, size_t n, ImuSample* sample);

// Streaming decoder. Resync: bytes before `5A A5` are skipped; a candidate
// with LEN = 0 or LEN > 256 (length error) or a bad CRC (checksum error) is
// rejected and the search restarts one byte after its first byte, so a good
// frame that began inside a bad one is still found. A frame with a good CRC
// but an unknown tag or truncated item counts as a payload error; it still
// yields a sample with the items before the problem, or none if there were none.
class Hi219Decoder {
 public:
  void Feed(const uint8_t* data, size_t n, Time receive_time);
  void Feed(const std::vector<uint8_t>& bytes, Time receive_time) {
    Feed(bytes.data(), bytes.size(), receive_time);
  }
  // Everything decoded since the previous call, oldest first.
  std::vector<ImuSample> TakeSamples();

  const DecoderStats& stats() const { return stats_; }
  size_t BufferedBytes() const { return buffer_.size(); }
  void Reset() { buffer_.Clear(); }

 private:
  StreamBuffer buffer_;
  DecoderStats stats_;
  std::vector<ImuSample> samples_;
};

// Wraps a payload in a frame (header, LEN, CRC). Returns false (appending
// nothing) for an empty payload or one longer than 256 bytes.
bool EncodeHi219Frame(const std::vector<uint8_t>& payload, std::vector<uint8_t>* out);

// One frame holding a 0x91 packet built from the device-unit fields of
// `sample` (absent fields are written as zero). Always 82 bytes.
std::vector<uint8_t> EncodeHi219Packet91Frame(const ImuSample& sample);

// One frame holding the legacy items for the fields present in `sample`, in
// the order 0x90, 0xA0, 0xB0, 0xC0, 0xD0, 0xD1, 0xF0. The i16 items are
// round(value * scale) saturated to [-32768, 32767] (acc * 1000, gyro * 10,
// mag * 10, pitch and roll * 100, yaw * 10). Fields only the 0x91 packet has
// (status, temperature, system time) are not written. Returns an empty vector
// if no legacy field is present.
std::vector<uint8_t> EncodeHi219LegacyFrame(const ImuSample& sample);

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_CODECS_HI219_CODEC_H_
