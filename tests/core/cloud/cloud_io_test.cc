#include "core/cloud/cloud_io.h"
#include "core/evaluation/cloud_arrays.h"

#include <gtest/gtest.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <limits>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>

namespace sweepscan {
namespace {

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/sweepscan_cloud_io_" + name;
}

std::vector<CloudPoint> RandomCloud(size_t n) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-5, 5);
  std::vector<CloudPoint> pts(n);
  for (size_t i = 0; i < n; ++i) {
    pts[i].x = u(rng);
    pts[i].y = u(rng);
    pts[i].z = u(rng);
    pts[i].range_m = std::abs(u(rng));
    pts[i].time_ns = 1'000'000'000 + static_cast<int64_t>(i) * 200'000;
    pts[i].scan = static_cast<uint32_t>(i / 700);
    pts[i].beam = static_cast<uint16_t>(i % 700);
    pts[i].pose_source = static_cast<uint8_t>(i % 3);
    pts[i].flags = static_cast<uint8_t>(i % 2);
  }
  return pts;
}

class CloudIoTest : public ::testing::TestWithParam<std::string> {};

TEST_P(CloudIoTest, RoundTripKeepsEveryAttribute) {
  const auto pts = RandomCloud(5000);
  const std::string path = TempPath("rt." + GetParam());
  ASSERT_TRUE(SaveCloud(path, pts).ok());
  std::vector<CloudPoint> back;
  const Status s = LoadCloud(path, &back);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(back.size(), pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_EQ(back[i].x, pts[i].x);
    EXPECT_EQ(back[i].z, pts[i].z);
    EXPECT_EQ(back[i].range_m, pts[i].range_m);
    EXPECT_EQ(back[i].time_ns, pts[i].time_ns);
    EXPECT_EQ(back[i].scan, pts[i].scan);
    EXPECT_EQ(back[i].beam, pts[i].beam);
    EXPECT_EQ(back[i].pose_source, pts[i].pose_source);
    EXPECT_EQ(back[i].flags, pts[i].flags);
  }
  std::vector<Eigen::Vector3f> xyz;
  ASSERT_TRUE(LoadCloudPositions(path, &xyz).ok());
  ASSERT_EQ(xyz.size(), pts.size());
  EXPECT_EQ(xyz[17].y(), pts[17].y);
  std::remove(path.c_str());
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A streamed reconstruction's file: written in pieces, the count known only
// at Finish. PCL reads it back whole, its records are SaveCloud's bytes,
// and its header has the same length whatever the count.
TEST_P(CloudIoTest, StreamedWriterGivesSaveCloudsRecordsInPieces) {
  const auto pts = RandomCloud(10001);
  const std::string whole = TempPath("whole." + GetParam());
  const std::string streamed = TempPath("streamed." + GetParam());
  ASSERT_TRUE(SaveCloud(whole, pts).ok());
  CloudFileWriter w;
  ASSERT_TRUE(w.Open(streamed).ok());
  size_t at = 0;
  for (size_t piece : {size_t{1}, size_t{0}, size_t{4999}, size_t{5001}}) {
    ASSERT_TRUE(w.Append(pts.data() + at, piece).ok());
    at += piece;
  }
  EXPECT_FALSE(std::ifstream(streamed).good());  // under its name only when finished
  ASSERT_TRUE(w.Finish().ok());
  EXPECT_EQ(w.points(), pts.size());
  std::vector<CloudPoint> back;
  const Status s = LoadCloud(streamed, &back);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(back.size(), pts.size());
  EXPECT_EQ(std::memcmp(back.data(), pts.data(), pts.size() * sizeof(CloudPoint)), 0);
  const std::string a = FileBytes(whole), b = FileBytes(streamed);
  const size_t records = pts.size() * 32;
  ASSERT_GT(b.size(), records);
  EXPECT_EQ(a.substr(a.size() - records), b.substr(b.size() - records));
  // Header: SaveCloud's plus one padding line, 20 - 5 digits (x2 for PCD) wide.
  const size_t pad = GetParam() == "ply" ? 8 + 15 + 1 : 2 + 30 + 1;
  EXPECT_EQ(b.size() - records, a.size() - records + pad);
  // The same header length for an empty cloud, which reads back empty.
  CloudFileWriter empty;
  ASSERT_TRUE(empty.Open(streamed).ok());
  ASSERT_TRUE(empty.Finish().ok());
  EXPECT_EQ(FileBytes(streamed).size(), b.size() - records);
  ASSERT_TRUE(LoadCloud(streamed, &back).ok());
  EXPECT_TRUE(back.empty());
  std::remove(whole.c_str());
  std::remove(streamed.c_str());
}

INSTANTIATE_TEST_SUITE_P(Formats, CloudIoTest, ::testing::Values("ply", "pcd"));

TEST(CloudIoErrorsTest, RefusesMissingCorruptAndUnknownFiles) {
  std::vector<Eigen::Vector3f> xyz;
  Status s = LoadCloudPositions(TempPath("missing.ply"), &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("cannot open"), std::string::npos);

  const std::string junk = TempPath("junk.ply");
  std::ofstream(junk) << "this is not a ply file\n";
  s = LoadCloudPositions(junk, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find(junk), std::string::npos);

  // A PLY cut in the middle of its binary body.
  const auto pts = RandomCloud(1000);
  const std::string cut = TempPath("cut.ply");
  ASSERT_TRUE(SaveCloud(cut, pts).ok());
  std::ifstream in(cut, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::vector<CloudPoint> back;
  EXPECT_FALSE(LoadCloud(cut, &back).ok());

  EXPECT_FALSE(SaveCloud(TempPath("x.xyz"), pts).ok());
  EXPECT_FALSE(SaveCloud("/dev/null/x.ply", pts).ok());
}

// Headers are checked against the file size before anything is allocated
// (issue 16: `element vertex -5` or 2^64-1 aborted with std::bad_alloc; 10
// declared vertices followed by 1.2 MB of junk were accepted).
void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string PlyHeaderFor(const std::string& count) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + count +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

// Double coordinates (CloudCompare's and PDAL's for a georeferenced cloud)
// are read as such: PCL copies a field only into one of its own type, and
// such a file came back as a cloud of zeros. Binary and ASCII PLY, and PCD.
// Another type is refused by name, and a double cloud far from the origin
// (a UTM northing) is refused rather than rounded to half-metre steps.
TEST(CloudIoErrorsTest, DoubleCoordinatesAreReadAndFarOnesRefused) {
  const std::vector<CloudPoint> pts = RandomCloud(500);
  auto ply = [&](const std::string& name, const std::string& format, const std::string& type,
                 double shift) {
    const std::string path = TempPath(name);
    std::ofstream out(path, std::ios::binary);
    out << "ply\nformat " << format << " 1.0\ncomment written by the test\nelement vertex "
        << pts.size() << "\nproperty " << type << " x\nproperty " << type << " y\nproperty " << type
        << " z\nproperty uchar red\nend_header\n";
    for (const CloudPoint& p : pts) {
      const double v[3] = {p.x + shift, p.y + shift, p.z};
      if (format == "ascii") {
        char line[128];
        std::snprintf(line, sizeof(line), "%.17g %.17g %.17g 7\n", v[0], v[1], v[2]);
        out << line;
      } else if (type == "double") {
        out.write(reinterpret_cast<const char*>(v), sizeof(v));
        out.put(7);
      } else {
        const int32_t iv[3] = {static_cast<int32_t>(v[0]), static_cast<int32_t>(v[1]),
                               static_cast<int32_t>(v[2])};
        out.write(reinterpret_cast<const char*>(iv), sizeof(iv));
        out.put(7);
      }
    }
    return path;
  };
  for (const std::string& format : {std::string("binary_little_endian"), std::string("ascii")}) {
    const std::string path = ply("double_" + format + ".ply", format, "double", 1000.0);
    std::vector<Eigen::Vector3f> xyz;
    ASSERT_TRUE(LoadCloudPositions(path, &xyz).ok()) << format;
    ASSERT_EQ(xyz.size(), pts.size());
    std::vector<CloudPoint> all;
    ASSERT_TRUE(LoadCloud(path, &all).ok()) << format;
    ASSERT_EQ(all.size(), pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3f want(static_cast<float>(pts[i].x + 1000.0),
                                 static_cast<float>(pts[i].y + 1000.0), pts[i].z);
      EXPECT_EQ(xyz[i], want) << format << " " << i;
      EXPECT_EQ(Eigen::Vector3f(all[i].x, all[i].y, all[i].z), want) << format << " " << i;
    }
  }
  const std::string pcd = TempPath("double.pcd");
  {
    std::ofstream out(pcd, std::ios::binary);
    out << "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << pts.size()
        << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << pts.size() << "\nDATA binary\n";
    for (const CloudPoint& p : pts) {
      const double v[3] = {p.x, p.y, p.z};
      out.write(reinterpret_cast<const char*>(v), sizeof(v));
    }
  }
  std::vector<Eigen::Vector3f> xyz;
  ASSERT_TRUE(LoadCloudPositions(pcd, &xyz).ok());
  ASSERT_EQ(xyz.size(), pts.size());
  EXPECT_EQ(xyz[17], Eigen::Vector3f(pts[17].x, pts[17].y, pts[17].z));

  // A PCD without a TYPE line gets PCL's answer, as before: the position
  // check takes its fields as float (not "has no x coordinate").
  const std::string untyped = TempPath("untyped.pcd");
  std::ofstream(untyped)
      << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
         "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n";
  const Status untyped_read = LoadCloudPositions(untyped, &xyz);
  ASSERT_FALSE(untyped_read.ok());
  EXPECT_NE(untyped_read.message().find(
                "untyped.pcd: not a readable point cloud (PCL could not parse it)"),
            std::string::npos)
      << untyped_read.message();

  Status s = LoadCloudPositions(ply("far.ply", "binary_little_endian", "double", 5000000.0), &xyz);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(
      s.message().find("far.ply: its coordinates reach 5000005 m from the origin, beyond 8000 m"),
      std::string::npos)
      << s.message();
  s = LoadCloudPositions(ply("int.ply", "binary_little_endian", "int", 0.0), &xyz);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(
                "int.ply: its x coordinates are of type int; sweepscan reads float or double"),
            std::string::npos)
      << s.message();
}

TEST(CloudHeaderTest, ForgedOrOversizedCountsAreRefusedWithoutAllocating) {
  std::vector<Eigen::Vector3f> xyz;
  for (const char* count : {"-5", "18446744073709551615", "1e9", "4000000000"}) {
    const std::string path = TempPath("forged.ply");
    WriteText(path, PlyHeaderFor(count) + std::string(120, '\0'));
    const Status s = LoadCloudPositions(path, &xyz);
    EXPECT_FALSE(s.ok()) << count;
    EXPECT_NE(s.message().find("forged.ply: not a readable point cloud"), std::string::npos)
        << s.message();
  }
  const std::string pcd = TempPath("forged.pcd");
  WriteText(pcd,
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2000000000\n"
            "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2000000000\nDATA binary\n" +
                std::string(24, '\0'));
  const Status s = LoadCloudPositions(pcd, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("POINTS 2000000000"), std::string::npos) << s.message();
}

// Counts that no data can hold are refused before PCL loops or allocates:
// rows of no bytes (a PLY element without properties: 300 M vertices took
// 4.7 GB, 10^12 junk rows ran for days) and an ASCII PCD whose points have
// more values than the file has characters (PCL allocated 2.5 GB for 296
// bytes).
TEST(CloudHeaderTest, RowsOfNoBytesAndAsciiValuesBeyondTheFileAreRefused) {
  std::vector<Eigen::Vector3f> xyz;
  const std::string empty_rows = TempPath("empty_rows.ply");
  WriteText(empty_rows,
            "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
            "property float y\nproperty float z\nelement junk 999999999999\nend_header\n" +
                std::string(24, '\0'));
  Status s = LoadCloudPositions(empty_rows, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("element junk declares 999999999999 rows but no properties"),
            std::string::npos)
      << s.message();
  const std::string no_properties = TempPath("no_properties.ply");
  WriteText(no_properties, "ply\nformat binary_little_endian 1.0\nelement vertex 300000000\nend_header\n");
  s = LoadCloudPositions(no_properties, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("element vertex declares 300000000 rows but no properties"),
            std::string::npos)
      << s.message();
  const std::string wide = TempPath("wide.pcd");
  WriteText(wide,
            "VERSION 0.7\nFIELDS a b c d e\nSIZE 4 4 4 4 4\nTYPE F F F F F\n"
            "COUNT 1048576 1048576 1048576 1048576 1048576\nWIDTH 60\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 60\nDATA ascii\n" +
                std::string(60, '1'));
  s = LoadCloudPositions(wide, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("POINTS 60 of 5242880 values"), std::string::npos) << s.message();
}

TEST(CloudHeaderTest, TrailingJunkAndShortDataAreRefused) {
  std::vector<Eigen::Vector3f> xyz;
  const std::string junk = TempPath("junk.ply");
  WriteText(junk, PlyHeaderFor("10") + std::string(120, '\0') + std::string(1200000, 'j'));
  Status s = LoadCloudPositions(junk, &xyz);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("trailing junk"), std::string::npos) << s.message();
  const std::string exact = TempPath("exact.ply");
  WriteText(exact, PlyHeaderFor("10") + std::string(120, '\0'));
  s = LoadCloudPositions(exact, &xyz);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(xyz.size(), 10u);
  const std::string cut = TempPath("cut.ply");
  WriteText(cut, PlyHeaderFor("10") + std::string(100, '\0'));
  EXPECT_FALSE(LoadCloudPositions(cut, &xyz).ok());
}

