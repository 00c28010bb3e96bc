// All PCL templates of core's cloud I/O live in this one translation unit.
#include "core/cloud/cloud_io.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <pcl/conversions.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "core/common/checked_file.h"
#include "core/common/file_suffix.h"

namespace sweepscan {
struct EIGEN_ALIGN16 PclSweepPoint {
  PCL_ADD_POINT4D;
  float range;
  double time;
  std::uint32_t scan;
  std::uint16_t beam;
  std::uint8_t source;
  std::uint8_t flags;
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};
}  // namespace sweepscan

POINT_CLOUD_REGISTER_POINT_STRUCT(sweepscan::PclSweepPoint,
                                  (float, x, x)(float, y, y)(float, z, z)(float, range, range)(
                                      double, time, time)(std::uint32_t, scan, scan)(
                                      std::uint16_t, beam, beam)(std::uint8_t, source, source)(
                                      std::uint8_t, flags, flags))

namespace sweepscan {
namespace {

// PCL's PLY reader warns on stderr about the "camera" element its own writer
// adds; errors are reported through our Status instead.
void QuietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

// Little-endian appends for the hand-written binary bodies (x86 and ARM
// Linux are little-endian; PLY says so in its header, PCD assumes the host).
template <typename T>
void Put(std::string* out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out->append(b, sizeof(T));
}

// One vertex in file order: x y z range (float), time (double), scan (u32),
// beam (u16), source, flags (u8): 32 bytes, packed.
constexpr size_t kRecordSize = 4 * 4 + 8 + 4 + 2 + 1 + 1;

void AppendRecord(const CloudPoint& p, std::string* out) {
  Put<float>(out, p.x);
  Put<float>(out, p.y);
  Put<float>(out, p.z);
  Put<float>(out, p.range_m);
  Put<double>(out, static_cast<double>(p.time_ns) * 1e-9);
  Put<std::uint32_t>(out, p.scan);
  Put<std::uint16_t>(out, p.beam);
  Put<std::uint8_t>(out, p.pose_source);
  Put<std::uint8_t>(out, p.flags);
}

std::string PlyHeader(size_t n) {
  return "ply\nformat binary_little_endian 1.0\ncomment sweepscan cloud (docs/cloud-format.md)\n"
         "element vertex " +
         std::to_string(n) +
         "\nproperty float x\nproperty float y\nproperty float z\nproperty float range\n"
         "property double time\nproperty uint scan\nproperty ushort beam\nproperty uchar source\n"
         "property uchar flags\nend_header\n";
}

std::string PcdHeader(size_t n) {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
         "FIELDS x y z range time scan beam source flags\nSIZE 4 4 4 4 8 4 2 1 1\n"
         "TYPE F F F F F U U U U\nCOUNT 1 1 1 1 1 1 1 1 1\nWIDTH " +
         std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(n) +
         "\nDATA binary\n";
}

// A streamed file's header: the count is known only at the end, so the
// header has a fixed length whatever it is, a comment line padding the
// count's digits to 20 (the most a uint64 has).
std::string StreamedHeader(bool ply, uint64_t n) {
  const size_t digits = std::to_string(n).size();
  if (ply) {
    std::string h = PlyHeader(n);
    const std::string pad = "comment " + std::string(20 - digits, ' ') + "\n";
    return h.insert(h.find("element vertex"), pad);
  }
  std::string h = PcdHeader(n);
  const std::string pad = "# " + std::string(2 * (20 - digits), ' ') + "\n";
  return h.insert(h.find("VERSION"), pad);
}

// ---------------------------------------------------------------------------
// Header validation before PCL allocates anything: the counts a header
// declares must fit the bytes that follow it.

std::vector<std::string> SplitWords(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  std::string w;
  while (in >> w) words.push_back(w);
  return words;
}

// A plain non-negative decimal (no sign, no exponent) of at most 15 digits.
bool ParseCount(const std::string& s, uint64_t* out) {
  if (s.empty() || s.size() > 15 || s.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  *out = std::stoull(s);
  return true;
}

int PlyTypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" ||
      t == "float32") {
    return 4;
  }
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// Reads the header (at most 64 KiB); *data_offset is the first data byte.
Status ReadHeaderLines(const std::string& path, const char* end_marker,
                       std::vector<std::string>* lines, uint64_t* data_offset) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open for reading");
  std::string head(64 * 1024, '\0');
  in.read(&head[0], static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  size_t pos = 0;
  while (pos < head.size()) {
    const size_t nl = head.find('\n', pos);
    if (nl == std::string::npos) break;
    std::string line = head.substr(pos, nl - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = nl + 1;
    lines->push_back(line);
    const std::vector<std::string> w = SplitWords(line);
    if (!w.empty() && w[0] == end_marker) {
      *data_offset = pos;
      return Status::Ok();
    }
  }
  return Status::Error(path + ": not a readable point cloud (no " + end_marker +
                       " line within the first 64 KiB)");
}

Status ValidatePly(const std::string& path, uint64_t file_size) {
  std::vector<std::string> lines;
  uint64_t data_offset = 0;
  Status s = ReadHeaderLines(path, "end_header", &lines, &data_offset);
  if (!s.ok()) return s;
  auto bad = [&](const std::string& why) {
    return Status::Error(path + ": not a readable point cloud (PLY header: " + why + ")");
  };
  if (lines.empty() || lines[0] != "ply") return bad("does not start with 'ply'");
  std::string format;
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t fixed_bytes = 0;     // Per row, fixed-size properties.
    uint64_t min_list_bytes = 0;  // Per row, the count fields of list properties.
    int properties = 0;
  };
  std::vector<Element> elements;
  // PCL sizes the cloud as width x height rows of the vertex element, in
  // header order: `obj_info num_cols` / `num_rows` set either, and
  // `element vertex N` sets N x 1 unless both were set (PCL's writer puts
  // an organised cloud's before it). They must agree with the vertex count
  // or the range grid's, or PCL allocates what they say (a 250-byte file
  // with num_cols and num_rows of 20 000 cost 4.8 GB before a byte was read).
  uint64_t width = 0, height = 0;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> w = SplitWords(lines[i]);
    if (!w.empty() && w[0] == "obj_info" && w.size() >= 3 &&
        (w[1] == "num_cols" || w[1] == "num_rows")) {
      uint64_t v = 0;
      if (!ParseCount(w[2], &v)) return bad("'" + lines[i] + "' has no valid count");
      (w[1] == "num_cols" ? width : height) = v;
      continue;
    }
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info" || w[0] == "end_header") continue;
    if (w[0] == "format") {
      if (w.size() < 2) return bad("format line without a format");
      format = w[1];
    } else if (w[0] == "element") {
      Element e;
      if (w.size() != 3 || !ParseCount(w[2], &e.count)) {
        return bad("'" + lines[i] + "' has no valid non-negative count");
      }
      e.name = w[1];
      for (const Element& seen : elements) {
        // PCL takes the cloud's rows from one and its width from the other.
        if (seen.name == e.name) return bad("two '" + e.name + "' elements");
      }
      if (e.name == "vertex" && (width == 0 || height == 0)) {
        width = e.count;
        height = 1;
      }
      elements.push_back(e);
    } else if (w[0] == "property") {
      if (elements.empty()) return bad("property before any element");
      Element& e = elements.back();
      ++e.properties;
      if (w.size() >= 2 && w[1] == "list") {
        // PCL sizes every vertex row by the first one's lists: one long
        // list first, then short rows, is the first row times the count.
        if (e.name == "vertex") return bad("a list property in the vertex element");
        const int count_size = w.size() == 5 ? PlyTypeSize(w[2]) : 0;
        if (count_size == 0 || PlyTypeSize(w[3]) == 0) return bad("bad list property");
        e.min_list_bytes += static_cast<uint64_t>(count_size);
      } else {
        const int size = w.size() == 3 ? PlyTypeSize(w[1]) : 0;
        if (size == 0) return bad("bad property '" + lines[i] + "'");
        e.fixed_bytes += static_cast<uint64_t>(size);
      }
    } else {
      return bad("unknown header line '" + lines[i] + "'");
    }
  }
  if (format.empty()) return bad("no format line");
  const Element* vertex = nullptr;
  const Element* grid = nullptr;
  for (const Element& e : elements) {
    if (e.name == "vertex") vertex = &e;
    if (e.name == "range_grid") grid = &e;
  }
  const uint64_t vertices = vertex != nullptr ? vertex->count : 0;
  const uint64_t cells = grid != nullptr ? grid->count : vertices;
  const bool fits = height != 0 && width <= UINT64_MAX / height;
  if (vertex != nullptr &&
      !(fits && (width * height == vertices || width * height == cells))) {
    return bad("obj_info num_cols x num_rows (" + std::to_string(width) + " x " +
               std::to_string(height) + ") differs from the " + std::to_string(vertices) +
               " vertices");
  }
  const uint64_t data_size = file_size - data_offset;
  // PCL lays an organised cloud out on its range grid, a vertex row a cell
  // (the invalid cells cost a row too): bounded by the file, or a grid of
  // one-byte rows would cost a vertex row each (26 000 times the file).
  if (grid != nullptr && vertex != nullptr && vertex->fixed_bytes > 0 &&
      grid->count > 64 * std::max<uint64_t>(data_size, 1) / vertex->fixed_bytes) {
    return bad("a range grid of " + std::to_string(grid->count) + " cells of " +
               std::to_string(vertex->fixed_bytes) + " bytes for " + std::to_string(data_size) +
               " bytes of data");
  }
  const std::string declared = std::to_string(data_size) + " bytes follow the header";
  if (format == "ascii") {
    // Every value needs at least one character and a separator.
    for (const Element& e : elements) {
      const uint64_t per_row = 2 * static_cast<uint64_t>(std::max(1, e.properties));
      if (e.count > data_size / per_row) {
        return bad("element " + e.name + " declares " + std::to_string(e.count) +
                   " rows but only " + declared);
      }
    }
    return Status::Ok();
  }
  if (format != "binary_little_endian" && format != "binary_big_endian") {
    return bad("unknown format '" + format + "'");
  }
  uint64_t expected = 0;
  bool exact = true;
  for (const Element& e : elements) {
    const uint64_t row = e.fixed_bytes + e.min_list_bytes;
    if (e.min_list_bytes > 0) exact = false;
    if (row == 0 && e.count > 0) {
      // Rows of no bytes: any count fits, and the reader would loop (or
      // allocate) once per declared row.
      return bad("element " + e.name + " declares " + std::to_string(e.count) +
                 " rows but no properties");
    }
    if (row > 0 && e.count > data_size / row) {
      return bad("element " + e.name + " declares " + std::to_string(e.count) + " rows of " +
                 std::to_string(row) + " bytes but only " + declared);
    }
    expected += e.count * row;
    if (expected > data_size) {
      return bad("the elements need " + std::to_string(expected) + " bytes but only " + declared);
    }
  }
  if (exact && expected != data_size) {
    return bad("the elements need " + std::to_string(expected) + " bytes but " + declared +
               " (trailing junk or a cut file)");
  }
  return Status::Ok();
}

Status ValidatePcd(const std::string& path, uint64_t file_size) {
  std::vector<std::string> lines;
  uint64_t data_offset = 0;
  Status s = ReadHeaderLines(path, "DATA", &lines, &data_offset);
  if (!s.ok()) return s;
  auto bad = [&](const std::string& why) {
    return Status::Error(path + ": not a readable point cloud (PCD header: " + why + ")");
  };
  std::vector<uint64_t> sizes, counts;
  uint64_t width = 0, height = 1, points = 0;
  bool have_points = false, have_width = false;
  std::string data;
  // PCL matches a keyword by its first letters ("POINTSx" is POINTS) and
  // acts on every line (each POINTS resizes the cloud: POINTS 300000000
  // then POINTS 1 kept 3.6 GB): a keyword is taken exactly and once.
  static const char* const kKeywords[] = {"VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE",
                                          "COUNT",   "WIDTH",  "HEIGHT",  "VIEWPOINT",
                                          "POINTS",  "DATA"};
  std::set<std::string> seen;
  for (const std::string& line : lines) {
    const std::vector<std::string> w = SplitWords(line);
    if (w.empty() || w[0][0] == '#') continue;
    for (const char* k : kKeywords) {
      if (w[0].compare(0, std::strlen(k), k) != 0) continue;
      if (w[0] != k) return bad("unknown header line '" + line + "'");
      if (!seen.insert(k).second) return bad("two " + std::string(k) + " lines");
    }
    auto numbers = [&](std::vector<uint64_t>* out) {
      for (size_t i = 1; i < w.size(); ++i) {
        uint64_t v;
        if (!ParseCount(w[i], &v)) return false;
        out->push_back(v);
      }
      return true;
    };
    if (w[0] == "SIZE") {
      if (!numbers(&sizes)) return bad("bad SIZE");
    } else if (w[0] == "COUNT") {
      if (!numbers(&counts)) return bad("bad COUNT");
    } else if (w[0] == "WIDTH") {
      if (w.size() != 2 || !ParseCount(w[1], &width)) return bad("bad WIDTH");
      have_width = true;
    } else if (w[0] == "HEIGHT") {
      if (w.size() != 2 || !ParseCount(w[1], &height)) return bad("bad HEIGHT");
    } else if (w[0] == "POINTS") {
      if (w.size() != 2 || !ParseCount(w[1], &points)) return bad("bad POINTS");
      have_points = true;
    } else if (w[0] == "DATA") {
      if (w.size() != 2) return bad("bad DATA");
      data = w[1];
    }
  }
  if (sizes.empty()) return bad("no SIZE line");
  if (counts.empty()) counts.assign(sizes.size(), 1);
  if (counts.size() != sizes.size()) return bad("SIZE and COUNT differ in length");
  if (!have_points) {
    if (!have_width) return bad("neither POINTS nor WIDTH");
    points = width * height;
  }
  if (have_width && width * height != points) return bad("WIDTH x HEIGHT differs from POINTS");
  uint64_t point_size = 0;
  for (size_t i = 0; i < sizes.size(); ++i) {
    if (sizes[i] != 1 && sizes[i] != 2 && sizes[i] != 4 && sizes[i] != 8) return bad("bad SIZE");
    if (counts[i] > (1u << 20)) return bad("COUNT too large");
    point_size += sizes[i] * counts[i];
  }
  const uint64_t data_size = file_size - data_offset;
  const std::string declared = std::to_string(data_size) + " bytes follow the header";
  if (data == "ascii") {
    // Every value needs at least one character and a separator (PCL
    // allocates points x point_size before it parses a line).
    uint64_t values = 0;
    for (const uint64_t c : counts) values += c;
    if (values == 0 || points > data_size / (2 * values)) {
      return bad("POINTS " + std::to_string(points) + " of " + std::to_string(values) +
                 " values but only " + declared);
    }
    return Status::Ok();
  }
  if (data == "binary") {
    if (point_size == 0 || points > data_size / point_size || points * point_size != data_size) {
      return bad("POINTS " + std::to_string(points) + " of " + std::to_string(point_size) +
                 " bytes but " + declared);
    }
    return Status::Ok();
  }
  if (data == "binary_compressed") {
    if (data_size < 8) return bad("compressed data shorter than its 8-byte sizes");
    // The data start with their compressed and uncompressed sizes (u32
    // little-endian). PCL allocates the uncompressed size twice, zeroed,
    // before it decompresses: it must be the points' bytes, and the
    // compressed bytes must be in the file.
    uint32_t sizes_at[2] = {0, 0};
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(data_offset));
    if (!in.read(reinterpret_cast<char*>(sizes_at), sizeof(sizes_at)))
      return bad("cannot read the compressed data's sizes");
    const uint64_t compressed = sizes_at[0], uncompressed = sizes_at[1];
    if (compressed > data_size - 8) {
      return bad("compressed data of " + std::to_string(compressed) + " bytes but " + declared);
    }
    if (point_size == 0 || points > UINT64_MAX / point_size ||
        uncompressed != points * point_size) {
      return bad("POINTS " + std::to_string(points) + " of " + std::to_string(point_size) +
                 " bytes but the data decompress to " + std::to_string(uncompressed));
    }
    // LZF's best ratio is about 1:100.
    if (points / 128 > std::max<uint64_t>(compressed, 1) / point_size + 1) {
      return bad("POINTS " + std::to_string(points) + " for only " + std::to_string(compressed) +
                 " bytes of compressed data");
    }
    return Status::Ok();
  }
  return bad("unknown DATA '" + data + "'");
}

}  // namespace

