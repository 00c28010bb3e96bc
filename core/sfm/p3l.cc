// The P3L minimal solver; docs/sfm.md derives every step. Equation numbers
// refer to Choi et al. 2017 (Sensors 17:242).
#include "core/sfm/p3l.h"

#include <Eigen/Geometry>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <string>

#include "core/sfm/polynomial.h"

namespace sweepscan::sfm {
namespace {

// An orthonormal basis (a, b) of the plane with normal n, a x b = n, turned
// by `phi` within the plane.
void PlaneBasis(const Eigen::Vector3d& n, double phi, Eigen::Vector3d* a, Eigen::Vector3d* b) {
  // Pick the coordinate axis least aligned with n.
  Eigen::Vector3d seed = Eigen::Vector3d::UnitX();
  if (std::abs(n.x()) > std::abs(n.y())) seed = Eigen::Vector3d::UnitY();
  if (std::abs(seed.dot(n)) > std::abs(n.z())) seed = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d a0 = (seed - seed.dot(n) * n).normalized();
  const Eigen::Vector3d b0 = n.cross(a0);
  *a = std::cos(phi) * a0 + std::sin(phi) * b0;
  *b = n.cross(*a);
}

// The rotation taking u1 -> v1 and u2 -> v2 exactly when u1 . u2 = v1 . v2
// (Eq. 4-8: R = R_iw R_is, one orthonormal frame built on each pair of line
// directions, R_is^T taking the rig's frame to it and R_iw out to the world).
Eigen::Matrix3d Triad(const Eigen::Vector3d& u1, const Eigen::Vector3d& u2, const Eigen::Vector3d& v1,
                      const Eigen::Vector3d& v2) {
  Eigen::Matrix3d E, F;
  E.col(0) = u1;
  E.col(1) = (u2 - u2.dot(u1) * u1).normalized();
  E.col(2) = E.col(0).cross(E.col(1));
  F.col(0) = v1;
  F.col(1) = (v2 - v2.dot(v1) * v1).normalized();
  F.col(2) = F.col(0).cross(F.col(1));
  return F * E.transpose();
}

// Newton steps on the three rotation constraints r_i = n_i^T R u_i (Eq. 9),
// R <- exp([delta]x) R with dr_i/ddelta = ((R u_i) x n_i)^T. Keeps the best
// rotation seen (with noise a near-real root may have no exact real
// solution nearby) and returns its max |r_i|.
double PolishRotation(const std::array<Eigen::Vector3d, 3>& n, const std::array<Eigen::Vector3d, 3>& u,
                      Eigen::Matrix3d* R) {
  Eigen::Matrix3d current = *R;
  double best = 1e300;
  for (int it = 0; it <= 10; ++it) {
    Eigen::Vector3d r;
    Eigen::Matrix3d J;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d w = current * u[i];
      r[i] = n[i].dot(w);
      J.row(i) = w.cross(n[i]).transpose();
    }
    const double worst = r.cwiseAbs().maxCoeff();
    if (worst < best) {
      best = worst;
      *R = current;
    }
    if (worst < 1e-15 || it == 10) break;
    const double det = J.determinant();
    if (!(std::abs(det) > 1e-12)) break;
    const Eigen::Vector3d delta = -J.inverse() * r;
    const double angle = delta.norm();
    if (!(angle < 0.5)) break;  // Not near a solution: leave it to the residual test.
    if (angle > 0) current = Eigen::AngleAxisd(angle, delta / angle).toRotationMatrix() * current;
  }
  return best;
}

// The degree-16 polynomial in x = c1/s1 (Eq. 13-35), for plane bases
// (a_j, b_j) and the angle constraints g_ij = u_i . u_j (Eq. 10-12).
Poly BuildPolynomial(const std::array<Eigen::Vector3d, 3>& a, const std::array<Eigen::Vector3d, 3>& b,
                     double g12, double g13, double g23) {
  // v1 = c1 a1 + s1 b1 with (c1, s1) = (x, 1) / k, k^2 = 1 + x^2. Then, for
  // j = 2, 3: k (v1 . a_j) = A_j = x (a1.a_j) + (b1.a_j), k (v1 . b_j) = B_j.
  Poly A[2], B[2], N[2], R[2];
  const Poly k2 = Poly::Linear(1.0, 0.0) + Poly::Linear(0.0, 1.0) * Poly::Linear(0.0, 1.0);
  const double g1[2] = {g12, g13};
  for (int j = 0; j < 2; ++j) {
    A[j] = Poly::Linear(b[0].dot(a[j + 1]), a[0].dot(a[j + 1]));
    B[j] = Poly::Linear(b[0].dot(b[j + 1]), a[0].dot(b[j + 1]));
    N[j] = A[j] * A[j] + B[j] * B[j];            // k^2 |proj of v1 on plane j|^2
    R[j] = N[j] - (g1[j] * g1[j]) * k2;          // k^2 r_j^2, r_j = sqrt(N_j - g_1j^2)
  }
  // v_j . v_k = (c_j, s_j) M (c_k, s_k)^T with M the 2x2 basis products.
  const double m00 = a[1].dot(a[2]), m01 = a[1].dot(b[2]), m10 = b[1].dot(a[2]), m11 = b[1].dot(b[2]);
  auto form = [&](const Poly& x2, const Poly& y2, const Poly& x3, const Poly& y3) {
    return x2 * (m00 * x3 + m01 * y3) + y2 * (m10 * x3 + m11 * y3);
  };
  // (c_j, s_j) N_j = G_j p_j + sigma_j r_j q_j, p_j = (A_j, B_j), q_j = (-B_j, A_j),
  // G_j = g_1j k (Eq. 14-20). Substituted into v2 . v3 = g23 (Eq. 12) times N2 N3:
  //   X + sigma2 k Y r2 + sigma3 k Z r3 + sigma2 sigma3 W r2 r3 = 0        (Eq. 21-25)
  const Poly minusB2 = -1.0 * B[0], minusB3 = -1.0 * B[1];
  const Poly X = (g12 * g13) * k2 * form(A[0], B[0], A[1], B[1]) - g23 * N[0] * N[1];
  const Poly Y = g13 * form(minusB2, A[0], A[1], B[1]);
  const Poly Z = g12 * form(A[0], B[0], minusB3, A[1]);
  const Poly W = form(minusB2, A[0], minusB3, A[1]);
  // Squaring twice removes the signs and the roots (Eq. 26-35):
  //   L = X^2 + W^2 R2 R3 - k^2 (Y^2 R2 + Z^2 R3) = 2 r2 r3 (k^2 Y Z - X W) = 2 r2 r3 K
  //   F = L^2 - 4 R2 R3 K^2 = 0,  degree 16 in x.
  const Poly L = X * X + W * W * R[0] * R[1] - k2 * (Y * Y * R[0] + Z * Z * R[1]);
  const Poly K = k2 * Y * Z - X * W;
  return L * L - 4.0 * (R[0] * R[1] * K * K);
}

}  // namespace

