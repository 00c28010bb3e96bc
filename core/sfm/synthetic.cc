#include "core/sfm/synthetic.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace sweepscan::sfm {
namespace {

Eigen::Vector3d RandomUnit(std::mt19937_64* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(g(*rng), g(*rng), g(*rng));
  } while (v.norm() < 1e-6);
  return v.normalized();
}

// A random line on the plane: two points of the box [-h, h]^3 projected onto
// it, at least 0.5 m apart.
void LineOnPlane(const WorldPlane& plane, double h, std::mt19937_64* rng, Eigen::Vector3d* p0,
                 Eigen::Vector3d* p1) {
  std::uniform_real_distribution<double> u(-h, h);
  do {
    Eigen::Vector3d a(u(*rng), u(*rng), u(*rng)), b(u(*rng), u(*rng), u(*rng));
    *p0 = a - plane.SignedDistance(a) * plane.normal;
    *p1 = b - plane.SignedDistance(b) * plane.normal;
  } while ((*p1 - *p0).norm() < 0.5);
}

}  // namespace

SyntheticProblem MakeSyntheticProblem(const SyntheticOptions& o, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  SyntheticProblem sp;
  // Pose: axis uniform on the sphere, angle uniform in [0, max].
  const double angle = std::abs(unit(*rng)) * o.max_rotation_deg * M_PI / 180.0;
  sp.R_true = Eigen::AngleAxisd(angle, RandomUnit(rng)).toRotationMatrix();
  sp.t_true = o.max_translation_m * Eigen::Vector3d(unit(*rng), unit(*rng), unit(*rng));
  const int total = 3 + o.extra_correspondences;
  std::vector<WorldPlane> planes;
  const double min_sin = std::sin(o.min_plane_angle_deg * M_PI / 180.0);
  while (static_cast<int>(planes.size()) < total) {
    WorldPlane p;
    p.normal = RandomUnit(rng);
    p.d = o.max_plane_distance_m * unit(*rng);
    // Orient the normal to the back side: the sensor stands in front (Eq. 37).
    if (p.SignedDistance(sp.t_true) > 0) {
      p.normal = -p.normal;
      p.d = -p.d;
    }
    if (std::abs(p.SignedDistance(sp.t_true)) < 0.2) continue;
    bool ok = true;
    for (const WorldPlane& q : planes) ok = ok && p.normal.cross(q.normal).norm() > min_sin;
    if (planes.size() == 2) {
      ok = ok && std::abs(planes[0].normal.dot(planes[1].normal.cross(p.normal))) > min_sin * min_sin;
    }
    if (ok) planes.push_back(p);
  }
  std::uniform_real_distribution<double> noise(-0.5 * o.noise_width_m, 0.5 * o.noise_width_m);
  const Eigen::Matrix3d Rt = sp.R_true.transpose();
  for (int i = 0; i < total; ++i) {
    Eigen::Vector3d w0, w1;
    RigLine line;
    for (;;) {
      LineOnPlane(planes[i], o.point_box_m, rng, &w0, &w1);
      const Eigen::Vector3d dir = (Rt * (w1 - w0)).normalized();
      bool ok = true;  // keep the lines of the minimal problem clearly non-parallel
      for (int j = 0; j < std::min(i, 3); ++j) ok = ok && dir.cross(sp.lines[j].direction).norm() > 0.05;
      if (ok) break;
    }
    for (int k = 0; k < o.points_per_line; ++k) {
      const double s = o.points_per_line == 1 ? 0.0 : static_cast<double>(k) / (o.points_per_line - 1);
      Eigen::Vector3d p = Rt * ((1 - s) * w0 + s * w1 - sp.t_true);
      p += Eigen::Vector3d(noise(*rng), noise(*rng), noise(*rng));
      line.points.push_back(p);
    }
    line.direction = (line.points.back() - line.points.front()).normalized();
    line.point = line.points.front();
    if (i < 3) {
      sp.planes[i] = planes[i];
      sp.lines[i] = line;
    } else {
      sp.disambiguation.extra_lines.push_back(line);
      sp.disambiguation.extra_planes.push_back(planes[i]);
    }
  }
  return sp;
}

ProtocolRow RunProtocol(const SyntheticOptions& options, int trials, uint64_t seed) {
  std::mt19937_64 rng(seed);
  ProtocolRow row;
  row.noise_width_m = options.noise_width_m;
  row.trials = trials;
  std::vector<double> rc, tc, rr, tr;
  double candidates = 0;
  P3lOptions po;
  // With noise the three constraints still have exact solutions; the
  // residual bound only rejects spurious near-real roots.
  for (int k = 0; k < trials; ++k) {
    const SyntheticProblem sp = MakeSyntheticProblem(options, &rng);
    std::vector<PoseCandidate> cands;
    if (!SolveP3l(sp.planes, sp.lines, po, sp.disambiguation, &cands).ok() || cands.empty()) continue;
    ++row.solved;
    candidates += static_cast<double>(cands.size());
    double best = 1e300;
    size_t bi = 0;
    for (size_t i = 0; i < cands.size(); ++i) {
      const double e = RotationAngle(cands[i].R, sp.R_true) + (cands[i].t - sp.t_true).norm();
      if (e < best) {
        best = e;
        bi = i;
      }
    }
    if ((cands[bi].R - sp.R_true).cwiseAbs().maxCoeff() < 1e-6 &&
        (cands[bi].t - sp.t_true).cwiseAbs().maxCoeff() < 1e-6) {
      ++row.truth_found_1e6;
    }
    rc.push_back(RotationAngle(cands[bi].R, sp.R_true) * 180.0 / M_PI);
    tc.push_back((cands[bi].t - sp.t_true).norm());
    rr.push_back(RotationAngle(cands[0].R, sp.R_true) * 180.0 / M_PI);
    tr.push_back((cands[0].t - sp.t_true).norm());
  }
  auto stats = [](const std::vector<double>& v, double* mean, double* sd) {
    if (v.empty()) return;
    double m = 0;
    for (double x : v) m += x;
    m /= static_cast<double>(v.size());
    double s = 0;
    for (double x : v) s += (x - m) * (x - m);
    *mean = m;
    *sd = std::sqrt(s / static_cast<double>(v.size()));
  };
  stats(rc, &row.rot_mean_deg, &row.rot_std_deg);
  stats(tc, &row.trans_mean_m, &row.trans_std_m);
  stats(rr, &row.ranked_rot_mean_deg, &row.ranked_rot_std_deg);
  stats(tr, &row.ranked_trans_mean_m, &row.ranked_trans_std_m);
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  row.rot_median_deg = median(rc);
  row.trans_median_m = median(tc);
  row.mean_candidates = row.solved ? candidates / row.solved : 0.0;
  return row;
}

}  // namespace sweepscan::sfm
