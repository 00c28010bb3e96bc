// STM32 differential-drive motor board, WHEELTEC-style serial frames
// (16-bit fields BIG-endian, 115200 baud). Encoders and streaming decoders for
// both directions: the simulator decodes commands and encodes feedback, the
// robot agent does the opposite. Byte formats: docs/device-codecs.md.
//
//   host -> board, 11 bytes: 7B flag 00 vx(i16) vy(i16) wz(i16) XOR 7D
//   board -> host, 24 bytes: 7B stop_flag vx vy wz acc_xyz gyro_xyz voltage_mV(u16) XOR 7D
//   XOR covers every byte before it (bytes 0..8, resp. 0..21).
//
// Threading: each decoder is used from one thread at a time; the encoders are pure.
#ifndef SWEEPSCAN_HARDWARE_CODECS_MOTOR_BOARD_CODEC_H_
#define SWEEPSCAN_HARDWARE_CODECS_MOTOR_BOARD_CODEC_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/time.h"
#include "hardware/codecs/codec_common.h"

namespace sweepscan {
namespace hardware {

inline constexpr uint8_t kMotorFrameHead = 0x7B;
inline constexpr uint8_t kMotorFrameTail = 0x7D;
inline constexpr size_t kMotorCommandSize = 11;
inline constexpr size_t kMotorFeedbackSize = 24;
// Wire scales: velocities in mm/s, yaw rate in rad/s * 1000,
// acc raw / 1671.84 = m/s^2, gyro raw * 0.00026644 = rad/s, voltage in mV.
inline constexpr double kMotorVelocityScale = 1000.0;  // raw per m/s and per rad/s.
inline constexpr double kMotorAccRawPerMps2 = 1671.84;
inline constexpr double kMotorGyroRadpsPerRaw = 0.00026644;

// Velocity command. SI in, SI out; on the wire vx, vy are mm/s and wz is
// rad/s * 1000, each rounded to nearest and saturated to [-32768, 32767]
// (so |v| <= 32.767 m/s, |wz| <= 32.767 rad/s; larger values are clamped, not wrapped).
struct MotorCommand {
  uint8_t flag = 0;  // Byte 1; unused by WHEELTEC boards, carried through.
  double vx_mps = 0;
  double vy_mps = 0;  // Always 0 on a differential drive; carried through.
  double wz_radps = 0;
  Time receive_time;  // Set by the decoder: receive time of the chunk with the last byte.
};

struct MotorFeedback {
  uint8_t stop_flag = 0;
  double vx_mps = 0;
  double vy_mps = 0;
  double wz_radps = 0;
  std::array<double, 3> acc_mps2{};
  std::array<double, 3> gyro_radps{};
  double voltage_v = 0;  // Wire: u16 mV, saturated to [0, 65.535] V on encode.
  Time receive_time;     // Set by the decoder.
};

std::vector<uint8_t> EncodeMotorCommand(const MotorCommand& command);
std::vector<uint8_t> EncodeMotorFeedback(const MotorFeedback& feedback);

// Fixed-length frame decoder shared by both directions. Resync: bytes before
// 0x7B are skipped; a candidate whose last byte is not 0x7D (framing error)
// or whose XOR is wrong (checksum error) is rejected and the search restarts
// one byte after its 0x7B, so a good frame that began inside it is still
// found. Byte 2 of a command (0x00 on the wire) is not checked.
template <typename Record, size_t kSize>
class MotorFrameDecoder {
 public:
  void Feed(const uint8_t* data, size_t n, Time receive_time);
  void Feed(const std::vector<uint8_t>& bytes, Time receive_time) {
    Feed(bytes.data(), bytes.size(), receive_time);
  }
  // Everything decoded since the previous call, oldest first.
  std::vector<Record> TakeRecords();

  const DecoderStats& stats() const { return stats_; }
  size_t BufferedBytes() const { return buffer_.size(); }
  void Reset() { buffer_.Clear(); }

 private:
  StreamBuffer buffer_;
  DecoderStats stats_;
  std::vector<Record> records_;
};

using MotorCommandDecoder = MotorFrameDecoder<MotorCommand, kMotorCommandSize>;
using MotorFeedbackDecoder = MotorFrameDecoder<MotorFeedback, kMotorFeedbackSize>;

// Decode one complete, already validated frame (used by the decoders; exposed
// for tests). `frame` must hold kMotorCommandSize resp. kMotorFeedbackSize bytes.
MotorCommand DecodeMotorCommandFrame(const uint8_t* frame);
MotorFeedback DecodeMotorFeedbackFrame(const uint8_t* frame);

extern template class MotorFrameDecoder<MotorCommand, kMotorCommandSize>;
extern template class MotorFrameDecoder<MotorFeedback, kMotorFeedbackSize>;

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_CODECS_MOTOR_BOARD_CODEC_H_
