#!/usr/bin/python3
"""Compares the poses sweepscan made of an imported bag with the bag's own
GPS fixes (docs/results.md, "A real robot's bag").

  sweepscan-cli import BAG --out S.sweepscan
  sweepscan-cli export S.sweepscan --format rosbag --out track.bag   (the EKF's poses)
  sweepscan-cli export S.sweepscan --format rosbag --out odo.bag --no-ekf
  scripts/ros-track-vs-gps.py BAG track.bag [odo.bag ...] [--fix /fix]

Reads the fixes (sensor_msgs/NavSatFix, status >= 0) and each track's
nav_msgs/Path with ROS's own Python reader (Debian's python3-rosbag; run
with /usr/bin/python3), puts the fixes in a local east-north plane at the
first fix (WGS84, exact to millimetres over kilometres), and fits each track
to them by the best 2D rotation and translation (the track's odom frame has
no known heading), and again with a scale (which takes out the wheels'
scale error and leaves the heading's): then prints, per track and fit, the
RMS and largest horizontal distance to the fixes at the fixes' times and
the end point's distance, and both path lengths.
"""
import argparse
import math

import numpy as np
import rosbag

A, F = 6378137.0, 1 / 298.257223563  # WGS84
E2 = F * (2 - F)


def ecef(lat, lon, h):
    lat, lon = math.radians(lat), math.radians(lon)
    n = A / math.sqrt(1 - E2 * math.sin(lat) ** 2)
    return np.array([(n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
                     (n * (1 - E2) + h) * math.sin(lat)])


def enu(fixes):
    lat0, lon0, h0 = fixes[0][1:]
    o = ecef(lat0, lon0, h0)
    la, lo = math.radians(lat0), math.radians(lon0)
    r = np.array([[-math.sin(lo), math.cos(lo), 0],
                  [-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo), math.cos(la)]])
    return np.array([f[0] for f in fixes]), np.array([r @ (ecef(*f[1:]) - o) for f in fixes])


def read_track(path):
    for _, m, _ in rosbag.Bag(path).read_messages(topics=["/sweepscan/path"]):
        t = np.array([p.header.stamp.to_sec() for p in m.poses])
        xy = np.array([[p.pose.position.x, p.pose.position.y] for p in m.poses])
        return t, xy
    raise SystemExit(path + ": no /sweepscan/path")


def fit(a, b, scale=False):
    """s R, t minimising sum |s R a + t - b|^2 (2D; s = 1 unless `scale`,
    Umeyama 1991)."""
    ca, cb = a.mean(0), b.mean(0)
    u, sv, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1, d]) @ u.T
    s = (sv[0] + d * sv[1]) / np.sum((a - ca) ** 2) if scale else 1.0
    return s * r, cb - s * r @ ca, s


def length(xy):
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bag")
    ap.add_argument("tracks", nargs="+")
    ap.add_argument("--fix", default="/fix")
    a = ap.parse_args()
    fixes = [(m.header.stamp.to_sec(), m.latitude, m.longitude, m.altitude)
             for _, m, _ in rosbag.Bag(a.bag).read_messages(topics=[a.fix]) if m.status.status >= 0]
    tf, gps = enu(fixes)
    print(f"{len(fixes)} fixes over {tf[-1] - tf[0]:.1f} s, GPS path {length(gps):.1f} m")
    for path in a.tracks:
        t, xy = read_track(path)
        keep = (tf >= t[0]) & (tf <= t[-1])
        at = np.column_stack([np.interp(tf[keep], t, xy[:, 0]), np.interp(tf[keep], t, xy[:, 1])])
        print(f"{path}: {keep.sum()} fixes matched, track length {length(xy):.1f} m")
        for scale in (False, True):
            r, c, s = fit(at, gps[keep], scale)
            d = np.linalg.norm(at @ r.T + c - gps[keep], axis=1)
            what = f"rotation, translation and scale ({s:.4f})" if scale else "rotation and translation"
            print(f"  fitted by {what}: distance to the fixes RMS {math.sqrt(np.mean(d ** 2)):.2f} m, "
                  f"max {d.max():.2f} m, at the end {d[-1]:.2f} m")


if __name__ == "__main__":
    main()
