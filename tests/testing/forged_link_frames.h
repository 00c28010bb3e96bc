// A flood of forged robot-link frame candidates, as a peer or someone on
// the path could send them (tests of the agent's and the workstation's
// decode bounds).
#ifndef SWEEPSCAN_TESTS_TESTING_FORGED_LINK_FRAMES_H_
#define SWEEPSCAN_TESTS_TESTING_FORGED_LINK_FRAMES_H_

#include <cstdint>
#include <vector>

#include "hardware/link/link_protocol.h"

namespace sweepscan::testing {

// `count` link headers (28 bytes each) from `sender`, each with a good
// header CRC and announcing `payload` bytes. Only the headers are sent, so
// every candidate's frame CRC runs over bytes that are mostly the next
// candidates', and fails: 28 bytes of input cost the decoder `payload`
// bytes of CRC work before they are rejected.
inline std::vector<uint8_t> ForgedLinkCandidates(hardware::LinkSender sender, size_t count,
                                                 size_t payload) {
  std::vector<uint8_t> bytes;
  const std::vector<uint8_t> body(payload, 0x5A);
  for (size_t i = 0; i < count; ++i) {
    std::vector<uint8_t> frame;
    hardware::AppendRawLinkFrame(sender, static_cast<uint32_t>(i), Time(), 0x14, body.data(),
                                 body.size(), &frame);
    frame.back() ^= 0xFF;  // A bad frame CRC, should the payload ever be there.
    bytes.insert(bytes.end(), frame.begin(), frame.begin() + hardware::kLinkHeaderSize);
  }
  return bytes;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_FORGED_LINK_FRAMES_H_
