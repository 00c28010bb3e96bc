#!/usr/bin/python3
"""The evaluation of `sweepscan-cli evaluate CLOUD` done with Open3D, side by side.

The same cloud, the same parameters (EvaluationOptions' defaults):
  outlier removal  k = 20 neighbours, 2 standard deviations
                   (remove_statistical_outlier; Open3D counts the point itself
                   among its 20, PCL and sweepscan do not: a few points differ)
  planes           RANSAC, 3 cm band, 3-point samples, 500 iterations, the
                   largest first, its inliers removed, until 10 planes or one
                   holds fewer than 1 % of the points (segment_plane in a
                   loop; Open3D samples the whole remaining cloud, sweepscan
                   a 50 000-point subsample, then both take every inlier)
  density          mean nearest-neighbour distance, Miao Eq. 18-19
                   (compute_nearest_neighbor_distance)

Usage (Debian 12: apt install python3-open3d; run with Debian's python3):
    /usr/bin/python3 tests/bench/open3d_evaluate.py CLOUD.ply [--json]

Prints the stage times, the planes, the density and the peak resident
memory of this process; docs/performance.md ("Evaluation") has the figures
beside sweepscan's.
"""
import json
import resource
import sys
import time

import numpy as np
import open3d as o3d


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 1:
        print(__doc__)
        return 2
    as_json = "--json" in sys.argv
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    times = {}
    t0 = time.perf_counter()
    cloud = o3d.io.read_point_cloud(args[0])
    times["read_s"] = time.perf_counter() - t0
    n_in = len(cloud.points)

    t = time.perf_counter()
    clean, _ = cloud.remove_statistical_outlier(nb_neighbors=20, std_ratio=2.0)
    times["outliers_s"] = time.perf_counter() - t
    del cloud
    n_clean = len(clean.points)

    t = time.perf_counter()
    planes = []
    remaining = clean
    min_count = max(3, int(0.01 * n_clean))
    while len(planes) < 10 and len(remaining.points) >= min_count:
        model, inliers = remaining.segment_plane(distance_threshold=0.03, ransac_n=3,
                                                 num_iterations=500)
        if len(inliers) < min_count:
            break
        pts = np.asarray(remaining.points)[inliers]
        centroid = pts.mean(axis=0)
        # Least-squares refit on the inliers, as sweepscan reports it.
        _, s, vt = np.linalg.svd(pts - centroid, full_matrices=False)
        normal = vt[2]
        if abs(normal[2]) > 0.9 and normal[2] < 0:
            normal = -normal
        planes.append({"normal": normal.tolist(), "d": float(-normal @ centroid),
                       "points": len(inliers), "rms_m": float(s[2] / np.sqrt(len(inliers)))})
        remaining = remaining.select_by_index(inliers, invert=True)
    times["planes_s"] = time.perf_counter() - t

    t = time.perf_counter()
    nn = np.asarray(clean.compute_nearest_neighbor_distance())
    density = float(nn.mean())
    times["density_s"] = time.perf_counter() - t
    times["total_s"] = time.perf_counter() - t0
    times["evaluation_s"] = times["total_s"] - times["read_s"]
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

    report = {"open3d": o3d.__version__, "points": n_in, "points_after_outlier_removal": n_clean,
              "planes": planes, "mean_nn_distance_m": density, "timing": times,
              "peak_rss_mib": peak_mib}
    if as_json:
        print(json.dumps(report, indent=2))
        return 0
    print("open3d %s: %d points, %d after outlier removal, mean nearest-neighbour distance %.2f mm"
          % (o3d.__version__, n_in, n_clean, 1e3 * density))
    for i, p in enumerate(planes):
        n = p["normal"]
        print("  plane %d n (%+.4f %+.4f %+.4f) d %+.3f m, %d points, RMS %.1f mm"
              % (i, n[0], n[1], n[2], p["d"], p["points"], 1e3 * p["rms_m"]))
    print("timing: read %.3f s, outliers %.3f s, planes %.3f s, density %.3f s, "
          "evaluation %.3f s; peak RSS %.0f MiB"
          % (times["read_s"], times["outliers_s"], times["planes_s"], times["density_s"],
             times["evaluation_s"], peak_mib))
    return 0


if __name__ == "__main__":
    sys.exit(main())
