// All PCL templates of core's cloud I/O live in this one translation unit.
#include "core/cloud/cloud_io.h"

#include <pcl/console/print.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

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

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
                    [](char a, char b) { return std::tolower(a) == b; });
}

// PCL's PLY reader warns on stderr about the "camera" element its own writer
// adds; errors are reported through our Status instead.
void QuietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

bool FileReadable(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return static_cast<bool>(f);
}

}  // namespace

Status SaveCloud(const std::string& path, const std::vector<CloudPoint>& points) {
  const bool ply = EndsWith(path, ".ply");
  if (!ply && !EndsWith(path, ".pcd")) {
    return Status::Error(path + ": unknown cloud format (use .ply or .pcd)");
  }
  pcl::PointCloud<PclSweepPoint> cloud;
  cloud.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const CloudPoint& p = points[i];
    PclSweepPoint& q = cloud[i];
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.range = p.range_m;
    q.time = static_cast<double>(p.time_ns) * 1e-9;
    q.scan = p.scan;
    q.beam = p.beam;
    q.source = p.pose_source;
    q.flags = p.flags;
  }
  cloud.width = static_cast<std::uint32_t>(points.size());
  cloud.height = 1;
  cloud.is_dense = true;
  // PCL's writers pick the format from our call, not the file name, so the
  // temporary file keeps the real extension's writer.
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  int rc;
  if (ply) {
    rc = pcl::io::savePLYFileBinary(tmp, cloud);
  } else {
    rc = pcl::io::savePCDFileBinary(tmp, cloud);
  }
  if (rc != 0) {
    std::remove(tmp.c_str());
    return Status::Error(path + ": cannot write cloud");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return Status::Error(path + ": cannot replace file");
  }
  return Status::Ok();
}

// Reads a PLY or PCD file (by extension) into a PCL cloud of PointT.
template <typename PointT>
Status ReadPcl(const std::string& path, pcl::PointCloud<PointT>* cloud) {
  if (!FileReadable(path)) return Status::Error(path + ": cannot open for reading");
  QuietPcl();
  int rc = -1;
  if (EndsWith(path, ".ply")) {
    rc = pcl::io::loadPLYFile(path, *cloud);
  } else if (EndsWith(path, ".pcd")) {
    rc = pcl::io::loadPCDFile(path, *cloud);
  } else {
    return Status::Error(path + ": unknown cloud format (use .ply or .pcd)");
  }
  if (rc != 0) return Status::Error(path + ": not a readable point cloud (PCL could not parse it)");
  return Status::Ok();
}

Status LoadCloudPositions(const std::string& path, std::vector<Eigen::Vector3f>* points) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  const Status s = ReadPcl(path, &cloud);
  if (!s.ok()) return s;
  points->clear();
  points->reserve(cloud.size());
  for (const auto& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) points->emplace_back(p.x, p.y, p.z);
  }
  return Status::Ok();
}

Status LoadCloud(const std::string& path, std::vector<CloudPoint>* points) {
  pcl::PointCloud<PclSweepPoint> cloud;
  const Status s = ReadPcl(path, &cloud);
  if (!s.ok()) return s;
  points->resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const PclSweepPoint& q = cloud[i];
    CloudPoint& p = (*points)[i];
    p.x = q.x;
    p.y = q.y;
    p.z = q.z;
    p.range_m = q.range;
    p.time_ns = static_cast<int64_t>(std::llround(q.time * 1e9));
    p.scan = q.scan;
    p.beam = q.beam;
    p.pose_source = q.source;
    p.flags = q.flags;
  }
  return Status::Ok();
}

std::vector<Eigen::Vector3f> VoxelDownsample(const std::vector<Eigen::Vector3f>& points, double leaf_m) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr in(new pcl::PointCloud<pcl::PointXYZ>);
  in->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) (*in)[i] = pcl::PointXYZ(points[i].x(), points[i].y(), points[i].z());
  pcl::PointCloud<pcl::PointXYZ> out;
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(in);
  const float leaf = static_cast<float>(leaf_m);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.filter(out);
  std::vector<Eigen::Vector3f> result;
  result.reserve(out.size());
  for (const auto& p : out) result.emplace_back(p.x, p.y, p.z);
  return result;
}

}  // namespace sweepscan
