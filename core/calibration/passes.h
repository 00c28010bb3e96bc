// Pass separation for the calibration drive (Miao et al. 2022, section 4).
//
// On the circle drive the vertical scan plane contains (up to the lidar's
// offset l1) the line from the robot to the circle's centre, so it sweeps
// around the centre once per turn and meets every object twice: once from
// the near side (robot between the centre and the object, object on the
// robot's right for a counter-clockwise drive) and once from the far side
// (seen through the centre). The two sightings are separated by about half a
// turn in time, 13 s at 0.2 m/s on a 0.83 m circle, while the samples of one
// sighting follow each other every 0.2 ms; a gap in time therefore separates
// them cleanly, and the circle's geometry names them.
//
// Headless, no state: callable from any thread.
#ifndef SWEEPSCAN_CORE_CALIBRATION_PASSES_H_
#define SWEEPSCAN_CORE_CALIBRATION_PASSES_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "core/cloud/cloud.h"
#include "core/common/time.h"
#include "core/pose/pose_buffer.h"

namespace sweepscan {

// One sighting: the closed interval of robot time [begin_ns, end_ns] that
// holds its samples.
struct PassWindow {
  int64_t begin_ns = 0;
  int64_t end_ns = 0;
  size_t count = 0;  // samples or points that formed it

  bool Contains(int64_t t_ns) const { return t_ns >= begin_ns && t_ns <= end_ns; }
  double duration_s() const { return 1e-9 * static_cast<double>(end_ns - begin_ns); }
};

// Splits time stamps (any order) into windows wherever two consecutive
// stamps are more than `gap_s` apart. Windows with fewer than `min_count`
// stamps (a stray return) are dropped. Windows come out in time order.
std::vector<PassWindow> SplitByTimeGaps(std::vector<int64_t> times_ns, double gap_s,
                                        size_t min_count = 1);

// The cloud's points inside `region` (world frame), split by time gaps:
// result[k] holds the indices into `points` of sighting k, in time order.
std::vector<std::vector<size_t>> SplitRegionIntoPasses(const std::vector<CloudPoint>& points,
                                                       const Eigen::AlignedBox3d& region,
                                                       double gap_s = 1.0, size_t min_count = 20);

// The windows of the same split (for picking samples by time).
std::vector<PassWindow> FindPassWindows(const std::vector<CloudPoint>& points,
                                        const Eigen::AlignedBox3d& region, double gap_s = 1.0,
                                        size_t min_count = 20);

// Index of the window that holds t_ns, or -1.
int PassOfTime(const std::vector<PassWindow>& windows, int64_t t_ns);

enum class CirclePass { kNear = 0, kFar = 1 };

// The circle drive's geometry. With the robot at polar angle phi about the
// centre and the object at bearing psi, the scan plane meets the object when
// phi ~ psi (near side) and when phi ~ psi + pi (far side, through the
// centre); a robot position is assigned to the nearer of the two.
struct CircleDrive {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius_m = 0.83;

  CirclePass PassOf(const Eigen::Vector2d& robot_xy, const Eigen::Vector2d& object_xy) const;
  // As PassOf with the robot's position at time t from `poses`; false if the
  // buffer does not cover t.
  bool PassAtTime(const PoseBuffer& poses, Time t, const Eigen::Vector2d& object_xy,
                  CirclePass* pass) const;
};

// The circle of a calibration drive from the robot's positions: the
// algebraic least-squares circle (Kasa: x^2 + y^2 + D x + E y + F = 0,
// linear in D, E, F; centre (-D/2, -E/2), r^2 = (D^2 + E^2)/4 - F). Refused,
// with why, unless the positions go at least `min_turns` round the centre
// and stay within 15 % of the radius of the circle (a straight or wandering
// drive has no passes).
bool FitCircleDrive(const PoseBuffer& poses, CircleDrive* circle, std::string* why,
                    double min_turns = 0.9);

// How far the heading of `poses` departs from that of `reference` over the
// same drive: the largest |(psi(t) - psi(t0)) - (psi_ref(t) - psi_ref(t0))|,
// radians, at `poses`' times that `reference` covers (t0 the first), both
// headings unwrapped. Odometry against the EKF (which fuses the IMU's yaw):
// unequal wheel radii or slip turn the odometry's heading steadily away, and
// the automatic calibration would absorb that turn into the angles. -1 if
// the two share no time.
double MaxHeadingDeparture(const PoseBuffer& poses, const PoseBuffer& reference);

// The pass of every point of a circle drive (CircleDrive::PassOf with the
// robot's position at the point's own time): 0 near side (pass A), 1 far
// side (pass B), kNoPass where the poses do not cover the point's time.
// Points of one object get one label per sighting; the two passes of the
// target are the two labels.
constexpr uint8_t kNoPass = 255;
std::vector<uint8_t> LabelCirclePasses(const std::vector<CloudPoint>& points,
                                       const PoseBuffer& poses, const CircleDrive& circle);
// The same for points[0, n) into labels[0, n), a chunk at a time: `hint`
// (start at 0) carries the pose lookup across chunks in time order.
void LabelCirclePasses(const CloudPoint* points, size_t n, const PoseBuffer& poses,
                       const CircleDrive& circle, size_t* hint, uint8_t* labels);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_PASSES_H_
