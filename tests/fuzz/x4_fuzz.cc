// libFuzzer target: X4Decoder on arbitrary bytes, fed in chunks whose size
// comes from the first input byte, plus the packet encoder on fuzzed values.
// Checks, beyond "no crash / no sanitizer report": the byte accounting
// identity, the output ranges, and encode -> decode of fuzzed packets.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "hardware/codecs/x4_codec.h"

namespace {

using sweepscan::Time;
using namespace sweepscan::hardware;

void Check(bool ok) {
  if (!ok) std::abort();
}

double ReadDouble(const uint8_t* p) {
  int32_t v;
  std::memcpy(&v, p, sizeof(v));
  return v / 1000.0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t chunk = 1 + data[0] % 97;
  ++data;
  --size;

  X4DecoderOptions options;
  options.max_samples_per_packet = 255;
  X4Decoder decoder(options);
  size_t packets = 0;
  for (size_t pos = 0; pos < size; pos += chunk) {
    const size_t n = size - pos < chunk ? size - pos : chunk;
    decoder.Feed(data + pos, n, Time(sweepscan::Duration(static_cast<int64_t>(pos))));
    for (const X4Packet& p : decoder.TakePackets()) {
      ++packets;
      Check(!p.samples.empty() && p.samples.size() <= 255);
      for (const X4Sample& s : p.samples) {
        Check(s.angle_deg >= 0 && s.angle_deg < 360);
        Check(s.valid == (s.distance_mm > 0));
      }
    }
    for (const X4Scan& s : decoder.TakeScans()) Check(!s.samples.empty());
    decoder.TakeDeviceInfos();
    decoder.TakeHealth();
  }
  const DecoderStats& st = decoder.stats();
  Check(st.bytes_in == size);
  Check(st.bytes_in == st.bytes_in_frames + st.bytes_skipped + decoder.BufferedBytes());
  Check(decoder.BufferedBytes() < kX4PacketHeaderSize + 2 * kX4MaxSamplesPerPacket);
  Check(packets <= st.frames_ok);

  // Encoder: the same bytes as packet parameters.
  if (size >= 9) {
    X4PacketToEncode e;
    e.ring_start = data[0] & 1;
    e.scan_frequency_hz = data[0] / 10.0;
    e.first_angle_deg = ReadDouble(data + 1);
    e.last_angle_deg = ReadDouble(data + 5);
    for (size_t i = 9; i + 1 < size && e.distances_mm.size() < 255; i += 2) {
      e.distances_mm.push_back(static_cast<double>((data[i] << 8 | data[i + 1])) - 1000.0);
      e.interference.push_back(data[i]);
    }
    std::vector<uint8_t> bytes;
    if (EncodeX4ScanPacket(e, &bytes)) {
      X4Decoder d2(options);
      d2.Feed(bytes, Time());
      const auto out = d2.TakePackets();
      Check(out.size() == 1 && out[0].samples.size() == e.distances_mm.size());
      Check(d2.stats().bytes_skipped == 0);
    } else {
      Check(e.distances_mm.empty());
    }
  }
  return 0;
}
