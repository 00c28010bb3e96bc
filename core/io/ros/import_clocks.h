// The import's checks of a bag's clocks (core/io/ros/import.h,
// docs/ros-bags.md "Time" and "Clocks"): within a topic, stamps that go
// back or jump (StampCheck); across topics, a topic stamped on another
// clock than the others (CheckClocks). Internal to import.cc.
#ifndef SWEEPSCAN_CORE_IO_ROS_IMPORT_CLOCKS_H_
#define SWEEPSCAN_CORE_IO_ROS_IMPORT_CLOCKS_H_

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/io/ros/import.h"

namespace sweepscan::io::import_internal {

constexpr int64_t kOneSecondNs = 1000000000;

// Per-topic stamp tracking: out-of-order messages, clock jumps and gaps.
class StampCheck {
 public:
  // False (with *error) on a clock that jumps back by more than a second.
  bool Observe(const std::string& topic, int64_t stamp_ns, uint64_t index, RosImportReport* report,
               std::string* error) {
    auto it = last_.find(topic);
    if (it != last_.end()) {
      const int64_t d = stamp_ns - it->second;
      if (d < -kOneSecondNs) {
        *error =
            topic + ": message " + std::to_string(index) + " is stamped " +
            std::to_string(-d * 1e-9) +
            " s before the one before it: the clock jumped back (two recordings or a "
            "restarted simulation in one bag?); cut the bag at that point and import the parts";
        return false;
      }
      if (d < 0) ++report->out_of_order;
      if (d > kOneSecondNs) ++report->time_gaps;
    }
    last_[topic] = std::max(stamp_ns, it == last_.end() ? stamp_ns : it->second);
    return true;
  }

 private:
  std::map<std::string, int64_t> last_;
};

// Stamps and log times of one topic differ by the sensor's and the
// network's latency (ms, at worst a loaded recorder's backlog, a second or
// two); topics whose differences disagree by more are on different clocks.
constexpr int64_t kClockDisagreementNs = int64_t{5} * 1000000000;

inline std::string SecondsText(int64_t ns) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3f s", static_cast<double>(ns) * 1e-9);
  return text;
}

// Compares the sensor topics' (header stamp - log time) of their first
// messages. The offset most topics share (ties: the scan's, then the
// odometry's) is the bag's sensor clock; a topic off it by more than
// kClockDisagreementNs gets its log time moved onto that clock instead
// of its stamps (r->stamps_from_log_time), with a warning naming it: the
// cloud is then right to the topic's latency, where its stamps would put
// its odometry or IMU years away from the scans.
// `offsets`: each sensor topic and its first message's stamp - log time,
// in the order scan, odometry, IMU.
inline void CheckClocks(const std::vector<std::pair<std::string, int64_t>>& offsets,
                        RosImportReport* r) {
  const auto agree = [](int64_t a, int64_t b) {
    return (a > b ? static_cast<uint64_t>(a) - static_cast<uint64_t>(b)
                  : static_cast<uint64_t>(b) - static_cast<uint64_t>(a)) <=
           static_cast<uint64_t>(kClockDisagreementNs);
  };
  size_t best = 0, best_votes = 0;
  for (size_t i = 0; i < offsets.size(); ++i) {
    size_t votes = 0;
    for (const auto& o : offsets) votes += agree(offsets[i].second, o.second);
    if (votes > best_votes) {
      best = i;
      best_votes = votes;
    }
  }
  // Of the topics on the bag's clock, the one logged soonest after its
  // stamp: the least latency, the best guess at a message's transport time
  // (a LaserScan is stamped at its first beam, logged a turn later).
  size_t reference = best;
  for (size_t i = 0; i < offsets.size(); ++i) {
    if (agree(offsets[i].second, offsets[best].second) &&
        offsets[i].second > offsets[reference].second) {
      reference = i;
    }
  }
  const auto& [reference_topic, reference_offset] = offsets[reference];
  for (const auto& [topic, offset] : offsets) {
    if (agree(offset, offsets[best].second)) continue;
    r->stamps_from_log_time[topic] = reference_offset;
    r->warnings.push_back(
        topic + ": header stamps are " + SecondsText(offset) + " from their log times, but " +
        reference_topic + "'s are " + SecondsText(reference_offset) +
        ": stamped on another clock (from boot, or left 0?); its times are its log times" +
        (reference_offset == 0 ? std::string() : " moved by " + SecondsText(reference_offset)) +
        " instead (its transport latency is not undone)");
  }
}

}  // namespace sweepscan::io::import_internal

#endif  // SWEEPSCAN_CORE_IO_ROS_IMPORT_CLOCKS_H_
