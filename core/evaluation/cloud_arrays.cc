#include "core/evaluation/cloud_arrays.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>

#include "core/common/file_suffix.h"

namespace sweepscan {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

bool ReadLine(std::FILE* f, std::string* line) {
  line->clear();
  int c;
  // Only a line's last '\r' is its ending: one inside a line separates
  // words, as PCL and the validator (cloud_io.cc) read it ("POI\rNTS" was
  // POINTS here and nothing there).
  const auto cut = [&] {
    if (!line->empty() && line->back() == '\r') line->pop_back();
  };
  while ((c = std::fgetc(f)) != EOF) {
    if (c == '\n') {
      cut();
      return true;
    }
    line->push_back(static_cast<char>(c));
    if (line->size() > 4096) return false;
  }
  cut();
  return !line->empty();
}

// Field layout of one record: where x, y, z are and how wide.
struct Layout {
  size_t record = 0;
  size_t offset[3] = {0, 0, 0};
  int width[3] = {0, 0, 0};  // 4 float, 8 double
};

double Get(const unsigned char* p, int width) {
  if (width == 4) {
    float v;
    std::memcpy(&v, p, 4);
    return v;
  }
  double v;
  std::memcpy(&v, p, 8);
  return v;
}

CloudReadResult ReadRecords(std::FILE* f, size_t count, const Layout& layout, const std::string& path,
                            std::vector<Eigen::Vector3f>* points, std::string* error) {
  points->clear();
  // Checked here, against the bytes after the header, before anything is
  // allocated: not trusted to another parser's reading of the header.
  const long at = std::ftell(f);
  struct stat st {};
  const uint64_t follow = at >= 0 && fstat(fileno(f), &st) == 0 && st.st_size > at
                              ? static_cast<uint64_t>(st.st_size - at)
                              : 0;
  if (layout.record == 0 || count > follow / layout.record) {
    *error = path + ": truncated (" + std::to_string(count) + " points of " +
             std::to_string(layout.record) + " bytes declared, " + std::to_string(follow) +
             " bytes follow the header)";
    return CloudReadResult::kError;
  }
  points->reserve(count);
  constexpr size_t kChunkRecords = 1 << 16;
  // At most what the file holds (checked above): a header of one point of
  // 2^20 doubles would otherwise cost 64k records of 8 MiB.
  std::vector<unsigned char> buffer(std::min(count, kChunkRecords) * layout.record);
  size_t left = count;
  while (left > 0) {
    const size_t want = std::min(left, kChunkRecords);
    if (std::fread(buffer.data(), layout.record, want, f) != want) {
      *error = path + ": truncated (" + std::to_string(count - left) + " of " +
               std::to_string(count) + " points)";
      return CloudReadResult::kError;
    }
    for (size_t r = 0; r < want; ++r) {
      const unsigned char* rec = buffer.data() + r * layout.record;
      const float x = static_cast<float>(Get(rec + layout.offset[0], layout.width[0]));
      const float y = static_cast<float>(Get(rec + layout.offset[1], layout.width[1]));
      const float z = static_cast<float>(Get(rec + layout.offset[2], layout.width[2]));
      if (std::isfinite(x) && std::isfinite(y) && std::isfinite(z)) points->emplace_back(x, y, z);
    }
    left -= want;
  }
  return CloudReadResult::kOk;
}

int PlyWidth(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
      type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

bool IsFloatType(const std::string& type, int width) {
  return (width == 4 && (type == "float" || type == "float32")) ||
         (width == 8 && (type == "double" || type == "float64"));
}

CloudReadResult ReadPly(std::FILE* f, const std::string& path, std::vector<Eigen::Vector3f>* points,
                        std::string* error) {
  std::string line;
  if (!ReadLine(f, &line) || line != "ply") return CloudReadResult::kUnsupported;
  Layout layout;
  bool found[3] = {false, false, false};
  size_t count = 0;
  int element = 0;  // 0 none yet, 1 vertex (first), 2 later elements
  while (ReadLine(f, &line)) {
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "format") {
      std::string format;
      in >> format;
      if (format != "binary_little_endian") return CloudReadResult::kUnsupported;
    } else if (word == "element") {
      std::string name;
      in >> name;
      if (element == 0) {
        if (name != "vertex" || !(in >> count)) return CloudReadResult::kUnsupported;
        element = 1;
      } else {
        element = 2;
      }
    } else if (word == "property" && element == 1) {
      std::string type, name;
      in >> type >> name;
      const int width = PlyWidth(type);
      if (width == 0) return CloudReadResult::kUnsupported;  // a list, or unknown
      for (int a = 0; a < 3; ++a) {
        if (name == std::string(1, static_cast<char>('x' + a))) {
          if (!IsFloatType(type, width)) return CloudReadResult::kUnsupported;
          layout.offset[a] = layout.record;
          layout.width[a] = width;
          found[a] = true;
        }
      }
      layout.record += static_cast<size_t>(width);
    } else if (word == "end_header") {
      if (!found[0] || !found[1] || !found[2]) return CloudReadResult::kUnsupported;
      return ReadRecords(f, count, layout, path, points, error);
    }
  }
  return CloudReadResult::kUnsupported;
}

CloudReadResult ReadPcd(std::FILE* f, const std::string& path, std::vector<Eigen::Vector3f>* points,
                        std::string* error) {
  std::string line;
  std::vector<std::string> fields, types;
  std::vector<size_t> sizes, counts;
  size_t n = 0;
  while (ReadLine(f, &line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string word, v;
    in >> word;
    if (word == "FIELDS") {
      while (in >> v) fields.push_back(v);
    } else if (word == "SIZE") {
      while (in >> v) sizes.push_back(std::stoul(v));
    } else if (word == "TYPE") {
      while (in >> v) types.push_back(v);
    } else if (word == "COUNT") {
      while (in >> v) counts.push_back(std::stoul(v));
    } else if (word == "POINTS") {
      in >> n;
    } else if (word == "DATA") {
      in >> v;
      if (v != "binary") return CloudReadResult::kUnsupported;
      if (counts.empty()) counts.assign(fields.size(), 1);
      if (sizes.size() != fields.size() || types.size() != fields.size() ||
          counts.size() != fields.size()) {
        return CloudReadResult::kUnsupported;
      }
      Layout layout;
      bool found[3] = {false, false, false};
      for (size_t i = 0; i < fields.size(); ++i) {
        for (int a = 0; a < 3; ++a) {
          if (fields[i] == std::string(1, static_cast<char>('x' + a))) {
            if (types[i] != "F" || (sizes[i] != 4 && sizes[i] != 8) || counts[i] != 1) {
              return CloudReadResult::kUnsupported;
            }
            layout.offset[a] = layout.record;
            layout.width[a] = static_cast<int>(sizes[i]);
            found[a] = true;
          }
        }
        layout.record += sizes[i] * counts[i];
      }
      if (!found[0] || !found[1] || !found[2]) return CloudReadResult::kUnsupported;
      return ReadRecords(f, n, layout, path, points, error);
    }
  }
  return CloudReadResult::kUnsupported;
}

}  // namespace

CloudReadResult ReadCloudPositions(const std::string& path, std::vector<Eigen::Vector3f>* points,
                                   std::string* error) {
  const bool ply = HasFileSuffix(path, ".ply");
  if (!ply && !HasFileSuffix(path, ".pcd")) return CloudReadResult::kUnsupported;
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) {
    *error = path + ": cannot open for reading";
    return CloudReadResult::kError;
  }
  try {
    return ply ? ReadPly(f.get(), path, points, error) : ReadPcd(f.get(), path, points, error);
  } catch (const std::exception&) {  // std::stoul on a malformed header
    return CloudReadResult::kUnsupported;
  }
}

}  // namespace sweepscan
