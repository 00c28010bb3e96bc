// Reads the positions of a cloud file straight into the array the
// evaluation uses (12 bytes a point, no pcl::PointCloud in between):
// binary little-endian PLY with a fixed-size vertex element first, and
// binary PCD. Non-finite points are dropped, as LoadCloudPositions
// (core/cloud/cloud_io.h) does. Other encodings (ASCII, compressed PCD)
// return kUnsupported: read those with LoadCloudPositions.
#ifndef SWEEPSCAN_CORE_EVALUATION_CLOUD_ARRAYS_H_
#define SWEEPSCAN_CORE_EVALUATION_CLOUD_ARRAYS_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace sweepscan {

enum class CloudReadResult { kOk, kUnsupported, kError };

// On kError, *error says where and why.
CloudReadResult ReadCloudPositions(const std::string& path, std::vector<Eigen::Vector3f>* points,
                                   std::string* error);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_EVALUATION_CLOUD_ARRAYS_H_
