// libFuzzer target: Hi219Decoder on arbitrary bytes in fuzzed chunk sizes,
// plus re-encoding of every decoded 0x91 sample (must decode back bit-exact)
// and of the legacy items (must decode back to the same field set).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "hardware/codecs/hi219_codec.h"

namespace {

using sweepscan::Time;
using namespace sweepscan::hardware;

void Check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t chunk = 1 + data[0] % 131;
  ++data;
  --size;

  Hi219Decoder decoder;
  for (size_t pos = 0; pos < size; pos += chunk) {
    const size_t n = size - pos < chunk ? size - pos : chunk;
    decoder.Feed(data + pos, n, Time());
    for (const ImuSample& s : decoder.TakeSamples()) {
      Check(s.fields != 0);
      const uint32_t k91 = kImuMainStatus | kImuTemperature | kImuSystemTime;
      if ((s.fields & k91) == k91) {
        const std::vector<uint8_t> f = EncodeHi219Packet91Frame(s);
        Check(f.size() == 82);
        Hi219Decoder d2;
        d2.Feed(f, Time());
        const auto back = d2.TakeSamples();
        Check(back.size() == 1);
        Check(EncodeHi219Packet91Frame(back[0]) == f);
      }
      const std::vector<uint8_t> legacy = EncodeHi219LegacyFrame(s);
      const uint32_t legacy_fields =
          kImuUserId | kImuAcc | kImuGyro | kImuMag | kImuEuler | kImuQuat | kImuPressure;
      if ((s.fields & legacy_fields) != 0) {
        Hi219Decoder d3;
        d3.Feed(legacy, Time());
        const auto back = d3.TakeSamples();
        Check(back.size() == 1 && back[0].fields == (s.fields & legacy_fields));
      } else {
        Check(legacy.empty());
      }
    }
  }
  const DecoderStats& st = decoder.stats();
  Check(st.bytes_in == size);
  Check(st.bytes_in == st.bytes_in_frames + st.bytes_skipped + decoder.BufferedBytes());
  Check(decoder.BufferedBytes() < kHi219HeaderSize + kHi219MaxPayload);
  return 0;
}