// Header lines PCL sizes the cloud by, which the checks had not read: a
// PLY's obj_info num_cols / num_rows (a 250-byte file cost 4.8 GB), a
// second vertex element, a range grid far beyond the vertices; a PCD's
// repeated or prefixed keyword (PCL resizes at every POINTS line and takes
// "POINTSx" as POINTS) and a compressed block's uncompressed size (PCL
// allocates it twice, zeroed, before decompressing).
TEST(CloudHeaderTest, WhatPclSizesTheCloudByMustAgreeWithTheData) {
  std::vector<Eigen::Vector3f> xyz;
  const std::string body(12, '\0');  // one vertex of three floats
  const auto ply_with = [&](const std::string& name, const std::string& extra) {
    const std::string path = TempPath(name);
    WriteText(path, "ply\nformat binary_little_endian 1.0\n" + extra +
                        "element vertex 1\nproperty float x\nproperty float y\n"
                        "property float z\nend_header\n" + body);
    return path;
  };
  const auto refused = [&](const std::string& path, const std::string& why) {
    const Status s = LoadCloudPositions(path, &xyz);
    EXPECT_FALSE(s.ok()) << path;
    EXPECT_NE(s.message().find(why), std::string::npos) << s.message();
  };
  // One of them before the vertex element is overridden by it, as in PCL;
  // both are kept (PCL's writer puts an organised cloud's there).
  ASSERT_TRUE(LoadCloudPositions(ply_with("info_first.ply", "obj_info num_cols 20000\n"), &xyz).ok());
  EXPECT_EQ(xyz.size(), 1u);
  ASSERT_TRUE(LoadCloudPositions(
                  ply_with("pcl_info.ply", "obj_info num_cols 1\nobj_info num_rows 1\n"), &xyz)
                  .ok());
  refused(ply_with("both_first.ply", "obj_info num_cols 20000\nobj_info num_rows 20000\n"),
          "obj_info num_cols x num_rows (20000 x 20000) differs from the 1 vertices");
  std::string path = TempPath("obj_info.ply");
  WriteText(path, PlyHeaderFor("1").substr(0, PlyHeaderFor("1").size() - 11) +
                      "obj_info num_cols 20000\nobj_info num_rows 20000\nend_header\n" + body);
  refused(path, "obj_info num_cols x num_rows (20000 x 20000) differs from the 1 vertices");
  path = TempPath("two_vertex.ply");
  WriteText(path, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                  "property float y\nproperty float z\nelement vertex 1\nproperty uchar a\n"
                  "end_header\n" + body + std::string(1, '\0'));
  refused(path, "two 'vertex' elements");
  // A range grid costs PCL a vertex row a cell: wide rows (1 003 values)
  // on a grid of one-byte cells.
  std::string wide = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                     "property float y\nproperty float z\n";
  for (int i = 0; i < 1000; ++i) wide += "property double d" + std::to_string(i) + "\n";
  path = TempPath("grid.ply");
  WriteText(path, wide + "element range_grid 1000\nproperty list uchar int vertex_indices\n"
                         "end_header\n" + std::string(8012 + 1000, '\0'));
  refused(path, "a range grid of 1000 cells of 8012 bytes for 9012 bytes of data");
  WriteText(path, wide + "element range_grid 60\nproperty list uchar int vertex_indices\n"
                         "end_header\n" + std::string(8012 + 60, '\0'));
  EXPECT_TRUE(ValidateCloudFile(path).ok());  // 60 cells: within 64 times the data
  path = TempPath("vertex_list.ply");
  WriteText(path, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                  "property float y\nproperty float z\nproperty list uint float h\nend_header\n" +
                      body + std::string(4, '\0'));
  refused(path, "a list property in the vertex element");

  const std::string fields =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\n";
  path = TempPath("twice.pcd");
  WriteText(path, fields + "POINTS 300000000\nPOINTS 1\nDATA binary\n" + body);
  refused(path, "two POINTS lines");
  path = TempPath("prefixed.pcd");
  WriteText(path, fields + "POINTSx 300000000\nPOINTS 1\nDATA binary\n" + body);
  refused(path, "unknown header line 'POINTSx 300000000'");
  path = TempPath("compressed.pcd");
  const uint32_t claim[2] = {4, 0x7FFFFFFFu};
  std::string block(reinterpret_cast<const char*>(claim), 8);
  WriteText(path, fields + "POINTS 1\nDATA binary_compressed\n" + block + "abcd");
  refused(path, "POINTS 1 of 12 bytes but the data decompress to 2147483647");
  const uint32_t beyond[2] = {400, 12};
  WriteText(path, fields + "POINTS 1\nDATA binary_compressed\n" +
                      std::string(reinterpret_cast<const char*>(beyond), 8) + "abcd");
  refused(path, "compressed data of 400 bytes but 12 bytes follow the header");
}

