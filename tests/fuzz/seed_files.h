// File helpers shared by the seed-corpus generators (make_seed_corpus,
// make_link_seed_corpus). A seed file is <chunk-selector byte> + content, as
// the fuzz targets expect.
#ifndef SWEEPSCAN_TESTS_FUZZ_SEED_FILES_H_
#define SWEEPSCAN_TESTS_FUZZ_SEED_FILES_H_

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace sweepscan::fuzz {

using Bytes = std::vector<uint8_t>;

inline void WriteSeed(const std::string& path, uint8_t selector, const Bytes& content) {
  std::ofstream out(path, std::ios::binary);
  out.put(static_cast<char>(selector));
  out.write(reinterpret_cast<const char*>(content.data()),
            static_cast<std::streamsize>(content.size()));
  if (!out) std::fprintf(stderr, "cannot write %s\n", path.c_str());
}

inline Bytes ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void Append(const Bytes& b, Bytes* out) { out->insert(out->end(), b.begin(), b.end()); }

}  // namespace sweepscan::fuzz

#endif  // SWEEPSCAN_TESTS_FUZZ_SEED_FILES_H_
