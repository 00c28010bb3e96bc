#!/usr/bin/env python3
"""Small ROS 1 bags with hand-known content, written by ROS's own Python
writer (Debian's python3-rosbag), for tests/core/io/ros/import_test.cc.
Every value here is what the C++ test expects back; keep the two in step.

usage: make_test_rosbags.py OUT_DIR
writes OUT_DIR/{rules,clock_jump,no_sensor,no_tf_path,pose_only_odom,two_scans}.bag
"""
import math
import os
import sys

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, LaserScan
from tf2_msgs.msg import TFMessage

T0 = 1700000100  # s; robot time = stamp - (T0 - 1) s = 1 s at T0


def t(s):
    ns = int(round((T0 + s) * 1e9))
    return rospy.Time(ns // 1000000000, ns % 1000000000)


def tf(stamp, parent, child, xyz, q):
    m = TransformStamped()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, parent, child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = xyz
    r = m.transform.rotation
    r.x, r.y, r.z, r.w = q
    return m


def quat_axis(axis, angle):
    s = math.sin(angle / 2)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2))


def scan(stamp, frame, angle_min, inc, n, ranges, ti=0.0, scan_time=0.0, intensities=()):
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.angle_min, m.angle_increment = angle_min, inc
    m.angle_max = angle_min + (n - 1) * inc
    m.time_increment, m.scan_time = ti, scan_time
    m.range_min, m.range_max = 0.1, 10.0
    m.ranges = list(ranges)
    m.intensities = list(intensities)
    return m


def odom(stamp, x, y, yaw, v, w):
    m = Odometry()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, "odom", "base_footprint"
    m.pose.pose.position.x, m.pose.pose.position.y = x, y
    q = quat_axis((0, 0, 1), yaw)
    o = m.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    m.twist.twist.linear.x, m.twist.twist.angular.z = v, w
    return m


def imu(stamp, frame, q, gyro, no_orientation=False):
    m = Imu()
    m.header.stamp, m.header.frame_id = stamp, frame
    if no_orientation:
        m.orientation_covariance[0] = -1.0
    else:
        m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w = q
    m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = gyro
    return m


def static_tf(bag, stamp):
    # base_footprint -> mast (0.1, 0, 0.3), mast -> laser (0, 0.05, 0.2) turned
    # -90 deg about y (sweepscan's vertical mount), imu_link turned +90 deg
    # about z from base_footprint.
    bag.write("/tf_static", TFMessage([
        tf(stamp, "base_footprint", "mast", (0.1, 0.0, 0.3), (0, 0, 0, 1)),
        tf(stamp, "mast", "laser", (0.0, 0.05, 0.2), quat_axis((0, 1, 0), -math.pi / 2)),
        tf(stamp, "base_footprint", "imu_link", (0.05, 0.0, 0.1), quat_axis((0, 0, 1), math.pi / 2)),
    ]), stamp)


def rules(path):
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))
        # Scan 0: 8 beams, time_increment 1 ms, every kind of return.
        b.write("/scan", scan(t(0.0), "laser", -0.4, 0.1, 8,
                              [1.0, float("nan"), float("inf"), -float("inf"), 0.05, 12.0, 2.5, 3.0],
                              ti=0.001, scan_time=0.1,
                              intensities=[10, 11, 12, 13, 14, 15, 16, 17]), t(0.01))
        # Scan 1: time_increment 0, scan_time 0.2 s: beams spread over the turn.
        b.write("/scan", scan(t(0.2), "laser", 0.0, math.pi / 2, 4, [1.0, 2.0, 3.0, 4.0],
                              ti=0.0, scan_time=0.2), t(0.21))
        # Scan 2: 10 ranges but the angles make 20: refused.
        b.write("/scan", scan(t(0.4), "laser", 0.0, 0.01, 20, [1.0] * 10, ti=0.001), t(0.41))
        # Scan 3: negative time_increment: beam 2 first in time.
        b.write("/scan", scan(t(0.6), "laser", 0.0, 0.1, 3, [1.0, 2.0, 3.0], ti=-0.001), t(0.61))
        # Scan 4: stamped before scan 3 (out of order by 0.1 s, not a clock jump);
        # one intensity for two ranges: dropped, counted.
        b.write("/scan", scan(t(0.5), "laser", 0.0, 0.1, 2, [5.0, 6.0], ti=0.001, intensities=[7.0]),
                t(0.62))
        b.write("/odom", odom(t(0.0), 1.0, 2.0, 0.5, 0.25, 0.1), t(0.0))
        b.write("/odom", odom(t(0.1), 1.02, 2.01, 0.51, 0.3, -0.2), t(0.1))
        b.write("/imu", imu(t(0.05), "imu_link", quat_axis((0, 0, 1), 1.0), (0.2, 0.0, 0.3)), t(0.05))
        b.write("/imu", imu(t(0.15), "imu_link", None, (0.0, 0.0, 0.4), no_orientation=True), t(0.15))


def clock_jump(path):
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))
        for i, s in enumerate([0.0, 0.1, 0.2, -5.0]):
            b.write("/scan", scan(t(s), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=0.001), t(0.1 * i))


def no_sensor(path):
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))


def no_tf_path(path):
    with rosbag.Bag(path, "w") as b:
        b.write("/tf_static", TFMessage([tf(t(0.0), "base_footprint", "camera", (0, 0, 1), (0, 0, 0, 1))]), t(0.0))
        b.write("/scan", scan(t(0.0), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=0.001), t(0.0))


def pose_only_odom(path):
    """A driver that fills the pose and leaves the twist at zero: 0.5 m/s
    along a heading of 0.3 rad while turning at 0.2 rad/s, 10 Hz."""
    with rosbag.Bag(path, "w") as b:
        x = y = 0.0
        yaw = 0.3
        for k in range(11):
            b.write("/odom", odom(t(0.1 * k), x, y, yaw, 0.0, 0.0), t(0.1 * k))
            mid = yaw + 0.5 * 0.02
            x += 0.05 * math.cos(mid)
            y += 0.05 * math.sin(mid)
            yaw += 0.02


def two_scans(path):
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))
        for topic in ("/scan_front", "/scan_rear"):
            b.write(topic, scan(t(0.0), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=0.001), t(0.0))


def bad_times(path):
    """Beams that cannot be timed: NaN, a 20 s span, an infinite scan_time, a
    4 s span (more than a session's scan record holds)."""
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))
        b.write("/scan", scan(t(0.0), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=0.001), t(0.0))
        b.write("/scan", scan(t(0.1), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=float("nan")), t(0.1))
        b.write("/scan", scan(t(0.2), "laser", 0.0, 0.1, 20, [1.0] * 20, ti=1.0), t(0.2))
        b.write("/scan", scan(t(0.3), "laser", 0.0, 0.1, 2, [1.0, 2.0], ti=0.0,
                              scan_time=float("inf")), t(0.3))
        b.write("/scan", scan(t(0.4), "laser", 0.0, 0.01, 40, [1.0] * 40, ti=0.1), t(0.4))


def long_span(path):
    """Only scans whose beams span 4 s: each refused by the import's rule."""
    with rosbag.Bag(path, "w") as b:
        static_tf(b, t(0.0))
        for k in range(3):
            b.write("/scan", scan(t(5.0 * k), "laser", 0.0, 0.01, 40, [1.0] * 40, ti=0.1), t(5.0 * k))


if __name__ == "__main__":
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    for f in (rules, clock_jump, no_sensor, no_tf_path, pose_only_odom, two_scans, bad_times, long_span):
        f(os.path.join(out, f.__name__ + ".bag"))
