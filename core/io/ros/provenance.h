// The provenance of an imported recording: a SHA-256 of the bag's bytes, so
// a session says exactly which bag it came from (docs/ros-bags.md).
#ifndef SWEEPSCAN_CORE_IO_ROS_PROVENANCE_H_
#define SWEEPSCAN_CORE_IO_ROS_PROVENANCE_H_

#include <atomic>
#include <string>

#include "core/common/status.h"

namespace sweepscan::io {

// Lowercase hex SHA-256 of a file, or of a folder's regular files (a ROS 2
// bag: metadata.yaml and its storage files) concatenated in name order.
// `stop`, when set, ends it early with "stopped" (an import that failed or
// was cancelled does not wait for the hash of a large bag).
Status HashBag(const std::string& path, std::string* sha256_hex,
               const std::atomic<bool>* stop = nullptr);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS_PROVENANCE_H_
