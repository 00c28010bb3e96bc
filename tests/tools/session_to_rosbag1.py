#!/usr/bin/env python3
"""Writes a ROS 1 bag of a sweepscan drive with ROS's own Python writer
(Debian's python3-rosbag, no roscore), as a robot running ROS would record it:

  /scan        sensor_msgs/LaserScan, one per lidar revolution
  /odom        nav_msgs/Odometry (twist from the wheel speeds, pose integrated)
  /imu/data    sensor_msgs/Imu (orientation from roll, pitch, yaw; yaw rate)
  /tf          odom -> base_footprint, with every odometry message
  /tf_static   base_footprint -> laser (the lidar's mount), base_footprint -> imu_link

Input: the CSV files of `sweepscan-cli export SESSION --out DIR` and the
session's meta.json (robot geometry). The bag is the independent side of the
import tests: nothing of sweepscan's C++ writes it.

A LaserScan needs evenly spaced beams, the X4 does not give them (its angle
correction depends on each range), so each sample goes into the bin of its
angle on a grid of --bins per turn, as a ROS lidar driver does. The stamp is
the time of bin 0 and time_increment the turn's period / bins, so that a
fine grid (the default 7200 bins, 0.05 deg) keeps every sample within
0.025 deg and a few microseconds of where and when the native session has it.

usage: session_to_rosbag1.py CSV_DIR META_JSON OUT.bag [--bins N]
       [--compression none|bz2|lz4] [--epoch S] [--drop-imu-orientation]
       [--intensity] [--scan-frame laser]
"""
import argparse
import csv
import json
import math
from collections import defaultdict

import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, LaserScan
from tf2_msgs.msg import TFMessage