Status SaveCloud(const std::string& path, const std::vector<CloudPoint>& points) {
  const bool ply = HasFileSuffix(path, ".ply");
  if (!ply && !HasFileSuffix(path, ".pcd")) {
    return Status::Error(path + ": unknown cloud format (use .ply or .pcd)");
  }
  // Written by hand through the checked writer: PCL's PLY writer reports
  // success after a failed write (on a full disk it left a short file whose
  // header promised every point) and its PCD writer throws.
  CheckedFileWriter out;
  Status s = out.Open(path);
  if (!s.ok()) return s;
  s = out.Write(ply ? PlyHeader(points.size()) : PcdHeader(points.size()));
  std::string chunk;
  chunk.reserve(4096 * kRecordSize);
  for (size_t i = 0; i < points.size() && s.ok(); ++i) {
    AppendRecord(points[i], &chunk);
    if (chunk.size() >= 4096 * kRecordSize || i + 1 == points.size()) {
      s = out.Write(chunk);
      chunk.clear();
    }
  }
  if (!s.ok()) return s;  // The writer removes its temporary.
  return out.Commit();
}

Status CloudFileWriter::Open(const std::string& path) {
  ply_ = HasFileSuffix(path, ".ply");
  if (!ply_ && !HasFileSuffix(path, ".pcd")) {
    return Status::Error(path + ": unknown cloud format (use .ply or .pcd)");
  }
  points_ = 0;
  Status s = out_.Open(path);
  if (s.ok()) s = out_.Write(StreamedHeader(ply_, 0));
  return s;
}

