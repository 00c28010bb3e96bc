// Small dense univariate polynomials (degree <= 16) and their real roots,
// for the minimal solver (core/sfm/p3l.h). Coefficients are stored lowest
// degree first: p(x) = c[0] + c[1] x + ... + c[deg] x^deg.
#ifndef SWEEPSCAN_CORE_SFM_POLYNOMIAL_H_
#define SWEEPSCAN_CORE_SFM_POLYNOMIAL_H_

#include <array>
#include <vector>

namespace sweepscan::sfm {

struct Poly {
  static constexpr int kMaxDegree = 16;
  std::array<double, kMaxDegree + 1> c{};
  int deg = 0;

  Poly() = default;
  // a + b x
  static Poly Linear(double a, double b) {
    Poly p;
    p.c[0] = a;
    p.c[1] = b;
    p.deg = 1;
    return p;
  }
  static Poly Constant(double a) {
    Poly p;
    p.c[0] = a;
    return p;
  }
  double operator()(double x) const;  // Horner
  double Derivative(double x) const;
};

Poly operator+(const Poly& a, const Poly& b);
Poly operator-(const Poly& a, const Poly& b);
Poly operator*(const Poly& a, const Poly& b);  // asserts deg(a) + deg(b) <= 16
Poly operator*(double s, const Poly& a);

struct RealRootOptions {
  // A complex eigenvalue z is kept as the real root Re(z) when
  // |Im z| <= near_real * (1 + |z|): noise (or rounding) splits a real double
  // root into a close complex pair, and the callers verify every candidate.
  double near_real = 0.05;
  int newton_iterations = 4;
};

// Real roots of p (leading coefficients below 1e-14 of the largest are
// dropped first) from the eigenvalues of the companion matrix of the
// scaled polynomial q(y) = p(rho y) / (lead rho^n), rho = |c0/cn|^(1/n), which
// balances the coefficients; each root is then polished with Newton steps on
// p (kept only when a step does not increase |p|).
std::vector<double> RealRoots(const Poly& p, const RealRootOptions& options = {});

}  // namespace sweepscan::sfm

#endif  // SWEEPSCAN_CORE_SFM_POLYNOMIAL_H_
