// Runs the real sweepscan-render on a small cloud. Needs a display (the test
// script runs CTest under xvfb-run); skipped without one.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>

#include "core/cloud/cloud_io.h"

namespace {

int RunRender(const std::string& args) {
  const int status = std::system((std::string(SWEEPSCAN_RENDER) + " " + args + " > /dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(RenderTest, WritesPngOfRequestedSize) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no X display (run under xvfb-run)";
  std::vector<sweepscan::CloudPoint> pts;
  for (int i = 0; i < 100; ++i) {
    for (int k = 0; k < 100; ++k) {
      sweepscan::CloudPoint p;
      p.x = 0.05f * i;
      p.y = 0.05f * k;
      p.z = 0.01f * i;
      pts.push_back(p);
    }
  }
  const std::string cloud = ::testing::TempDir() + "/sweepscan_render.ply";
  const std::string png = ::testing::TempDir() + "/sweepscan_render.png";
  ASSERT_TRUE(sweepscan::SaveCloud(cloud, pts).ok());
  ASSERT_EQ(RunRender(cloud + " " + png + " --size 320x200 --title test"), 0);
  std::ifstream in(png, std::ios::binary);
  unsigned char header[24] = {};
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  ASSERT_TRUE(in.good());
  EXPECT_EQ(header[1], 'P');
  EXPECT_EQ(header[2], 'N');
  EXPECT_EQ(header[3], 'G');
  // IHDR: width and height, big-endian, at bytes 16..23.
  EXPECT_EQ((header[18] << 8) | header[19], 320);
  EXPECT_EQ((header[22] << 8) | header[23], 200);
  // A crop that keeps part of the cloud, from the +y side.
  EXPECT_EQ(RunRender(cloud + " " + png + " --view back --crop 0,0,-1,2.5,5,1"), 0);
}

TEST(RenderTest, BadInputExitsTwo) {
  EXPECT_EQ(RunRender("/nonexistent.ply out.png"), 2);
  EXPECT_EQ(RunRender("only-one-argument.ply"), 2);
  EXPECT_EQ(RunRender("a.ply b.png --view sideways"), 2);
  // Crops: malformed, inverted, or keeping nothing.
  std::vector<sweepscan::CloudPoint> pts(10);
  for (int i = 0; i < 10; ++i) pts[i].x = 0.1f * i;
  const std::string cloud = ::testing::TempDir() + "/sweepscan_render_crop.ply";
  ASSERT_TRUE(sweepscan::SaveCloud(cloud, pts).ok());
  const std::string png = ::testing::TempDir() + "/sweepscan_render_crop.png";
  EXPECT_EQ(RunRender(cloud + " " + png + " --crop 1,2,3"), 2);
  EXPECT_EQ(RunRender(cloud + " " + png + " --crop 1,0,0,0,1,1"), 2);
  EXPECT_EQ(RunRender(cloud + " " + png + " --crop 5,5,5,6,6,6"), 2);
}

}  // namespace
