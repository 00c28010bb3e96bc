#include "core/cloud/cloud_io.h"

#include <gtest/gtest.h>

#include <cstdio>
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

TEST(CloudIoTest, VoxelDownsampleKeepsOnePointPerVoxel) {
  std::vector<Eigen::Vector3f> pts;
  // Two dense clusters 1 m apart, each inside one 0.5 m voxel.
  for (int i = 0; i < 1000; ++i) {
    pts.emplace_back(0.1f + 0.0001f * i, 0.1f, 0.1f);
    pts.emplace_back(1.1f + 0.0001f * i, 0.1f, 0.1f);
  }
  const auto out = VoxelDownsample(pts, 0.5);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(std::min(out[0].x(), out[1].x()), 0.1f + 0.0001f * 499.5f, 1e-4);
}

}  // namespace
}  // namespace sweepscan
