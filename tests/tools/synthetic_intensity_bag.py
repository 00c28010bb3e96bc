#!/usr/bin/python3
"""A large ROS 1 bag whose LaserScans carry intensities, for measuring what the
desktop app does with them (docs/performance.md, "An imported bag's
intensities"): SCANS scans of 500 beams at 10 Hz (intensity (beam + scan) mod
200, ranges 2-4 m), odometry at 20 Hz driving straight at 0.05 m/s, no tf
(give the mount to the import). Written by ROS's own Python writer.

  tests/tools/synthetic_intensity_bag.py OUT.bag SCANS
  sweepscan-cli import OUT.bag --out OUT.sweepscan --mount 0,0,0.3,1.5707963,0,0
"""
import math
import sys

import rosbag
import rospy
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

BEAMS = 500


def main():
    out, n_scans = sys.argv[1], int(sys.argv[2])
    t0 = 1700000000.0
    with rosbag.Bag(out, 'w') as bag:
        for k in range(n_scans):
            t = t0 + k * 0.1
            s = LaserScan()
            s.header.stamp = rospy.Time.from_sec(t)
            s.header.frame_id = 'laser'
            s.angle_min = -math.pi
            s.angle_increment = 2 * math.pi / BEAMS
            s.angle_max = s.angle_min + (BEAMS - 1) * s.angle_increment
            s.time_increment = 0.1 / BEAMS
            s.scan_time = 0.1
            s.range_min, s.range_max = 0.1, 12.0
            s.ranges = [3.0 + math.sin(i * 0.05 + k * 0.01) for i in range(BEAMS)]
            s.intensities = [float((i + k) % 200) for i in range(BEAMS)]
            bag.write('/scan', s, s.header.stamp)
            for j in range(2):
                o = Odometry()
                ts = t + j * 0.05
                o.header.stamp = rospy.Time.from_sec(ts)
                o.header.frame_id, o.child_frame_id = 'odom', 'base_link'
                o.pose.pose.position.x = 0.05 * (ts - t0)
                o.pose.pose.orientation.w = 1.0
                o.twist.twist.linear.x = 0.05
                bag.write('/odom', o, o.header.stamp)


if __name__ == '__main__':
    main()