Status CloudFileWriter::Append(const CloudPoint* points, size_t n) {
  Status s;
  for (size_t i = 0; i < n && s.ok(); ++i) {
    AppendRecord(points[i], &chunk_);
    if (chunk_.size() >= 4096 * kRecordSize) {
      s = out_.Write(chunk_);
      chunk_.clear();
    }
  }
  points_ += n;
  return s;
}

Status CloudFileWriter::Finish() {
  Status s = out_.Write(chunk_);
  chunk_.clear();
  const std::string header = StreamedHeader(ply_, points_);
  if (s.ok()) s = out_.Overwrite(0, header.data(), header.size());
  if (!s.ok()) return s;  // The writer removes its temporary.
  return out_.Commit();
}

Status SaveCloud(const std::string& path, const CloudSnapshotRef& cloud,
                 const std::atomic<bool>* cancel) {
  CloudFileWriter out;
  Status s = out.Open(path);
  const bool all = s.ok() && cloud.ForEachChunk([&](const CloudPoint* p, size_t n) {
    s = out.Append(p, n);
    return s.ok() && !(cancel != nullptr && *cancel);
  });
  if (!s.ok()) return s;  // The writer removes its temporary.
  if (!all) return Status::Error(path + ": cancelled");
  return out.Finish();
}

