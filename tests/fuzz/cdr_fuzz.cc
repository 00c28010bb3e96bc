// libFuzzer target: the four ROS 2 CDR decoders (core/io/ros2/cdr.h) on the
// same arbitrary bytes. Checks, beyond "no crash / no sanitizer report":
// a decoded message never holds more elements than its bytes can carry (the
// counts are refused before allocating), and a failure always names a field.
// Seeds: tests/fuzz/corpus/cdr (scripts/make-ros2-test-bags.sh).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/io/ros2/cdr.h"

namespace {

using namespace sweepscan::io;

void Check(bool ok) {
  if (!ok) std::abort();
}

void CheckFailure(const sweepscan::Status& s, const char* message) {
  if (s.ok()) return;
  // "<Message>: <field>: <why>"
  Check(s.message().rfind(std::string(message) + ": ", 0) == 0);
}

class NullSink : public RosMessageSink {
 public:
  bool OnLaserScan(const RosMessageInfo&, const RosLaserScan&) override { return true; }
  bool OnOdometry(const RosMessageInfo&, const RosOdometry&) override { return true; }
  bool OnImu(const RosMessageInfo&, const RosImu&) override { return true; }
  bool OnTf(const RosMessageInfo&, const RosTfMessage&) override { return true; }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  RosLaserScan scan;
  sweepscan::Status s = DecodeCdrLaserScan(data, size, &scan);
  CheckFailure(s, "LaserScan");
  if (s.ok()) Check(4 * (scan.ranges.size() + scan.intensities.size()) <= size);

  RosOdometry odom;
  CheckFailure(DecodeCdrOdometry(data, size, &odom), "Odometry");
  RosImu imu;
  CheckFailure(DecodeCdrImu(data, size, &imu), "Imu");

  RosTfMessage tf;
  s = DecodeCdrTfMessage(data, size, &tf);
  CheckFailure(s, "TFMessage");
  if (s.ok()) Check(72 * tf.transforms.size() <= size);

  // The dispatch path the readers use: every message is counted once.
  NullSink sink;
  RosReadStats stats;
  const std::string topic = "/fuzz", type = "fuzz";
  RosMessageInfo info;
  info.topic = &topic;
  info.type = &type;
  for (RosMessageKind kind : {RosMessageKind::kLaserScan, RosMessageKind::kOdometry,
                              RosMessageKind::kImu, RosMessageKind::kTf, RosMessageKind::kOther}) {
    Check(DispatchCdrMessage(kind, info, data, size, &sink, &stats));
  }
  Check(stats.messages_read + stats.messages_undecodable == 4 && stats.messages_skipped == 1);
  return 0;
}