double RotationConditioning(const std::array<Eigen::Vector3d, 3>& n, const std::array<Eigen::Vector3d, 3>& u,
                            const Eigen::Matrix3d& R) {
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i) J.row(i) = (R * u[i]).cross(n[i]).transpose();
  // sigma_min(J) = sqrt(lambda_min(J^T J)).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(J.transpose() * J, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(es.eigenvalues()[0], 0.0));
}

double RotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = 0.5 * ((a.transpose() * b).trace() - 1.0);
  return std::acos(std::clamp(c, -1.0, 1.0));
}

Status ToRigLine(const LineObservation& obs, const Rig& rig, RigLine* out) {
  if (obs.lidar < 0 || obs.lidar >= static_cast<int>(rig.rig_from_lidar.size())) {
    return Status::Error("unknown lidar " + std::to_string(obs.lidar));
  }
  if (obs.points.size() < 2) return Status::Error("a line needs at least two points");
  const Rigid3d& T = rig.rig_from_lidar[obs.lidar];
  out->points.clear();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : obs.points) {
    if (!p.allFinite()) return Status::Error("a point is not finite");
    out->points.push_back(T * p);
    mean += out->points.back();
  }
  mean /= static_cast<double>(out->points.size());
  Eigen::Vector3d dir;
  if (out->points.size() == 2) {
    dir = out->points[1] - out->points[0];
  } else {
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& p : out->points) S += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S);
    dir = es.eigenvectors().col(2) * std::sqrt(std::max(es.eigenvalues()[2], 0.0));
  }
  if (!(dir.norm() > 1e-9)) return Status::Error("the line's points coincide");
  out->direction = dir.normalized();
  out->point = mean;
  return Status::Ok();
}