// PCL's own writer's organised cloud passes the checks and reads back its
// valid points.
TEST(CloudHeaderTest, PclsOrganisedPlyIsRead) {
  pcl::PointCloud<pcl::PointXYZ> organised(4, 3);
  for (size_t i = 0; i < organised.size(); ++i) {
    const float v = i % 3 == 0 ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(i);
    organised[i] = pcl::PointXYZ(v, 2 * v, 3 * v);
  }
  organised.is_dense = false;
  // With its camera element (viewport 4 x 3, every cell a vertex) or
  // without (obj_info 4 x 3 before the 8 valid vertices, a 12-cell grid).
  for (const int variant : {0, 1, 2, 3}) {
    const bool binary = variant % 2 == 0, camera = variant < 2;
    const std::string path = TempPath("organised" + std::to_string(variant) + ".ply");
    pcl::PLYWriter writer;
    ASSERT_EQ(writer.write(path, organised, binary, camera), 0);
    std::vector<Eigen::Vector3f> xyz;
    const Status s = LoadCloudPositions(path, &xyz);
    ASSERT_TRUE(s.ok()) << s.message();
    ASSERT_EQ(xyz.size(), 8u);  // 12 cells, 4 of them NaN
    EXPECT_EQ(xyz[0], Eigen::Vector3f(1, 2, 3));
    EXPECT_EQ(xyz[7], Eigen::Vector3f(11, 22, 33));
  }
}

