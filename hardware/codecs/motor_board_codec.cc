#include "hardware/codecs/motor_board_codec.h"

#include <utility>

namespace sweepscan {
namespace hardware {
namespace {

uint8_t XorBytes(const uint8_t* p, size_t n) {
  uint8_t x = 0;
  for (size_t i = 0; i < n; ++i) x ^= p[i];
  return x;
}

void AppendI16Be(double value, std::vector<uint8_t>* out) {
  AppendU16Be(static_cast<uint16_t>(SaturatingRound<int16_t>(value)), out);
}

void FinishFrame(std::vector<uint8_t>* out) {
  out->push_back(XorBytes(out->data(), out->size()));
  out->push_back(kMotorFrameTail);
}

template <typename Record>
Record DecodeFrame(const uint8_t* frame);
template <>
MotorCommand DecodeFrame<MotorCommand>(const uint8_t* frame) {
  return DecodeMotorCommandFrame(frame);
}
template <>
MotorFeedback DecodeFrame<MotorFeedback>(const uint8_t* frame) {
  return DecodeMotorFeedbackFrame(frame);
}

}  // namespace

std::vector<uint8_t> EncodeMotorCommand(const MotorCommand& command) {
  std::vector<uint8_t> out;
  out.reserve(kMotorCommandSize);
  out.push_back(kMotorFrameHead);
  out.push_back(command.flag);
  out.push_back(0x00);
  AppendI16Be(command.vx_mps * kMotorVelocityScale, &out);
  AppendI16Be(command.vy_mps * kMotorVelocityScale, &out);
  AppendI16Be(command.wz_radps * kMotorVelocityScale, &out);
  FinishFrame(&out);
  return out;
}

std::vector<uint8_t> EncodeMotorFeedback(const MotorFeedback& feedback) {
  std::vector<uint8_t> out;
  out.reserve(kMotorFeedbackSize);
  out.push_back(kMotorFrameHead);
  out.push_back(feedback.stop_flag);
  AppendI16Be(feedback.vx_mps * kMotorVelocityScale, &out);
  AppendI16Be(feedback.vy_mps * kMotorVelocityScale, &out);
  AppendI16Be(feedback.wz_radps * kMotorVelocityScale, &out);
  for (double a : feedback.acc_mps2) AppendI16Be(a * kMotorAccRawPerMps2, &out);
  for (double g : feedback.gyro_radps) AppendI16Be(g / kMotorGyroRadpsPerRaw, &out);
  AppendU16Be(SaturatingRound<uint16_t>(feedback.voltage_v * 1000.0), &out);
  FinishFrame(&out);
  return out;
}

MotorCommand DecodeMotorCommandFrame(const uint8_t* f) {
  MotorCommand c;
  c.flag = f[1];
  c.vx_mps = ReadI16Be(f + 3) / kMotorVelocityScale;
  c.vy_mps = ReadI16Be(f + 5) / kMotorVelocityScale;
  c.wz_radps = ReadI16Be(f + 7) / kMotorVelocityScale;
  return c;
}

MotorFeedback DecodeMotorFeedbackFrame(const uint8_t* f) {
  MotorFeedback fb;
  fb.stop_flag = f[1];
  fb.vx_mps = ReadI16Be(f + 2) / kMotorVelocityScale;
  fb.vy_mps = ReadI16Be(f + 4) / kMotorVelocityScale;
  fb.wz_radps = ReadI16Be(f + 6) / kMotorVelocityScale;
  for (int i = 0; i < 3; ++i) {
    fb.acc_mps2[i] = ReadI16Be(f + 8 + 2 * i) / kMotorAccRawPerMps2;
    fb.gyro_radps[i] = ReadI16Be(f + 14 + 2 * i) * kMotorGyroRadpsPerRaw;
  }
  fb.voltage_v = ReadU16Be(f + 20) / 1000.0;
  return fb;
}

template <typename Record, size_t kSize>
void MotorFrameDecoder<Record, kSize>::Feed(const uint8_t* data, size_t n, Time receive_time) {
  if (data == nullptr) n = 0;
  stats_.bytes_in += n;
  buffer_.Append(data, n);
  while (buffer_.size() > 0) {
    const uint8_t* p = buffer_.data();
    const size_t avail = buffer_.size();
    if (p[0] != kMotorFrameHead) {
      stats_.bytes_skipped += buffer_.SkipToNext(kMotorFrameHead);
      continue;
    }
    if (avail < kSize) break;
    bool ok = true;
    if (p[kSize - 1] != kMotorFrameTail) {
      ++stats_.framing_errors;
      ok = false;
    } else if (XorBytes(p, kSize - 2) != p[kSize - 2]) {
      ++stats_.checksum_errors;
      ok = false;
    }
    if (!ok) {
      buffer_.Consume(1);
      stats_.bytes_skipped += 1;
      continue;
    }
    Record r = DecodeFrame<Record>(p);
    r.receive_time = receive_time;
    records_.push_back(r);
    buffer_.Consume(kSize);
    stats_.bytes_in_frames += kSize;
    ++stats_.frames_ok;
  }
  buffer_.Compact();
}

template <typename Record, size_t kSize>
std::vector<Record> MotorFrameDecoder<Record, kSize>::TakeRecords() {
  return std::exchange(records_, {});
}

template class MotorFrameDecoder<MotorCommand, kMotorCommandSize>;
template class MotorFrameDecoder<MotorFeedback, kMotorFeedbackSize>;

}  // namespace hardware
}  // namespace sweepscan
