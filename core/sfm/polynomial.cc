#include "core/sfm/polynomial.h"

#include <Eigen/Eigenvalues>  // RealSchur
#include <algorithm>
#include <cassert>
#include <cmath>

namespace sweepscan::sfm {

double Poly::operator()(double x) const {
  double v = c[deg];
  for (int i = deg - 1; i >= 0; --i) v = v * x + c[i];
  return v;
}

double Poly::Derivative(double x) const {
  if (deg == 0) return 0.0;
  double v = deg * c[deg];
  for (int i = deg - 1; i >= 1; --i) v = v * x + i * c[i];
  return v;
}

Poly operator+(const Poly& a, const Poly& b) {
  Poly r;
  r.deg = std::max(a.deg, b.deg);
  for (int i = 0; i <= r.deg; ++i) r.c[i] = a.c[i] + b.c[i];
  return r;
}

Poly operator-(const Poly& a, const Poly& b) {
  Poly r;
  r.deg = std::max(a.deg, b.deg);
  for (int i = 0; i <= r.deg; ++i) r.c[i] = a.c[i] - b.c[i];
  return r;
}

Poly operator*(const Poly& a, const Poly& b) {
  assert(a.deg + b.deg <= Poly::kMaxDegree);
  Poly r;
  r.deg = a.deg + b.deg;
  for (int i = 0; i <= a.deg; ++i) {
    if (a.c[i] == 0.0) continue;
    for (int j = 0; j <= b.deg; ++j) r.c[i + j] += a.c[i] * b.c[j];
  }
  return r;
}

Poly operator*(double s, const Poly& a) {
  Poly r = a;
  for (int i = 0; i <= r.deg; ++i) r.c[i] *= s;
  return r;
}

std::vector<double> RealRoots(const Poly& p, const RealRootOptions& options) {
  std::vector<double> roots;
  double big = 0.0;
  for (int i = 0; i <= p.deg; ++i) big = std::max(big, std::abs(p.c[i]));
  if (!(big > 0.0) || !std::isfinite(big)) return roots;
  int n = p.deg;
  while (n > 0 && std::abs(p.c[n]) <= 1e-14 * big) --n;
  // Roots at zero (trailing zero coefficients) are split off.
  int zeros = 0;
  while (zeros < n && std::abs(p.c[zeros]) <= 1e-300) ++zeros;
  for (int i = 0; i < zeros; ++i) roots.push_back(0.0);
  const int m = n - zeros;
  if (m <= 0) return roots;
  const double lead = p.c[n];
  // Scale x = rho y so that the monic q has |q_0| = 1.
  const double rho = std::pow(std::abs(p.c[zeros] / lead), 1.0 / m);
  // At most 16 x 16: storage on the stack, no allocation per solve.
  using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, Poly::kMaxDegree, Poly::kMaxDegree>;
  Mat companion = Mat::Zero(m, m);
  double rho_pow = 1.0;  // rho^(k - m) for coefficient k, built up from k = m down
  std::array<double, Poly::kMaxDegree + 1> q{};
  q[m] = 1.0;
  for (int k = m - 1; k >= 0; --k) {
    rho_pow /= rho;
    q[k] = p.c[k + zeros] / lead * rho_pow;
  }
  for (int i = 1; i < m; ++i) companion(i, i - 1) = 1.0;
  for (int i = 0; i < m; ++i) companion(i, m - 1) = -q[i];
  // The companion matrix is already upper Hessenberg: go straight to the
  // shifted QR iterations of the real Schur form (no reduction, no Schur
  // vectors). T is quasi-triangular: 1x1 blocks are real eigenvalues, 2x2
  // blocks complex pairs.
  Eigen::RealSchur<Mat> schur(m);
  schur.computeFromHessenberg(companion, Mat::Identity(m, m), /*computeU=*/false);
  if (schur.info() != Eigen::Success) return roots;
  const Mat& T = schur.matrixT();
  // Newton on p from rho * y; a step never travels far (stay on this root)
  // and never increases |p|.
  auto polish = [&](double y) {
    double x = y * rho;
    double fx = std::abs(p(x));
    for (int it = 0; it < options.newton_iterations; ++it) {
      const double dv = p.Derivative(x);
      if (dv == 0.0) break;
      const double nx = x - p(x) / dv;
      const double fn = std::abs(p(nx));
      if (!(fn <= fx) || !(std::abs(nx - x) <= 1e-2 * (1.0 + std::abs(x)))) break;
      x = nx;
      fx = fn;
    }
    roots.push_back(x);
  };
  for (int i = 0; i < m; ++i) {
    double re = T(i, i), im = 0.0;
    if (i + 1 < m && T(i + 1, i) != 0.0) {
      // 2x2 block [[a, b], [c, d]]: eigenvalues (a + d)/2 +- sqrt(((a - d)/2)^2 + b c).
      const double a = T(i, i), b = T(i, i + 1), c = T(i + 1, i), d = T(i + 1, i + 1);
      const double half = 0.5 * (a - d), disc = half * half + b * c;
      re = 0.5 * (a + d);
      if (disc >= 0.0) {
        // Two real eigenvalues (a block that did not split): take both.
        const double r = std::sqrt(disc);
        polish(re + r);
        polish(re - r);
        ++i;
        continue;
      }
      im = std::sqrt(-disc);
      ++i;  // The pair's second member is the conjugate.
    }
    if (std::abs(im) > options.near_real * (1.0 + std::hypot(re, im))) continue;
    polish(re);
  }
  return roots;
}

}  // namespace sweepscan::sfm
