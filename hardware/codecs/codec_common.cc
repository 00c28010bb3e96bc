#include "hardware/codecs/codec_common.h"

#include <cstring>
#include <sstream>

namespace sweepscan {
namespace hardware {

std::string DecoderStats::ToString() const {
  std::ostringstream s;
  s << "bytes_in=" << bytes_in << " bytes_in_frames=" << bytes_in_frames
    << " frames_ok=" << frames_ok << " bytes_skipped=" << bytes_skipped
    << " checksum_errors=" << checksum_errors << " length_errors=" << length_errors
    << " framing_errors=" << framing_errors << " payload_errors=" << payload_errors;
  return s.str();
}

// The bytes are assembled as a little-endian u32 (host byte order does not
// matter), then reinterpreted with memcpy, which is defined behaviour where a
// pointer cast would not be. Assumes IEEE 754 binary32 floats.
float ReadF32Le(const uint8_t* p) {
  static_assert(sizeof(float) == 4, "float must be 32-bit IEEE 754");
  const uint32_t bits = ReadU32Le(p);
  float v;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

void AppendF32Le(float v, std::vector<uint8_t>* out) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  AppendU32Le(bits, out);
}

}  // namespace hardware
}  // namespace sweepscan