Status ValidateCloudFile(const std::string& path) {
  uint64_t size = 0;
  const Status regular = CheckRegularFile(path, &size);
  if (!regular.ok()) return regular;
  if (HasFileSuffix(path, ".ply")) return ValidatePly(path, size);
  if (HasFileSuffix(path, ".pcd")) return ValidatePcd(path, size);
  return Status::Error(path + ": unknown cloud format (use .ply or .pcd)");
}

// PCL's blob of a PLY or PCD file (by extension), holding the width x
// height points it says: a PLY camera element's viewport, read from the
// data, resets them after the blob was sized (the conversion to points
// then allocated what they said and read past the blob).
Status ReadBlob(const std::string& path, pcl::PCLPointCloud2* blob) {
  QuietPcl();
  int rc = -1;
  try {
    rc = HasFileSuffix(path, ".ply") ? pcl::io::loadPLYFile(path, *blob)
                                     : pcl::io::loadPCDFile(path, *blob);
  } catch (const std::bad_alloc&) {
    return Status::Error(path + ": not a readable point cloud (too large for memory)");
  } catch (const std::exception& e) {
    return Status::Error(path + ": not a readable point cloud (" + e.what() + ")");
  }
  if (rc != 0) return Status::Error(path + ": not a readable point cloud (PCL could not parse it)");
  const uint64_t n = static_cast<uint64_t>(blob->width) * blob->height;
  if (n > 0 && (blob->point_step == 0 || blob->data.size() / blob->point_step < n)) {
    return Status::Error(path + ": not a readable point cloud (" + std::to_string(blob->width) +
                         " x " + std::to_string(blob->height) + " points but " +
                         std::to_string(blob->data.size()) + " bytes of " +
                         std::to_string(blob->point_step) + " a point)");
  }
  return Status::Ok();
}

