// libFuzzer target: both motor-board decoders on the same arbitrary bytes in
// fuzzed chunk sizes; every decoded record must re-encode to a frame that
// decodes to the same record.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "hardware/codecs/motor_board_codec.h"

namespace {

using sweepscan::Time;
using namespace sweepscan::hardware;

void Check(bool ok) {
  if (!ok) std::abort();
}

template <typename Decoder, typename Encode>
void Run(const uint8_t* data, size_t size, size_t chunk, size_t frame_size, Encode encode) {
  Decoder decoder;
  for (size_t pos = 0; pos < size; pos += chunk) {
    const size_t n = size - pos < chunk ? size - pos : chunk;
    decoder.Feed(data + pos, n, Time());
    for (const auto& r : decoder.TakeRecords()) {
      const std::vector<uint8_t> f = encode(r);
      Check(f.size() == frame_size);
      Decoder d2;
      d2.Feed(f, Time());
      const auto back = d2.TakeRecords();
      Check(back.size() == 1 && encode(back[0]) == f);
    }
  }
  const DecoderStats& st = decoder.stats();
  Check(st.bytes_in == size);
  Check(st.bytes_in == st.bytes_in_frames + st.bytes_skipped + decoder.BufferedBytes());
  Check(decoder.BufferedBytes() < frame_size);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t chunk = 1 + data[0] % 29;
  Run<MotorCommandDecoder>(data + 1, size - 1, chunk, kMotorCommandSize,
                           [](const MotorCommand& c) { return EncodeMotorCommand(c); });
  Run<MotorFeedbackDecoder>(data + 1, size - 1, chunk, kMotorFeedbackSize,
                            [](const MotorFeedback& f) { return EncodeMotorFeedback(f); });
  return 0;
}
