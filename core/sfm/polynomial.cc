#include "core/sfm/polynomial.h"

#include <Eigen/Eigenvalues>  // RealSchur
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

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

namespace {

// Eigenvalues (wr + i wi) of the upper Hessenberg n x n matrix a (destroyed):
// the shifted double-step (Francis) QR iteration with deflation, as in
// EISPACK's hqr. Only the eigenvalues are wanted, so each step transforms
// the active window [l, nn] alone (rows to nn, columns from l), not the whole
// quasi-triangular matrix a real Schur form keeps. A complex pair comes as
// two entries with wi of opposite signs. False after 60 iterations without
// a deflation (the caller falls back to Eigen).
bool HessenbergEigenvalues(double a[Poly::kMaxDegree][Poly::kMaxDegree], int n, double* wr,
                           double* wi) {
  const double eps = std::numeric_limits<double>::epsilon();
  double anorm = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = std::max(i - 1, 0); j < n; ++j) anorm += std::abs(a[i][j]);
  }
  int nn = n - 1;
  double t = 0.0;  // exceptional shifts so far
  while (nn >= 0) {
    int its = 0, l = 0;
    do {
      // Look for a single small subdiagonal element.
      for (l = nn; l > 0; --l) {
        double s = std::abs(a[l - 1][l - 1]) + std::abs(a[l][l]);
        if (s == 0.0) s = anorm;
        if (std::abs(a[l][l - 1]) <= eps * s) {
          a[l][l - 1] = 0.0;
          break;
        }
      }
      double x = a[nn][nn];
      if (l == nn) {  // one root
        wr[nn] = x + t;
        wi[nn] = 0.0;
        --nn;
      } else {
        double y = a[nn - 1][nn - 1];
        double w = a[nn][nn - 1] * a[nn - 1][nn];
        if (l == nn - 1) {  // two roots
          const double p = 0.5 * (y - x);
          const double q = p * p + w;
          double z = std::sqrt(std::abs(q));
          x += t;
          if (q >= 0.0) {
            z = p + std::copysign(z, p);
            wr[nn - 1] = wr[nn] = x + z;
            if (z != 0.0) wr[nn] = x - w / z;
            wi[nn - 1] = wi[nn] = 0.0;
          } else {
            wr[nn - 1] = wr[nn] = x + p;
            wi[nn - 1] = -z;
            wi[nn] = z;
          }
          nn -= 2;
        } else {  // no root yet: a double QR step on [l, nn]
          if (its == 60) return false;
          if (its == 10 || its == 20 || its == 40) {  // exceptional shift
            t += x;
            for (int i = 0; i <= nn; ++i) a[i][i] -= x;
            const double s = std::abs(a[nn][nn - 1]) + std::abs(a[nn - 1][nn - 2]);
            y = x = 0.75 * s;
            w = -0.4375 * s * s;
          }
          ++its;
          // Two consecutive small subdiagonal elements: start at m.
          int m = nn - 2;
          double p = 0.0, q = 0.0, r = 0.0, z = 0.0;
          for (; m >= l; --m) {
            z = a[m][m];
            r = x - z;
            double s = y - z;
            p = (r * s - w) / a[m + 1][m] + a[m][m + 1];
            q = a[m + 1][m + 1] - z - r - s;
            r = a[m + 2][m + 1];
            s = std::abs(p) + std::abs(q) + std::abs(r);
            p /= s;
            q /= s;
            r /= s;
            if (m == l) break;
            const double u = std::abs(a[m][m - 1]) * (std::abs(q) + std::abs(r));
            const double v =
                std::abs(p) * (std::abs(a[m - 1][m - 1]) + std::abs(z) + std::abs(a[m + 1][m + 1]));
            if (u <= eps * v) break;
          }
          for (int i = m; i < nn - 1; ++i) {
            a[i + 2][i] = 0.0;
            if (i != m) a[i + 2][i - 1] = 0.0;
          }
          for (int k = m; k < nn; ++k) {
            if (k != m) {
              p = a[k][k - 1];
              q = a[k + 1][k - 1];
              r = k + 1 != nn ? a[k + 2][k - 1] : 0.0;
              x = std::abs(p) + std::abs(q) + std::abs(r);
              if (x != 0.0) {
                p /= x;
                q /= x;
                r /= x;
              }
            }
            const double s = std::copysign(std::sqrt(p * p + q * q + r * r), p);
            if (s == 0.0) continue;
            if (k == m) {
              if (l != m) a[k][k - 1] = -a[k][k - 1];
            } else {
              a[k][k - 1] = -s * x;
            }
            p += s;
            x = p / s;
            y = q / s;
            z = r / s;
            q /= p;
            r /= p;
            for (int j = k; j <= nn; ++j) {  // rows k..k+2, columns to nn
              p = a[k][j] + q * a[k + 1][j];
              if (k + 1 != nn) {
                p += r * a[k + 2][j];
                a[k + 2][j] -= p * z;
              }
              a[k + 1][j] -= p * y;
              a[k][j] -= p * x;
            }
            const int mmin = nn < k + 3 ? nn : k + 3;
            for (int i = l; i <= mmin; ++i) {  // columns k..k+2, rows from l
              p = x * a[i][k] + y * a[i][k + 1];
              if (k + 1 != nn) {
                p += z * a[i][k + 2];
                a[i][k + 2] -= p * r;
              }
              a[i][k + 1] -= p * q;
              a[i][k] -= p;
            }
          }
        }
      }
    } while (l < nn - 1);
  }
  return true;
}

}  // namespace

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
  // The companion matrix is already upper Hessenberg: its eigenvalues by
  // the shifted double-step QR iteration on the active window only
  // (HessenbergEigenvalues); Eigen's RealSchur as the fallback.
  std::array<double, Poly::kMaxDegree> wr{}, wi{};
  double a[Poly::kMaxDegree][Poly::kMaxDegree];
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) a[i][j] = companion(i, j);
  }
  if (!HessenbergEigenvalues(a, m, wr.data(), wi.data())) {
    Eigen::RealSchur<Mat> schur(m);
    schur.computeFromHessenberg(companion, Mat::Identity(m, m), /*computeU=*/false);
    if (schur.info() != Eigen::Success) return roots;
    const Mat& T = schur.matrixT();
    for (int i = 0; i < m; ++i) {
      wr[i] = T(i, i);
      wi[i] = 0.0;
      if (i + 1 < m && T(i + 1, i) != 0.0) {
        // 2x2 block [[a, b], [c, d]]: eigenvalues (a + d)/2 +- sqrt(((a - d)/2)^2 + b c).
        const double ta = T(i, i), tb = T(i, i + 1), tc = T(i + 1, i), td = T(i + 1, i + 1);
        const double half = 0.5 * (ta - td), disc = half * half + tb * tc;
        const double mid = 0.5 * (ta + td), r = std::sqrt(std::abs(disc));
        wr[i] = disc >= 0.0 ? mid + r : mid;
        wr[i + 1] = disc >= 0.0 ? mid - r : mid;
        wi[i] = disc >= 0.0 ? 0.0 : r;
        wi[i + 1] = -wi[i];
        ++i;
      }
    }
  }
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
    // A complex pair once (its member with Im > 0), kept when near real.
    if (wi[i] < 0.0) continue;
    if (std::abs(wi[i]) > options.near_real * (1.0 + std::hypot(wr[i], wi[i]))) continue;
    polish(wr[i]);
  }
  return roots;
}

}  // namespace sweepscan::sfm