// PCL's blob as a cloud of PointT (each field PointT has, copied where the
// file has it with the same type).
template <typename PointT>
Status ConvertBlob(const std::string& path, const pcl::PCLPointCloud2& blob,
                   pcl::PointCloud<PointT>* cloud) {
  try {
    pcl::fromPCLPointCloud2(blob, *cloud);
  } catch (const std::bad_alloc&) {
    return Status::Error(path + ": not a readable point cloud (too large for memory)");
  } catch (const std::exception& e) {
    return Status::Error(path + ": not a readable point cloud (" + e.what() + ")");
  }
  return Status::Ok();
}

// How a file stores x, y and z: PCL copies a field into a point only when
// its type is the point's, so a PLY whose coordinates are double (what
// CloudCompare and PDAL write for a georeferenced cloud) came back as a
// cloud of zeros, without a word. Float (4-byte) positions are read as
// they are; double ones through PCLPointCloud2 and converted; any other
// type, or a missing axis, is refused by name.
enum class PositionType { kFloat, kDouble };
Status ReadPositionType(const std::string& path, PositionType* type) {
  std::vector<std::string> lines;
  uint64_t offset = 0;
  const bool ply = HasFileSuffix(path, ".ply");
  Status s = ReadHeaderLines(path, ply ? "end_header" : "DATA", &lines, &offset);
  if (!s.ok()) return s;
  std::string types[3];  // As the header names them: "float", "double", "int"...
  const char* const kAxes[3] = {"x", "y", "z"};
  if (ply) {
    bool vertex = false;
    for (const std::string& line : lines) {
      const std::vector<std::string> w = SplitWords(line);
      if (w.size() >= 2 && w[0] == "element") vertex = w[1] == "vertex";
      if (!vertex || w.size() != 3 || w[0] != "property") continue;
      for (int a = 0; a < 3; ++a) {
        if (w[2] == kAxes[a])
          types[a] = w[1] == "float32" ? "float" : w[1] == "float64" ? "double" : w[1];
      }
    }
  } else {
    std::vector<std::string> fields, sizes, kinds;
    for (const std::string& line : lines) {
      std::vector<std::string> w = SplitWords(line);
      if (w.empty()) continue;
      const std::string key = w[0];
      w.erase(w.begin());
      if (key == "FIELDS" || key == "COLUMNS") fields = w;  // COLUMNS: PCD 0.5
      if (key == "SIZE") sizes = w;
      if (key == "TYPE") kinds = w;
    }
    for (size_t i = 0; i < fields.size(); ++i) {
      // PCL reads a field without a TYPE as F and without a SIZE as 4.
      const std::string kind = i < kinds.size() ? kinds[i] : "F";
      const std::string size = i < sizes.size() ? sizes[i] : "4";
      for (int a = 0; a < 3; ++a) {
        if (fields[i] != kAxes[a]) continue;
        types[a] = kind == "F" && size == "4"   ? "float"
                   : kind == "F" && size == "8" ? "double"
                                                : kind + size;
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (types[a].empty()) return Status::Error(path + ": has no " + kAxes[a] + " coordinate");
    if (types[a] != "float" && types[a] != "double") {
      return Status::Error(path + ": its " + kAxes[a] + " coordinates are of type " + types[a] +
                           "; sweepscan reads float or double coordinates");
    }
  }
  const bool all_float = types[0] == "float" && types[1] == "float" && types[2] == "float";
  *type = all_float ? PositionType::kFloat : PositionType::kDouble;
  return Status::Ok();
}

// The positions of a cloud whose coordinates are (some of them) double,
// converted to the store's float. Refused if a finite one lies beyond
// 8 000 m of the origin: float keeps whole millimetres only within 8 192 m,
// and a georeferenced cloud (a UTM northing of 5 000 km) would come back in
// half-metre steps, every plane and distance measured on it wrong.
Status DoublePositions(const std::string& path, const pcl::PCLPointCloud2& blob,
                       std::vector<Eigen::Vector3f>* points) {
  int offset[3] = {-1, -1, -1};
  uint8_t type[3] = {0, 0, 0};
  for (const pcl::PCLPointField& f : blob.fields) {
    const int a = f.name == "x" ? 0 : f.name == "y" ? 1 : f.name == "z" ? 2 : -1;
    if (a < 0) continue;
    offset[a] = static_cast<int>(f.offset);
    type[a] = f.datatype;
  }
  for (int a = 0; a < 3; ++a) {
    if (offset[a] < 0 ||
        (type[a] != pcl::PCLPointField::FLOAT32 && type[a] != pcl::PCLPointField::FLOAT64)) {
      return Status::Error(
          path + ": not a readable point cloud (its coordinates are not float or double)");
    }
  }
  const size_t n = static_cast<size_t>(blob.width) * blob.height;  // ReadBlob checked
  points->resize(n);
  double farthest = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* row = blob.data.data() + i * blob.point_step;
    for (int a = 0; a < 3; ++a) {
      double v;
      if (type[a] == pcl::PCLPointField::FLOAT64) {
        std::memcpy(&v, row + offset[a], sizeof(v));
      } else {
        float f;
        std::memcpy(&f, row + offset[a], sizeof(f));
        v = f;
      }
      if (std::isfinite(v)) farthest = std::max(farthest, std::abs(v));
      (*points)[i][a] = static_cast<float>(v);
    }
  }
  if (farthest > 8000.0) {
    char why[200];
    std::snprintf(
        why, sizeof(why),
        ": its coordinates reach %.0f m from the origin, beyond 8000 m, where sweepscan's float "
        "positions would round them to %.2g m; move the cloud near the origin first",
        farthest, std::ldexp(1.0, std::ilogb(farthest) - 23));
    return Status::Error(path + why);
  }
  return Status::Ok();
}

// The file checked, how it stores its positions, and PCL's blob of it: one
// read of the file serves both the positions and the other fields.
Status ReadCloudFile(const std::string& path, PositionType* type, pcl::PCLPointCloud2* blob) {
  Status s = ValidateCloudFile(path);
  if (s.ok()) s = ReadPositionType(path, type);
  if (s.ok()) s = ReadBlob(path, blob);
  return s;
}

Status LoadCloudPositions(const std::string& path, std::vector<Eigen::Vector3f>* points) {
  PositionType type = PositionType::kFloat;
  pcl::PCLPointCloud2 blob;
  Status s = ReadCloudFile(path, &type, &blob);
  if (!s.ok()) return s;
  points->clear();
  if (type == PositionType::kDouble) {
    s = DoublePositions(path, blob, points);
    if (!s.ok()) return s;
    points->erase(std::remove_if(points->begin(), points->end(),
                                 [](const Eigen::Vector3f& p) { return !p.allFinite(); }),
                  points->end());
    return Status::Ok();
  }
  pcl::PointCloud<pcl::PointXYZ> cloud;
  s = ConvertBlob(path, blob, &cloud);
  if (!s.ok()) return s;
  decltype(blob.data)().swap(blob.data);  // Its bytes are in the cloud now.
  points->reserve(cloud.size());
  for (const auto& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) points->emplace_back(p.x, p.y, p.z);
  }
  return Status::Ok();
}

