// libFuzzer target: the checks a ROS 1 bag passes before rosbag_storage
// reads it (core/io/rosbag1/rosbag1_check.h), on arbitrary bytes as a bag
// image and as each kind's message body. Beyond "no crash / no sanitizer
// report": a refusal names the bag (or the message type) and, for a bag
// that starts like one, the byte; a body accepted as a LaserScan holds no
// more elements than its bytes carry (what roscpp would then allocate).
// Seeds: tests/fuzz/corpus/rosbag1 (python3-rosbag, tests/tools/make_test_rosbags.py).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/io/rosbag1/rosbag1_check.h"

namespace {

using namespace sweepscan::io;

void Check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The records only (a summary's check), then the chunks walked too
  // (before messages are read): whatever the first refuses, the second does.
  bool records_ok = true;
  for (const bool chunks : {false, true}) {
    const sweepscan::Status s = CheckRosbag1Image(data, size, "fuzz.bag", chunks);
    if (!chunks) records_ok = s.ok();
    if (chunks && !records_ok) Check(!s.ok());
    if (s.ok()) continue;
    Check(s.message().rfind("fuzz.bag: ", 0) == 0);
    const bool magic = size >= 13 && std::memcmp(data, "#ROSBAG V2.0\n", 13) == 0;
    if (magic && s.message().find("beyond the end of the file") == std::string::npos) {
      Check(s.message().find("at byte ") != std::string::npos);
    }
  }
  for (RosMessageKind kind : {RosMessageKind::kLaserScan, RosMessageKind::kOdometry,
                              RosMessageKind::kImu, RosMessageKind::kTf, RosMessageKind::kOther}) {
    const sweepscan::Status m = CheckRos1Message(kind, data, size);
    if (!m.ok()) Check(m.message().rfind(std::string(RosMessageKindName(kind)) + ": ", 0) == 0);
    if (m.ok() && kind == RosMessageKind::kLaserScan) {
      // seq, stamp, frame_id, 7 floats, then ranges: its count fits the bytes.
      uint32_t frame, ranges;
      std::memcpy(&frame, data + 12, 4);
      std::memcpy(&ranges, data + 16 + frame + 28, 4);
      Check(static_cast<uint64_t>(ranges) * 4 <= size);
    }
  }
  return 0;
}
