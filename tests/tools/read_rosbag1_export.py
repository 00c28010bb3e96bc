#!/usr/bin/env python3
"""Reads what `sweepscan-cli export --format rosbag` wrote with ROS's own
Python reader (python3-rosbag, sensor_msgs.point_cloud2) and prints a JSON
summary for tests/app/cli_ros_test.cc: the topics and types, the cloud's
fields, point count, first and last point, intensity sum, and the path's
pose count, frame and first and last position.

usage: read_rosbag1_export.py BAG
"""
import json
import sys

import rosbag
from sensor_msgs import point_cloud2

out = {}
bag = rosbag.Bag(sys.argv[1])
out["types"] = {t: i.msg_type for t, i in bag.get_type_and_topic_info().topics.items()}
for topic, m, _ in bag.read_messages():
    if topic == "/sweepscan/cloud":
        pts = list(point_cloud2.read_points(m, field_names=("x", "y", "z", "intensity", "time")))
        out["cloud"] = {"frame": m.header.frame_id, "fields": [f.name for f in m.fields], "points": len(pts),
                        "first": list(pts[0]), "last": list(pts[-1]),
                        "intensity_sum": sum(p[3] for p in pts)}
    elif topic == "/sweepscan/path":
        out["path"] = {"frame": m.header.frame_id, "poses": len(m.poses),
                       "first": [m.poses[0].pose.position.x, m.poses[0].pose.position.y],
                       "last": [m.poses[-1].pose.position.x, m.poses[-1].pose.position.y]}
print(json.dumps(out))
