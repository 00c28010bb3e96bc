// libFuzzer target: the MCAP reader (core/io/ros2/mcap.h) on an arbitrary
// file image, through its in-memory entry points (ReadMcapFromMemory,
// SummarizeMcapFromMemory): the same code as for files, minus pread().
// Checks, beyond "no crash / no sanitizer report": the sink sees exactly the
// messages the stats count; every error names "<memory>"; a successful read's
// summary counts at least the messages handed over or skipped; bytes_read
// never exceeds the input.
// Seeds: tests/fuzz/corpus/mcap (scripts/make-ros2-test-bags.sh).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/io/ros2/mcap.h"

namespace {

using namespace sweepscan::io;

void Check(bool ok) {
  if (!ok) std::abort();
}

class CountingSink : public RosMessageSink {
 public:
  bool OnLaserScan(const RosMessageInfo& i, const RosLaserScan&) override { return Note(i); }
  bool OnOdometry(const RosMessageInfo& i, const RosOdometry&) override { return Note(i); }
  bool OnImu(const RosMessageInfo& i, const RosImu&) override { return Note(i); }
  bool OnTf(const RosMessageInfo& i, const RosTfMessage&) override { return Note(i); }
  void OnUndecodable(const RosMessageInfo& i, const std::string& why) override {
    Check(i.topic != nullptr && !why.empty());
    ++undecodable;
  }
  uint64_t messages = 0, undecodable = 0;

 private:
  bool Note(const RosMessageInfo& i) {
    Check(i.topic != nullptr && i.type != nullptr);
    ++messages;
    return true;
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  CountingSink sink;
  RosReadStats stats;
  RosBagSummary summary;
  Ros2ReadReport report;
  sweepscan::Status s =
      ReadMcapFromMemory(data, size, RosReadOptions(), &sink, &summary, &stats, &report);
  Check(sink.messages == stats.messages_read);
  Check(sink.undecodable == stats.messages_undecodable);
  Check(stats.bytes_read <= size);
  if (s.ok()) {
    Check(summary.message_count >=
          stats.messages_read + stats.messages_undecodable + stats.messages_skipped);
  } else {
    Check(s.message().rfind("<memory>: ", 0) == 0);
  }
  for (const std::string& w : report.warnings) Check(w.rfind("<memory>: ", 0) == 0);

  RosBagSummary quick;
  Ros2ReadReport quick_report;
  s = SummarizeMcapFromMemory(data, size, &quick, &quick_report);
  if (!s.ok()) Check(s.message().rfind("<memory>: ", 0) == 0);
  return 0;
}
