#!/usr/bin/env python3
"""Writes a ROS 1 bag (python3-rosbag, ROS's own writer) whose middle scan
has more returns than a sweepscan session record holds (60 000 finite
ranges: 18 bytes each, over the writer's 1 MiB record cap) between two
ordinary scans of 360 beams, and base_link -> laser on /tf_static.

usage: big_scan_bag.py OUT.bag
"""
import sys

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

T0 = 1700000200


def scan(s, n):
    m = LaserScan()
    m.header.stamp, m.header.frame_id = rospy.Time(T0 + s), "laser"
    m.angle_increment = 6.283 / n
    m.angle_min = -3.1415
    m.angle_max = m.angle_min + (n - 1) * m.angle_increment
    m.time_increment, m.scan_time = 0.1 / n, 0.1
    m.range_min, m.range_max = 0.1, 30.0
    m.ranges = [2.0 + 0.001 * (i % 100) for i in range(n)]
    return m


def main():
    with rosbag.Bag(sys.argv[1], "w") as b:
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = rospy.Time(T0), "base_link", "laser"
        t.transform.translation.z = 0.4
        t.transform.rotation.w = 1.0
        b.write("/tf_static", TFMessage([t]), rospy.Time(T0))
        for k, n in enumerate((360, 60000, 360)):
            b.write("/scan", scan(1 + k, n), rospy.Time(T0 + 1 + k, 1000000))


if __name__ == "__main__":
    main()