def stamp(epoch, t):
    """epoch + t seconds as a rospy.Time, rounded to the nanosecond."""
    ns = int(round((epoch + t) * 1e9))
    return rospy.Time(ns // 1000000000, ns % 1000000000)


def quat_rpy(roll, pitch, yaw):
    """Rz(yaw) Ry(pitch) Rx(roll) as x, y, z, w."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def transform(t, parent, child, xyz, q):
    m = TransformStamped()
    m.header.stamp = t
    m.header.frame_id = parent
    m.child_frame_id = child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = xyz
    (m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z,
     m.transform.rotation.w) = q
    return m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv_dir")
    ap.add_argument("meta")
    ap.add_argument("out")
    ap.add_argument("--bins", type=int, default=7200)
    ap.add_argument("--compression", default="none", choices=["none", "bz2", "lz4"])
    ap.add_argument("--epoch", type=float, default=1700000000.0)
    ap.add_argument("--drop-imu-orientation", action="store_true")
    ap.add_argument("--intensity", action="store_true",
                    help="intensity = 100 * range (the X4 has none; to test that they pass)")
    ap.add_argument("--scan-frame", default="laser")
    ap.add_argument("--repeat", type=int, default=1,
                    help="write the drive N times, each shifted by its length (for throughput "
                         "benchmarks: scripts/ros-import-bench.sh)")
    a = ap.parse_args()

    meta = json.load(open(a.meta))
    robot = meta["robot"]
    # A simulated session starts at its scenario's start pose: the odometry
    # frame is the scenario's world, as a robot's odom frame is its map's
    # when it starts at a known place.
    start = meta.get("settings", {}).get("scenario", {}).get("path", {}).get("start", {})
    h, l1, d = robot["lidar_height_m"], robot["lidar_offset_x_m"], robot["wheel_distance_m"]

    scans = defaultdict(list)
    with open(f"{a.csv_dir}/lidar.csv") as f:
        for row in csv.DictReader(f):
            r = float(row["range_m"])
            scans[int(row["scan"])].append(
                (float(row["robot_time_s"]), r, float(row["theta_rad"])))
    with open(f"{a.csv_dir}/imu.csv") as f:
        imu = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    with open(f"{a.csv_dir}/wheels.csv") as f:
        wheels = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]

    comp = {"none": rosbag.Compression.NONE, "bz2": rosbag.Compression.BZ2,
            "lz4": rosbag.Compression.LZ4}[a.compression]
    first_t = min([s[0][0] for s in scans.values() if s] + [w["robot_time_s"] for w in wheels])
    t0 = stamp(a.epoch, first_t)
    inc = 2 * math.pi / a.bins
    # Messages are collected and written in time order, as `rosbag record`
    # writes them (a bag written topic by topic makes every reader
    # decompress a chunk per message: rosbag keeps one chunk decompressed).
    out = []

    class Collect:
        def write(self, topic, msg, t):
            out.append((t, len(out), topic, msg))

    with rosbag.Bag(a.out, "w", compression=comp) as real_bag:
        bag = Collect()
        # The sweepscan mount as a ROS scan frame: L = Ry(-90 deg) S (docs/ros-bags.md).
        s45 = math.sqrt(0.5)
        static = TFMessage([transform(t0, "base_footprint", a.scan_frame, (l1, 0.0, h), (0.0, -s45, 0.0, s45)),
                            transform(t0, "base_footprint", "imu_link", (robot["imu_offset_x_m"], 0.0, 0.1),
                                      (0.0, 0.0, 0.0, 1.0))])
        bag.write("/tf_static", static, t0)

        x, y, yaw = start.get("x_m", 0.0), start.get("y_m", 0.0), start.get("yaw_rad", 0.0)
        last_t = None
        for w in wheels:
            t = w["robot_time_s"]
            v = 0.5 * (w["left_mps"] + w["right_mps"])
            om = (w["right_mps"] - w["left_mps"]) / (2 * d)
            if last_t is not None:
                dt = t - last_t
                x += v * dt * math.cos(yaw + 0.5 * om * dt)
                y += v * dt * math.sin(yaw + 0.5 * om * dt)
                yaw += om * dt
            last_t = t
            m = Odometry()
            m.header.stamp = stamp(a.epoch, t)
            m.header.frame_id = "odom"
            m.child_frame_id = "base_footprint"
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            q = quat_rpy(0, 0, yaw)
            (m.pose.pose.orientation.x, m.pose.pose.orientation.y, m.pose.pose.orientation.z,
             m.pose.pose.orientation.w) = q
            m.twist.twist.linear.x = v
            m.twist.twist.angular.z = om
            m.pose.covariance[0] = m.pose.covariance[7] = 1e-4
            m.twist.covariance[0] = m.twist.covariance[35] = 1e-4
            bag.write("/odom", m, m.header.stamp)
            bag.write("/tf", TFMessage([transform(m.header.stamp, "odom", "base_footprint", (x, y, 0.0), q)]),
                      m.header.stamp)

        for r in imu:
            m = Imu()
            m.header.stamp = stamp(a.epoch, r["robot_time_s"])
            m.header.frame_id = "imu_link"
            if a.drop_imu_orientation:
                m.orientation_covariance[0] = -1.0
            else:
                (m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w) = quat_rpy(
                    r["roll_rad"], r["pitch_rad"], r["yaw_rad"])
                m.orientation_covariance[0] = m.orientation_covariance[4] = m.orientation_covariance[8] = 3e-5
            m.angular_velocity.z = r["gyro_z_rad_s"]
            m.angular_velocity_covariance[8] = 1e-6
            m.linear_acceleration_covariance[0] = -1.0
            bag.write("/imu/data", m, m.header.stamp)

        for index in sorted(scans):
            samples = [s for s in scans[index] if s[1] > 0.0]  # range 0: no return
            if len(samples) < 2:
                continue
            # The turn's angular rate from the first and last sample (theta
            # grows with time over a revolution), hence each bin's time.
            unwrapped, turns, prev = [], 0.0, None
            for (t, _, th) in samples:
                if prev is not None and th + turns < prev - math.pi:
                    turns += 2 * math.pi
                unwrapped.append(th + turns)
                prev = th + turns
            ta, tha = samples[0][0], unwrapped[0]
            tb, thb = samples[-1][0], unwrapped[-1]
            rate = (thb - tha) / (tb - ta)
            period = 2 * math.pi / rate
            # The grid runs in time order from the first sample's bin on,
            # past 2 pi if the turn started before angle 0 (LaserScan angles
            # are plain numbers; a driver whose turn starts at 352 deg has
            # angle_min 352 deg).
            angle_min = round(tha / inc) * inc
            n_bins = int(round((thb - angle_min) / inc)) + 1
            ranges = [float("nan")] * n_bins
            intensities = [0.0] * n_bins if a.intensity else []
            for (t, r, _), th in zip(samples, unwrapped):
                b = int(round((th - angle_min) / inc))
                if 0 <= b < n_bins and math.isnan(ranges[b]):
                    ranges[b] = r
                    if a.intensity:
                        intensities[b] = 100.0 * r
            m = LaserScan()
            m.header.stamp = stamp(a.epoch, ta + (angle_min - tha) / rate)
            m.header.frame_id = a.scan_frame
            m.angle_min = angle_min
            m.angle_max = angle_min + (n_bins - 1) * inc
            m.angle_increment = inc
            m.time_increment = period / a.bins
            m.scan_time = period
            m.range_min = 0.12
            m.range_max = 10.0
            m.ranges = ranges
            m.intensities = intensities
            bag.write("/scan", m, stamp(a.epoch, tb))
        out.sort(key=lambda e: (e[0], e[1]))
        span = (out[-1][0] - out[0][0]).to_sec() + 0.1
        for k in range(a.repeat):
            shift = rospy.Duration.from_sec(k * span)
            for t, _, topic, msg in out:
                if k > 0:
                    if topic == "/tf_static":
                        continue
                    # Stamps inside the message move with the log time.
                    for stamped in (msg.transforms if topic == "/tf" else [msg]):
                        stamped.header.stamp = (stamped.header.stamp + rospy.Duration.from_sec(span))
                real_bag.write(topic, msg, t + shift)


if __name__ == "__main__":
    main()
