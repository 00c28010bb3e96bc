// A LAS 1.4 file of ours read back field by field at the offsets
// docs/las-format.md gives (point format 6), for tests that check where a
// writer put each point, under which Point Source ID and with which time.
// Not a general reader: tests/tools/read_las.mjs reads our files with
// independent ones.
#ifndef SWEEPSCAN_TESTS_TESTING_LAS_RECORDS_H_
#define SWEEPSCAN_TESTS_TESTING_LAS_RECORDS_H_

#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

namespace sweepscan::testing {

struct LasRecords {
  std::string bytes;
  uint16_t global_encoding = 0;
  std::string system_identifier;
  uint32_t start = 0;  // offset to the point data
  uint16_t size = 0;   // record length
  uint64_t count = 0;  // number of point records
  double scale[3] = {0, 0, 0};
  double offset[3] = {0, 0, 0};

  // False unless PATH is a LAS file whose records fill it exactly.
  bool Read(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
    if (bytes.size() < 375 || bytes.compare(0, 4, "LASF") != 0) return false;
    global_encoding = Get<uint16_t>(6);
    system_identifier = std::string(bytes.data() + 26, strnlen(bytes.data() + 26, 32));
    start = Get<uint32_t>(96);
    size = Get<uint16_t>(105);
    count = Get<uint64_t>(247);
    for (int a = 0; a < 3; ++a) {
      scale[a] = Get<double>(131 + 8 * a);
      offset[a] = Get<double>(155 + 8 * a);
    }
    return size >= 30 && bytes.size() == start + count * size;
  }
  Eigen::Vector3d Position(size_t i) const {
    const size_t at = start + i * size;
    return {Get<int32_t>(at) * scale[0] + offset[0], Get<int32_t>(at + 4) * scale[1] + offset[1],
            Get<int32_t>(at + 8) * scale[2] + offset[2]};
  }
  uint16_t PointSourceId(size_t i) const { return Get<uint16_t>(start + i * size + 20); }
  double GpsTime(size_t i) const { return Get<double>(start + i * size + 22); }

  template <typename T>
  T Get(size_t at) const {
    T v;
    std::memcpy(&v, bytes.data() + at, sizeof(T));
    return v;
  }
};

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_TESTING_LAS_RECORDS_H_
