// RoundHalfAway (core/common/rounding.h) is std::llround, value for value:
// on halves and their neighbours either side, on the grid's millimetres
// and the X4's time stamps, on random doubles of every magnitude, and
// beyond 2^53, where it hands over to llround.
#include "core/common/rounding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace sweepscan {
namespace {

void ExpectSame(double x) {
  ASSERT_EQ(RoundHalfAway(x), std::llround(x)) << std::hexfloat << x;
}

TEST(RoundingTest, HalvesAndTheirNeighboursRoundAsLlround) {
  for (int64_t k = -2000; k <= 2000; ++k) {
    const double half = k + 0.5;
    for (double x : {double(k), half, std::nextafter(half, -1e300), std::nextafter(half, 1e300),
                     std::nextafter(double(k), -1e300), std::nextafter(double(k), 1e300)}) {
      ExpectSame(x);
    }
  }
  // The largest double below one half, whose x + 0.5 rounds up to 1.
  ExpectSame(0.49999999999999994);
  ExpectSame(-0.49999999999999994);
  ExpectSame(0.0);
  ExpectSame(-0.0);
}

TEST(RoundingTest, TheGridAndTimeStampsRoundAsLlround) {
  // GridIndex: a float position times 1000; SecondsToDuration: seconds
  // times 1e9.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> metres(-8000.0f, 8000.0f);
  std::uniform_real_distribution<double> seconds(0.0, 1e6);
  for (int i = 0; i < 1000000; ++i) {
    ExpectSame(static_cast<double>(metres(rng)) * 1000.0);
    ExpectSame(seconds(rng) * 1e9);
  }
}

TEST(RoundingTest, AnyDoubleRoundsAsLlroundWhereLlroundIsDefined) {
  std::mt19937_64 rng(4);
  int tested = 0;
  while (tested < 1000000) {
    const uint64_t bits = rng();
    double x;
    std::memcpy(&x, &bits, sizeof x);
    // llround's result is unspecified beyond int64 (and for NaN).
    if (!std::isfinite(x) || std::abs(x) >= 9.2e18) continue;
    ExpectSame(x);
    ++tested;
  }
  for (double x : {9007199254740992.0, -9007199254740992.0, 9007199254740993.0 * 2, 4503599627370495.5,
                   -4503599627370495.5, 1e18, -1e18}) {
    ExpectSame(x);
  }
}

}  // namespace
}  // namespace sweepscan
