// A ROS bag of a 2D lidar on a moving robot -> a sweepscan session that
// everything downstream opens like a native one (reconstruct, calibrate,
// evaluate, sfm, the app): the session holds decoded measurements
// (meta.json "content": "measurements", core/session/measurements.h) with
// the bag as provenance, and the lidar's mount from tf as the robot's
// nominal Laser -> Body transform (robot_model.h). docs/ros-bags.md gives
// every rule; in short:
//
//  * LaserScan sample i is at t_i = header.stamp + i * time_increment (the
//    message's own definition: the stamp is the first beam's time). When a
//    driver leaves time_increment at 0, the beams are spread over the turn:
//    time_increment = scan_time * angle_increment / (2 pi) (a spinning
//    lidar sweeps 2 pi in scan_time); with scan_time 0 too, every beam is at
//    the stamp (no per-sample deskew; said in the report). Its angle is
//    angle_min + i * angle_increment in the scan frame S (x_S at angle 0,
//    y_S at +pi/2); the sweepscan lidar frame L of Eq. 1 is L = Ry(-pi/2) S
//    (x_S -> z_L, y_S -> y_L), so theta_i = angle_i and the nominal mount is
//    N = R(base_from_scan) * Ry(pi/2). NaN and inf (no return, REP 117)
//    and returns outside [range_min, range_max] are dropped and counted.
//  * nav_msgs/Odometry gives the twist (linear.x, angular.z, in the child
//    frame) the EKF takes in place of the wheel encoders. When every twist
//    is zero while the pose moves (drivers that fill only the pose), the
//    twist is differentiated from consecutive poses.
//  * sensor_msgs/Imu gives attitude (unless orientation_covariance[0] = -1)
//    and yaw rate (unless angular_velocity_covariance[0] = -1), turned into
//    the base frame by tf's base_from_imu when tf has it.
//  * Times are shifted by a whole number of seconds (time_origin_ns, kept in
//    meta.json) so that robot time starts near 1 s, as a native session's.
//
// Memory: the bag is streamed (two passes: tf and the first message of each
// topic, then the sensor topics) and written as it is read; memory does not
// grow with the bag.
//
// Pure function; any thread (the app imports on a job thread).
#ifndef SWEEPSCAN_CORE_IO_ROS_IMPORT_H_
#define SWEEPSCAN_CORE_IO_ROS_IMPORT_H_

#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/geometry/transform.h"
#include "core/io/ros/ros_messages.h"

namespace sweepscan::io {

struct RosImportOptions {
  // Topics; empty = the one topic of that type in the bag (an error when
  // there are several, naming them). "none" = do not use odometry / IMU.
  std::string scan_topic, odom_topic, imu_topic;
  // The robot's body frame; empty = the odometry's child_frame_id, else
  // base_footprint, else base_link (the first that tf knows).
  std::string base_frame;
  // Overrides tf: base_from_scan as x, y, z (m), roll, pitch, yaw (rad).
  bool has_mount = false;
  Rigid3d base_from_scan;
  // Overrides tf for the IMU: base_from_imu (mounts often live in a launch
  // file's static_transform_publisher, not in the bag).
  bool has_imu_mount = false;
  Rigid3d base_from_imu;
  // Half the wheel track (m), used only to store twists as wheel speeds
  // (core/session/measurements.h); the EKF's yaw-rate noise is per wheel,
  // so it sets how much the odometry's turn rate is trusted. sweepscan's
  // robot's 0.15 m by default.
  double wheel_distance_m = 0.15;
  std::string notes;
  // 0..1 over both passes; return false to cancel (the import then fails
  // with "cancelled" and leaves no session behind).
  std::function<bool(double)> progress;
};

struct RosImportReport {
  std::string bag, format, session;
  std::string scan_topic, odom_topic, imu_topic;  // "" when not used
  std::string base_frame, scan_frame;
  std::string mount_source;  // "tf: base_link -> laser (static)" or "--mount"
  std::string imu_mount_source;  // "tf: ...", "--imu-mount" or "none: the IMU's axes are the robot's"
  Rigid3d base_from_scan;
  std::string time_rule;  // how per-sample times were made
  int64_t time_origin_ns = 0;
  uint64_t scans = 0, samples = 0;
  uint64_t no_returns = 0;          // NaN or +-inf (REP 117: no return, too near, too far)
  uint64_t out_of_range = 0;        // finite but outside [range_min, range_max] (dropped)
  uint64_t scans_refused = 0;       // ranges' length disagrees with the angles, bad angles
  std::string first_scan_refusal;   // where and why
  // Scans whose intensities were dropped: neither none nor one per range.
  uint64_t intensities_dropped = 0;
  uint64_t odometry = 0, imu = 0;
  bool twist_from_poses = false;    // odometry twists differentiated from poses
  // The first odometry pose (x, y, yaw in the odometry's frame): where the
  // session's world places the robot at the start (SessionStartPose), so
  // its clouds are in the bag's odometry frame.
  bool has_start = false;
  double start_x_m = 0.0, start_y_m = 0.0, start_yaw_rad = 0.0;
  uint64_t imu_without_attitude = 0, imu_without_gyro = 0;
  uint64_t out_of_order = 0;        // messages stamped before their predecessor (sorted)
  uint64_t time_gaps = 0;           // forward jumps > 1 s within a topic
  uint64_t undecodable = 0;         // messages whose bytes did not decode
  uint64_t scans_too_large = 0;     // scans whose session record would pass its 1 MiB cap
  // Topics whose header stamps are on another clock than the others' (a
  // driver stamping from boot, or 0): their times are their log times plus
  // the other topics' stamp - log time offset (docs/ros-bags.md, "Clocks").
  // Topic -> that offset, ns.
  std::map<std::string, int64_t> stamps_from_log_time;
  std::vector<std::string> warnings;

  nlohmann::json ToJson() const;
};

// Why an import failed: the CLI's exit code (1 for kOutput, 2 for kBag).
enum class RosImportFailure {
  kNone,
  kBag,        // the bag cannot be read, or holds nothing to import
  kOutput,     // the session cannot be created or written (a folder in the way, a full disk)
  kCancelled,  // options.progress returned false
};

// Imports `bag` into a new session folder `session_dir` (which must not
// exist or be empty). On failure nothing is left at session_dir, and
// *failure (if given) says whose fault it was.
Status ImportRosBag(const std::string& bag, const std::string& session_dir,
                    const RosImportOptions& options, RosImportReport* report,
                    RosImportFailure* failure = nullptr);

// Picks the topic of `kind`: `requested` if given (it must exist, be of
// that type and in an encoding read here), else the only one with messages
// that can be decoded (RosBagSummary::Decodable); *topic stays empty when
// there is none and the kind is optional. Topics of the kind passed over
// for their encoding are said in `warnings` (optional). Exposed for `info`
// and the app's topic chooser.
Status ChooseTopic(const RosBagSummary& summary, RosMessageKind kind, const std::string& requested,
                   bool required, std::string* topic, std::vector<std::string>* warnings = nullptr);

}  // namespace sweepscan::io

#endif  // SWEEPSCAN_CORE_IO_ROS_IMPORT_H_
