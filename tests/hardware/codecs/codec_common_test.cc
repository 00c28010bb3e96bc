#include "hardware/codecs/codec_common.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace sweepscan {
namespace hardware {
namespace {

TEST(SaturatingRoundTest, RoundsHalfAwayFromZeroAndSaturates) {
  EXPECT_EQ(SaturatingRound<int16_t>(1.5), 2);
  EXPECT_EQ(SaturatingRound<int16_t>(-1.5), -2);
  EXPECT_EQ(SaturatingRound<int16_t>(1.49), 1);
  EXPECT_EQ(SaturatingRound<int16_t>(32766.6), 32767);
  EXPECT_EQ(SaturatingRound<int16_t>(1e9), 32767);
  EXPECT_EQ(SaturatingRound<int16_t>(-32768.4), -32768);
  EXPECT_EQ(SaturatingRound<int16_t>(-1e9), -32768);
  EXPECT_EQ(SaturatingRound<int16_t>(NAN), 0);
  EXPECT_EQ(SaturatingRound<int16_t>(INFINITY), 32767);
  EXPECT_EQ(SaturatingRound<uint16_t>(-0.3), 0);
  EXPECT_EQ(SaturatingRound<uint16_t>(-7.0), 0);
  EXPECT_EQ(SaturatingRound<uint16_t>(65535.4), 65535);
  EXPECT_EQ(SaturatingRound<uint8_t>(300.0), 255);
}

TEST(ByteFieldTest, LittleAndBigEndian) {
  const uint8_t b[] = {0x34, 0x12, 0xCD, 0xAB};
  EXPECT_EQ(ReadU16Le(b), 0x1234);
  EXPECT_EQ(ReadU16Be(b), 0x3412);
  EXPECT_EQ(ReadU32Le(b), 0xABCD1234u);
  EXPECT_EQ(ReadI16Le(b + 2), static_cast<int16_t>(0xABCD));
  // 1.0f is 0x3F800000.
  const uint8_t one[] = {0x00, 0x00, 0x80, 0x3F};
  EXPECT_EQ(ReadF32Le(one), 1.0f);
  std::vector<uint8_t> out;
  AppendF32Le(1.0f, &out);
  AppendU16Be(0x1234, &out);
  AppendU16Le(0x1234, &out);
  EXPECT_EQ(out, (std::vector<uint8_t>{0x00, 0x00, 0x80, 0x3F, 0x12, 0x34, 0x34, 0x12}));
}

TEST(StreamBufferTest, ConsumeCompactAndClamp) {
  StreamBuffer buf;
  const uint8_t a[] = {1, 2, 3, 4};
  buf.Append(a, 4);
  buf.Consume(1);
  EXPECT_EQ(buf.size(), 3u);
  EXPECT_EQ(buf.data()[0], 2);
  buf.Compact();
  EXPECT_EQ(buf.size(), 3u);
  EXPECT_EQ(buf.data()[0], 2);
  buf.Consume(100);  // Clamped to what is there.
  EXPECT_EQ(buf.size(), 0u);
  buf.Append(nullptr, 5);  // Ignored.
  EXPECT_EQ(buf.size(), 0u);
}

}  // namespace
}  // namespace hardware
}  // namespace sweepscan