// The evaluation's own reader checks a header's count against the bytes
// that follow it before it allocates (it had trusted the validator, whose
// reading of an inner '\r' differed: a 3.3 GB buffer for a 12-byte file).
TEST(CloudHeaderTest, TheDirectReaderChecksCountsAgainstTheBytes) {
  const std::string path = TempPath("wide_direct.pcd");
  WriteText(path,
            "VERSION 0.7\nFIELDS x y z w\nSIZE 4 4 4 8\nTYPE F F F F\nCOUNT 1 1 1 100000\n"
            "WIDTH 4096\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4096\nDATA binary\n" +
                std::string(12, '\0'));
  std::vector<Eigen::Vector3f> xyz;
  std::string error;
  EXPECT_EQ(ReadCloudPositions(path, &xyz, &error), CloudReadResult::kError);
  EXPECT_NE(error.find("truncated (4096 points of 800012 bytes declared, 12 bytes follow the header)"),
            std::string::npos)
      << error;
  // "POI\rNTS" is no POINTS line to it, as to PCL and the validator.
  const std::string hidden = TempPath("hidden.pcd");
  WriteText(hidden,
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
            "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nPOI\rNTS 4096\nDATA binary\n" +
                std::string(12, '\0'));
  ASSERT_EQ(ReadCloudPositions(hidden, &xyz, &error), CloudReadResult::kOk) << error;
  EXPECT_EQ(xyz.size(), 1u);
}

TEST(CloudHeaderTest, AFolderIsAClearError) {
  const std::string dir = TempPath("folder.ply");
  std::remove(dir.c_str());
  ASSERT_EQ(std::system(("mkdir -p " + dir).c_str()), 0);
  std::vector<Eigen::Vector3f> xyz;
  const Status s = LoadCloudPositions(dir, &xyz);
  EXPECT_NE(s.message().find("is a folder"), std::string::npos) << s.message();
  const Status w = SaveCloud(dir, RandomCloud(3));
  EXPECT_NE(w.message().find("is a folder"), std::string::npos) << w.message();
}

}  // namespace
}  // namespace sweepscan
