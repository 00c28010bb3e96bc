// Cloud files through PCL's io module (never its visualization module).
//
// PLY (binary little-endian) and PCD (binary) carry every attribute of
// CloudPoint: x y z (float, m), range (float, m), time (double, s of robot
// time), scan (uint32), beam (uint16), source (uint8: 0 EKF, 1 odometry,
// 2 truth), flags (uint8: bit 0 placed without deskew). See docs/cloud-format.md.
#ifndef SWEEPSCAN_CORE_CLOUD_CLOUD_IO_H_
#define SWEEPSCAN_CORE_CLOUD_CLOUD_IO_H_

#include <Eigen/Core>
#include <atomic>
#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/common/checked_file.h"
#include "core/common/status.h"

namespace sweepscan {

// Chooses the format from the extension (.ply or .pcd). Written through the
// checked writer (core/common/checked_file.h): every write checked, fsync,
// rename only when complete; a failure names the file and the OS error.
Status SaveCloud(const std::string& path, const std::vector<CloudPoint>& points);
// SaveCloud for a cloud that arrives in pieces (a streamed reconstruction):
// the header is written first with room for any count and completed by
// Finish(), so the file is SaveCloud's byte for byte after its header, and
// the header differs only by a padding comment line (docs/cloud-format.md,
// "Streamed files"). Memory: one 128 KiB buffer. Like SaveCloud, the file
// exists under its name only when Finish() succeeded.
class CloudFileWriter {
 public:
  Status Open(const std::string& path);  // .ply or .pcd
  Status Append(const CloudPoint* points, size_t n);
  Status Finish();
  uint64_t points() const { return points_; }

 private:
  CheckedFileWriter out_;
  bool ply_ = true;
  uint64_t points_ = 0;
  std::string chunk_;
};

// A cloud snapshot through CloudFileWriter, a chunk decoded at a time (the
// cloud is never held whole: 32 bytes a point); stops (no file) when
// `cancel` becomes true, with the message "cancelled".
Status SaveCloud(const std::string& path, const CloudSnapshotRef& cloud,
                 const std::atomic<bool>* cancel = nullptr);

// Checks that PATH is a regular file whose PLY / PCD header is sane and
// declares exactly as many bytes as follow it (binary) or no more rows than
// the bytes could hold (ASCII), before anything is allocated.
Status ValidateCloudFile(const std::string& path);
// Reads the positions of any PLY or PCD with x, y, z fields (validated
// first), float or double (converted to float); non-finite points are left
// out. Refused: another type of x, y or z (named), a missing one, and a
// double cloud reaching beyond 8 000 m of the origin (float would round its
// positions to half a metre at a map grid's 5 000 km).
Status LoadCloudPositions(const std::string& path, std::vector<Eigen::Vector3f>* points);
// Reads a cloud written by SaveCloud, with all attributes (another PLY or
// PCD: its positions as LoadCloudPositions reads them, every point kept,
// and the attributes it has of the same name and type).
Status LoadCloud(const std::string& path, std::vector<CloudPoint>* points);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_CLOUD_IO_H_
