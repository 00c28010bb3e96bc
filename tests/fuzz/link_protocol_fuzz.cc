// libFuzzer target: LinkDecoder on arbitrary bytes, fed in chunks whose size
// comes from the first input byte. Checks, beyond "no crash / no sanitizer
// report": the byte accounting identity, the memory bound, that every
// delivered frame re-parses on its own (ParseLinkFrame) and that its payload
// survives encode -> parse -> encode unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "hardware/link/link_protocol.h"

namespace {

using namespace sweepscan::hardware;

void Check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t chunk = 1 + data[0] % 251;
  ++data;
  --size;

  LinkDecoderOptions options;
  options.keep_raw_frames = true;
  LinkDecoder decoder(options);
  std::vector<LinkMessage> out;
  for (size_t pos = 0; pos < size; pos += chunk) {
    const size_t n = size - pos < chunk ? size - pos : chunk;
    decoder.Feed(data + pos, n, &out);
    Check(decoder.BufferedBytes() < kLinkMaxFrameSize);
  }
  const LinkDecoderStats& st = decoder.stats();
  Check(st.codec.bytes_in == size);
  Check(st.codec.bytes_in ==
        st.codec.bytes_in_frames + st.codec.bytes_skipped + decoder.BufferedBytes());
  Check(out.size() == st.codec.frames_ok);
  for (const LinkMessage& m : out) {
    Check(m.raw.size() == kLinkFrameOverhead + m.header.payload_size);
    LinkMessage again;
    Check(ParseLinkFrame(m.raw.data(), m.raw.size(), &again).ok());
    Check(again.header.sequence == m.header.sequence && again.header.type == m.header.type);
    std::vector<uint8_t> a, b;
    EncodeLinkPayload(m.payload, &a);
    LinkPayload reparsed;
    Check(ParseLinkPayload(m.header.type, a.data(), a.size(), &reparsed, nullptr));
    EncodeLinkPayload(reparsed, &b);
    Check(a == b);
    Check(LinkPayloadType(m.payload) == m.header.type);
  }
  // ParseLinkFrame on the raw input must never crash either.
  LinkMessage single;
  (void)ParseLinkFrame(data, size, &single);
  return 0;
}
