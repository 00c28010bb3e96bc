#!/usr/bin/env python3
"""Copies a ROS 1 bag with one topic's header stamps on another clock, as a
driver that stamps from its own clock leaves them: the log times (the
recorder's clock) stay, only msg.header.stamp changes. Written with ROS's
own Python writer (python3-rosbag), never sweepscan's code.

usage: restamp_bag.py IN OUT TOPIC MODE
  MODE boot:S  stamps counted from a boot S seconds before the topic's first
               message (its first stamp becomes S, the rest keep their spacing)
  MODE zero    every stamp 0 (a driver that leaves header.stamp unset)
"""
import sys

import rosbag
import rospy


def main():
    src, dst, topic, mode = sys.argv[1:5]
    first = None
    with rosbag.Bag(src) as bag_in, rosbag.Bag(dst, "w") as bag_out:
        for name, msg, t in bag_in.read_messages():
            if name == topic:
                stamp = msg.header.stamp
                if mode == "zero":
                    msg.header.stamp = rospy.Time(0, 0)
                elif mode.startswith("boot:"):
                    if first is None:
                        first = stamp
                    boot = rospy.Duration(float(mode[5:]))
                    msg.header.stamp = rospy.Time(0, 0) + boot + (stamp - first)
                else:
                    sys.exit("unknown mode " + mode)
            bag_out.write(name, msg, t)


if __name__ == "__main__":
    main()