Status LoadCloud(const std::string& path, std::vector<CloudPoint>* points) {
  PositionType type = PositionType::kFloat;
  pcl::PCLPointCloud2 blob;
  Status s = ReadCloudFile(path, &type, &blob);
  if (!s.ok()) return s;
  std::vector<Eigen::Vector3f> doubles;  // A double file's positions, converted.
  if (type == PositionType::kDouble) {
    s = DoublePositions(path, blob, &doubles);
    if (!s.ok()) return s;
  }
  pcl::PointCloud<PclSweepPoint> cloud;
  s = ConvertBlob(path, blob, &cloud);
  if (!s.ok()) return s;
  decltype(blob.data)().swap(blob.data);  // Its bytes are in the cloud now.
  points->resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const PclSweepPoint& q = cloud[i];
    CloudPoint& p = (*points)[i];
    p.x = doubles.empty() ? q.x : doubles[i].x();
    p.y = doubles.empty() ? q.y : doubles[i].y();
    p.z = doubles.empty() ? q.z : doubles[i].z();
    p.range_m = q.range;
    p.time_ns = static_cast<int64_t>(std::llround(q.time * 1e9));
    p.scan = q.scan;
    p.beam = q.beam;
    p.pose_source = q.source;
    p.flags = q.flags;
  }
  return Status::Ok();
}

}  // namespace sweepscan
