// The check both ROS import tests make (tests/app/cli_ros_test.cc,
// cli_ros2_test.cc): a drive exported as a bag by an independent writer
// (tests/tools/session_to_rosbag1.py, session_to_ros2.mjs) and imported
// gives the native session's cloud point for point, within the writers'
// LaserScan binning.
#ifndef SWEEPSCAN_TESTS_TESTING_BINNED_CLOUD_H_
#define SWEEPSCAN_TESTS_TESTING_BINNED_CLOUD_H_

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/cloud/cloud.h"

namespace sweepscan::testing {

// The same points in the same order, the same ranges; each point within the
// 0.05 deg bins of the writers (0.025 deg at most: median 0.5 mm, p99 2 mm,
// max 6 mm over the lab), and its time the sample's but for a whole-second
// shift (the import's time origin) and the X4's angle correction (up to
// ~7 deg at 1 m, 2.7 ms of a 7 Hz turn: docs/device-codecs.md).
inline ::testing::AssertionResult SameCloudWithinBinning(const std::vector<CloudPoint>& native,
                                                         const std::vector<CloudPoint>& imported) {
  if (imported.size() != native.size() || native.empty()) {
    return ::testing::AssertionFailure() << imported.size() << " points, expected " << native.size();
  }
  std::vector<double> d(native.size());
  const int64_t shift = imported[0].time_ns - native[0].time_ns;
  for (size_t i = 0; i < native.size(); ++i) {
    const Eigen::Vector3f a(native[i].x, native[i].y, native[i].z), b(imported[i].x, imported[i].y, imported[i].z);
    d[i] = (a - b).norm();
    if (imported[i].range_m != native[i].range_m) {
      return ::testing::AssertionFailure() << "point " << i << ": range " << imported[i].range_m << ", expected "
                                           << native[i].range_m;
    }
    const int64_t dt = imported[i].time_ns - native[i].time_ns - shift;
    if (dt > 3000000 || dt < -3000000) {
      return ::testing::AssertionFailure() << "point " << i << ": time off by " << dt << " ns";
    }
  }
  std::sort(d.begin(), d.end());
  const double median = d[d.size() / 2], p99 = d[d.size() * 99 / 100], max = d.back();
  if (median > 0.0005 || p99 > 0.002 || max > 0.006) {
    return ::testing::AssertionFailure() << "distances median " << median << " p99 " << p99 << " max " << max
                                         << " m (limits 0.0005, 0.002, 0.006)";
  }
  return ::testing::AssertionSuccess();
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_BINNED_CLOUD_H_