Status CheckMinimalProblem(std::array<WorldPlane, 3>* planes, const std::array<RigLine, 3>& lines,
                           const P3lOptions& options) {
  for (int i = 0; i < 3; ++i) {
    WorldPlane& p = (*planes)[i];
    const std::string name = "planes[" + std::to_string(i) + "]";
    if (!p.normal.allFinite() || !std::isfinite(p.d)) return Status::Error(name + ": not finite");
    const double len = p.normal.norm();
    if (!(len > 1e-9)) return Status::Error(name + ": the normal is zero");
    p.normal /= len;
    p.d /= len;
    const std::string lname = "lines[" + std::to_string(i) + "]";
    if (!lines[i].direction.allFinite() || !lines[i].point.allFinite()) {
      return Status::Error(lname + ": not finite");
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      if ((*planes)[i].normal.cross((*planes)[j].normal).norm() < options.parallel_tolerance) {
        return Status::Error("planes[" + std::to_string(i) + "] and planes[" + std::to_string(j) +
                             "] are parallel: degenerate, the pose is not determined");
      }
    }
  }
  const double det = (*planes)[0].normal.dot((*planes)[1].normal.cross((*planes)[2].normal));
  if (std::abs(det) < options.parallel_tolerance) {
    return Status::Error(
        "the three plane normals share a direction (the planes meet in parallel lines): degenerate, "
        "the translation along it is not determined");
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      if (lines[i].direction.cross(lines[j].direction).norm() < options.parallel_tolerance) {
        return Status::Error("lines[" + std::to_string(i) + "] and lines[" + std::to_string(j) +
                             "] are parallel (both on the intersection of their planes): degenerate");
      }
    }
  }
  return Status::Ok();
}

std::vector<Eigen::Matrix3d> SolveP3lRotations(const std::array<Eigen::Vector3d, 3>& n,
                                               const std::array<Eigen::Vector3d, 3>& u,
                                               double max_residual) {
  std::vector<Eigen::Matrix3d> out;
  const double g12 = u[0].dot(u[1]), g13 = u[0].dot(u[2]), g23 = u[1].dot(u[2]);
  std::array<Eigen::Vector3d, 3> a, b;
  for (int j = 1; j < 3; ++j) PlaneBasis(n[j], 0.0, &a[j], &b[j]);
  // Roots x = c1/s1 near infinity (v1 close to +-a1) are computed poorly,
  // and clustered roots (coplanar lines meeting perpendicular planes) more
  // so. A second pass with plane 1's basis turned by 90 deg (phi) maps them
  // near x = 0; it runs only when the first pass has a root with |x| > 25 (v1 within 2.3 deg of a1) or
  // a small leading coefficient. The candidates of both passes are merged.
  for (double phi : {0.0, 0.5 * M_PI}) {
    PlaneBasis(n[0], phi, &a[0], &b[0]);
    const Poly F = BuildPolynomial(a, b, g12, g13, g23);
    double big = 0.0;
    for (int i = 0; i <= F.deg; ++i) big = std::max(big, std::abs(F.c[i]));
    const std::vector<double> roots = RealRoots(F);
    double largest = 0.0;
    for (double x : roots) largest = std::max(largest, std::abs(x));
    for (double x : roots) {
      const double k = std::sqrt(1.0 + x * x);
      for (double sign : {1.0, -1.0}) {
        const Eigen::Vector3d v1 = sign * (x * a[0] + b[0]) / k;
        // Line 2's direction from the angle constraint with line 1 (Eq. 10):
        // A c2 + B s2 = g12, c2^2 + s2^2 = 1.
        const double A = v1.dot(a[1]), B = v1.dot(b[1]);
        const double N = A * A + B * B;
        if (!(N > 1e-12)) continue;
        double r2 = N - g12 * g12;
        if (r2 < -1e-6 * N) continue;
        const double r = std::sqrt(std::max(r2, 0.0));
        for (double sigma : {1.0, -1.0}) {
          const double c2 = (A * g12 - sigma * B * r) / N, s2 = (B * g12 + sigma * A * r) / N;
          const Eigen::Vector3d v2 = (c2 * a[1] + s2 * b[1]).normalized();
          Eigen::Matrix3d R = Triad(u[0], u[1], v1, v2);
          // Line 3's constraint (Eq. 11-12) picks the real solutions; Newton
          // polishes the rotation to machine precision.
          if (std::abs(n[2].dot(R * u[2])) > 0.2) continue;
          const double residual = PolishRotation(n, u, &R);
          if (!(residual <= max_residual)) continue;
          bool duplicate = false;
          for (const Eigen::Matrix3d& q : out) {
            if ((q - R).norm() < 1e-7) duplicate = true;
          }
          if (!duplicate) out.push_back(R);
        }
      }
    }
    if (phi == 0.0 && largest <= 25.0 && std::abs(F.c[F.deg]) > 1e-3 * big) break;
  }
  return out;
}

Eigen::Vector3d SolveTranslation(const Eigen::Matrix3d& R, const std::array<WorldPlane, 3>& planes,
                                 const std::array<RigLine, 3>& lines) {
  // Eq. 36: stack n_i^T t = -d_i - n_i^T R p for every point p of line i and
  // solve the normal equations (sum n n^T) t = sum n (-d - n^T R p).
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d& n = planes[i].normal;
    for (const Eigen::Vector3d& p : lines[i].points) {
      AtA += n * n.transpose();
      Atb += n * (-planes[i].d - n.dot(R * p));
    }
  }
  return AtA.ldlt().solve(Atb);
}

Status SolveP3l(std::array<WorldPlane, 3> planes, const std::array<RigLine, 3>& lines,
                const P3lOptions& options, const Disambiguation& dis,
                std::vector<PoseCandidate>* candidates) {
  candidates->clear();
  Status s = CheckMinimalProblem(&planes, lines, options);
  if (!s.ok()) return s;
  const std::array<Eigen::Vector3d, 3> n = {planes[0].normal, planes[1].normal, planes[2].normal};
  const std::array<Eigen::Vector3d, 3> u = {lines[0].direction, lines[1].direction, lines[2].direction};
  const std::vector<RigLine>& extra_lines = dis.extra_lines;
  std::vector<WorldPlane> extra_planes = dis.extra_planes;
  if (extra_planes.size() != extra_lines.size()) return Status::Error("extra lines and planes differ in number");
  for (WorldPlane& p : extra_planes) {
    const double len = p.normal.norm();
    if (!(len > 1e-9) || !p.normal.allFinite() || !std::isfinite(p.d)) {
      return Status::Error("an extra plane is degenerate");
    }
    p.normal /= len;
    p.d /= len;
  }
  for (const Eigen::Matrix3d& R : SolveP3lRotations(n, u, options.max_rotation_residual)) {
    PoseCandidate c;
    c.R = R;
    c.t = SolveTranslation(R, planes, lines);
    bool in_front = true;
    for (int i = 0; i < 3; ++i) {
      if (!(planes[i].SignedDistance(c.t) < 0.0)) in_front = false;  // Eq. 37
    }
    if (options.require_in_front && !in_front) continue;
    c.rotation_residual = 0.0;
    c.conditioning = RotationConditioning(n, u, R);
    double sq = 0.0;
    int count = 0;
    for (int i = 0; i < 3; ++i) {
      c.rotation_residual = std::max(c.rotation_residual, std::abs(n[i].dot(R * u[i])));
      for (const Eigen::Vector3d& p : lines[i].points) {
        const double e = planes[i].SignedDistance(R * p + c.t);
        sq += e * e;
        ++count;
      }
    }
    c.point_rms = std::sqrt(sq / std::max(count, 1));
    if (!extra_lines.empty()) {
      double esq = 0.0;
      int ecount = 0;
      for (size_t k = 0; k < extra_lines.size(); ++k) {
        for (const Eigen::Vector3d& p : extra_lines[k].points) {
          const double e = extra_planes[k].SignedDistance(R * p + c.t);
          esq += e * e;
          ++ecount;
        }
      }
      c.score = std::sqrt(esq / std::max(ecount, 1));
    } else if (dis.has_previous) {
      c.score = RotationAngle(dis.previous_R, R) + (dis.previous_t - c.t).norm();
    } else {
      c.score = c.point_rms + c.rotation_residual;
    }
    bool duplicate = false;
    for (const PoseCandidate& q : *candidates) {
      if ((q.R - c.R).norm() < options.duplicate_tolerance && (q.t - c.t).norm() < 1e-6) duplicate = true;
    }
    if (!duplicate) candidates->push_back(c);
  }
  std::stable_sort(candidates->begin(), candidates->end(),
                   [](const PoseCandidate& x, const PoseCandidate& y) { return x.score < y.score; });
  return Status::Ok();
}

Status SolveP3l(const std::array<Correspondence, 3>& correspondences, const Rig& rig,
                const P3lOptions& options, const Disambiguation& disambiguation,
                std::vector<PoseCandidate>* candidates) {
  std::array<WorldPlane, 3> planes;
  std::array<RigLine, 3> lines;
  for (int i = 0; i < 3; ++i) {
    planes[i] = correspondences[i].plane;
    Status s = ToRigLine(correspondences[i].line, rig, &lines[i]);
    if (!s.ok()) return Status::Error("lines[" + std::to_string(i) + "]: " + s.message());
  }
  return SolveP3l(planes, lines, options, disambiguation, candidates);
}

}  // namespace sweepscan::sfm
