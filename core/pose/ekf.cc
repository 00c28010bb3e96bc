#include "core/pose/ekf.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <utility>

namespace sweepscan {

bool EkfOptions::IsValid(std::string* error) const {
  const double values[] = {accel_sigma, angular_accel_sigma, position_sigma,   yaw_sigma,
                           tilt_sigma,  yaw_offset_sigma,    wheel_v_sigma,    wheel_w_sigma,
                           gyro_sigma,  imu_yaw_sigma,       imu_tilt_sigma,   gyro_bias_sigma,
                           gyro_bias_prior_sigma};
  if (!std::isfinite(tilt_sigma_per_metre) || tilt_sigma_per_metre < 0.0) {
    *error = "EKF tilt_sigma_per_metre must be >= 0 and finite";
    return false;
  }
  for (double v : values) {
    if (!std::isfinite(v) || v <= 0.0) {
      *error = "EKF noise standard deviations must be positive and finite";
      return false;
    }
  }
  if (!(gate_chi2_1dof >= 0.0) || !(gate_chi2_2dof >= 0.0)) {
    *error = "EKF gate thresholds must be >= 0 (0 disables the gate)";
    return false;
  }
  return true;
}

void PoseEkf::Initialize(Time time, const State& state, const Covariance& covariance) {
  time_ = time;
  state_ = state;
  state_[kPsi] = WrapAngle(state_[kPsi]);
  covariance_ = covariance;
  if (!options_.estimate_gyro_bias) {  // g frozen at 0: the filter without the bias state
    state_[kGyroBias] = 0.0;
    covariance_.row(kGyroBias).setZero();
    covariance_.col(kGyroBias).setZero();
  }
  initialized_ = true;
  yaw_offset_known_ = false;
  after_gap_ = false;
  history_.clear();
}

void PoseEkf::PredictState(const EkfOptions& options, const State& s, const Covariance& p,
                           double dt, State* s_pred, Covariance* p_pred, Covariance* f_out) {
  const double psi = s[kPsi], v = s[kV], w = s[kW];
  const double h = psi + 0.5 * w * dt;
  const double c = std::cos(h), sn = std::sin(h);

  // (Eq. 6) state prediction.
  *s_pred = s;
  (*s_pred)[kX] += v * dt * c;
  (*s_pred)[kY] += v * dt * sn;
  (*s_pred)[kPsi] = WrapAngle(psi + w * dt);

  // (Eq. 7) F = df/ds.
  Covariance& f = *f_out;
  f.setIdentity();
  f(kX, kPsi) = -v * dt * sn;
  f(kX, kV) = dt * c;
  f(kX, kW) = -v * dt * sn * 0.5 * dt;
  f(kY, kPsi) = v * dt * c;
  f(kY, kV) = dt * sn;
  f(kY, kW) = v * dt * c * 0.5 * dt;
  f(kPsi, kW) = dt;

  State q;
  q << options.position_sigma * options.position_sigma,
      options.position_sigma * options.position_sigma, options.yaw_sigma * options.yaw_sigma,
      options.accel_sigma * options.accel_sigma,
      options.angular_accel_sigma * options.angular_accel_sigma,
      options.tilt_sigma * options.tilt_sigma, options.tilt_sigma * options.tilt_sigma,
      options.yaw_offset_sigma * options.yaw_offset_sigma,
      options.estimate_gyro_bias ? options.gyro_bias_sigma * options.gyro_bias_sigma : 0.0;
  // The tilt wanders with the floor under the wheels: its variance grows by
  // tilt_sigma_per_metre^2 per metre driven (|v| dt) as well as in time.
  const double q_tilt_distance =
      options.tilt_sigma_per_metre * options.tilt_sigma_per_metre * std::abs(v);
  q[kRoll] += q_tilt_distance;
  q[kPitch] += q_tilt_distance;
  // P- = F P F^T with F = I + D, D non-zero in the rows of x, y and psi
  // only (Eq. 7): F P F^T = (P + D P) + (P + D P) D^T, so each of D's rows
  // costs two 9-vector products. The dense 9x9x9 products cost six times
  // as much, and Eigen sends them to its blocked GEMM (every size is >=
  // its cache-friendly threshold of 8), whose packing costs more than the
  // product: the EKF was 18 % of a CLI reconstruct. Products of fixed
  // small sizes here and below are coefficient-based (lazyProduct).
  constexpr int kMoved[] = {kX, kY, kPsi};
  Eigen::Matrix<double, 3, kStateSize> d;  // D's non-zero rows
  for (int k = 0; k < 3; ++k) {
    d.row(k) = f.row(kMoved[k]);
    d(k, kMoved[k]) -= 1.0;
  }
  Covariance fp = p;
  for (int k = 0; k < 3; ++k) fp.row(kMoved[k]) += d.row(k).lazyProduct(p);
  *p_pred = fp;
  for (int k = 0; k < 3; ++k) p_pred->col(kMoved[k]) += fp.lazyProduct(d.row(k).transpose());
  p_pred->diagonal() += q * dt;
}

void PoseEkf::Predict(Time time) {
  const double dt = ToSeconds(time - time_);
  if (dt <= 0.0) return;
  if (keep_history_) history_.push_back({time_, state_, covariance_, after_gap_});
  after_gap_ = false;
  Covariance f;
  State s;
  Covariance p;
  PredictState(options_, state_, covariance_, dt, &s, &p, &f);
  state_ = s;
  covariance_ = p;
  time_ = time;
}

std::vector<PoseEkf::Estimate> PoseEkf::Smooth() const {
  std::vector<Estimate> out;
  if (!initialized_) return out;
  out = history_;
  out.push_back({time_, state_, covariance_, after_gap_});
  // Backward from the last estimate, which is already the smoothed one.
  for (size_t k = out.size() - 1; k-- > 0;) {
    const Estimate& next = out[k + 1];  // smoothed
    Estimate& e = out[k];               // filtered, becomes smoothed
    // A gap: no motion model links e to next (ResumeAfterGap), so e is the
    // last estimate of its segment and already its own smoothed one.
    if (next.after_gap) continue;
    const double dt = ToSeconds(next.time - e.time);
    State s_pred;
    Covariance p_pred, f;
    PredictState(options_, e.state, e.covariance, dt, &s_pred, &p_pred, &f);
    // C = P F^T (P-)^-1 = ((P-)^-1 F P)^T, P and P- symmetric. LDLT treats
    // a zero pivot (g frozen at 0 with variance 0) as a pseudo-inverse.
    const Eigen::LDLT<Covariance> ldlt(p_pred);
    const Covariance c = ldlt.solve(f.lazyProduct(e.covariance)).transpose();
    State dx = next.state - s_pred;
    dx[kPsi] = WrapAngle(dx[kPsi]);
    dx[kYawOffset] = WrapAngle(dx[kYawOffset]);
    e.state += c * dx;
    e.state[kPsi] = WrapAngle(e.state[kPsi]);
    e.state[kYawOffset] = WrapAngle(e.state[kYawOffset]);
    const Covariance dp = next.covariance - p_pred;
    const Covariance c_dp = c.lazyProduct(dp);
    e.covariance += c_dp.lazyProduct(c.transpose());
    e.covariance = 0.5 * (e.covariance + e.covariance.transpose());
  }
  return out;
}

// A gap of dt = time - time_ in the records (docs/models.md, "Gaps in the
// data"). Nothing is predicted with the motion model; instead:
//   x, y     held; P_xx, P_yy += position_sigma^2 (the travel bound, any
//            direction), their correlations with the rest kept
//   psi      held; P_psipsi += heading_sigma^2, so that the next IMU yaw
//            (z = psi + b, b known from before the gap) sets it:
//            K_psi = P_psipsi / (P_psipsi + P_bb + R) -> 1
//   v, w     0, uncorrelated, variances velocity/yaw_rate_variance: the
//            robot's speed after the gap is unrelated to the one before
//   roll, pitch  held, uncorrelated, variance tilt_variance: the robot may
//            stand on another patch of floor; the next tilt reading sets them
//   b, g     held; their random walks over dt as in Q (the IMU's heading
//            reference and gyro bias drift whether or not we hear from it)
void PoseEkf::ResumeAfterGap(Time time, const GapReset& reset) {
  const double dt = ToSeconds(time - time_);
  if (!initialized_ || dt <= 0.0) return;
  if (keep_history_) history_.push_back({time_, state_, covariance_, after_gap_});
  Covariance& p = covariance_;
  p(kYawOffset, kYawOffset) += options_.yaw_offset_sigma * options_.yaw_offset_sigma * dt;
  if (options_.estimate_gyro_bias) {
    p(kGyroBias, kGyroBias) += options_.gyro_bias_sigma * options_.gyro_bias_sigma * dt;
  }
  p(kX, kX) += reset.position_sigma * reset.position_sigma;
  p(kY, kY) += reset.position_sigma * reset.position_sigma;
  p(kPsi, kPsi) += reset.heading_sigma * reset.heading_sigma;
  const std::pair<int, double> restarted[] = {{kV, reset.velocity_variance},
                                              {kW, reset.yaw_rate_variance},
                                              {kRoll, reset.tilt_variance},
                                              {kPitch, reset.tilt_variance}};
  for (const auto& [i, variance] : restarted) {
    p.row(i).setZero();
    p.col(i).setZero();
    p(i, i) = variance;
  }
  state_[kV] = 0.0;
  state_[kW] = 0.0;
  time_ = time;
  after_gap_ = true;
}

// GCC 12 reports -Warray-bounds inside Eigen's vectorised copies for the
// 1x1 LDLT solve (M = 1: a 1x8 row block read as SSE packets). A false
// positive in third-party code (the sizes are fixed and correct); silenced
// here, for this function only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif
template <int M>
bool PoseEkf::Update(const Eigen::Matrix<double, M, 1>& z,
                     const Eigen::Matrix<double, M, kStateSize>& h,
                     const Eigen::Matrix<double, M, M>& r,
                     const Eigen::Matrix<bool, M, 1>& is_angle) {
  // (1) Innovation and its covariance.
  Eigen::Matrix<double, M, 1> y = z - h * state_;
  for (int i = 0; i < M; ++i) {
    if (is_angle[i]) y[i] = WrapAngle(y[i]);
  }
  const Eigen::Matrix<double, M, kStateSize> hp = h.lazyProduct(covariance_);
  const Eigen::Matrix<double, M, M> s = hp.lazyProduct(h.transpose()) + r;
  const Eigen::LDLT<Eigen::Matrix<double, M, M>> s_ldlt(s);

  // (2) Mahalanobis gate.
  const double gate = M == 1 ? options_.gate_chi2_1dof : options_.gate_chi2_2dof;
  const double d2 = y.dot(s_ldlt.solve(y));
  if (gate > 0.0 && d2 > gate) {
    ++counters_.rejected;
    return false;
  }

  // (3) Gain and state update: K = P H^T S^-1.
  const Eigen::Matrix<double, kStateSize, M> k =
      s_ldlt.solve(hp).transpose();  // (S^-1 H P)^T = P H^T S^-1, S and P symmetric
  state_ += k * y;
  state_[kPsi] = WrapAngle(state_[kPsi]);
  state_[kYawOffset] = WrapAngle(state_[kYawOffset]);

  // (4) Joseph form, P+ = (I - K H) P (I - K H)^T + K R K^T, as rank-M
  // updates: A = (I - K H) P = P - K (H P), then A (I - K H)^T = A - (A H^T) K^T.
  // The same matrix at a fifth of the dense 9x9x9 products' cost.
  const Covariance a = covariance_ - k.lazyProduct(hp);
  const Eigen::Matrix<double, kStateSize, M> a_ht = a.lazyProduct(h.transpose());
  const Eigen::Matrix<double, kStateSize, M> kr = k.lazyProduct(r);
  covariance_ = a - a_ht.lazyProduct(k.transpose()) + kr.lazyProduct(k.transpose());
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  ++counters_.updates;
  return true;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

bool PoseEkf::UpdateWheels(Time time, double v, double w) {
  Predict(time);
  Eigen::Matrix<double, 2, kStateSize> h = Eigen::Matrix<double, 2, kStateSize>::Zero();
  h(0, kV) = 1.0;
  h(1, kW) = 1.0;
  const Eigen::Vector2d r(options_.wheel_v_sigma * options_.wheel_v_sigma,
                          options_.wheel_w_sigma * options_.wheel_w_sigma);
  return Update<2>(Eigen::Vector2d(v, w), h, r.asDiagonal().toDenseMatrix(),
                   Eigen::Matrix<bool, 2, 1>(false, false));
}

bool PoseEkf::UpdateGyro(Time time, double w) {
  Predict(time);
  // z = w + g. With estimate_gyro_bias false, g stays 0 with variance 0
  // (no process noise, and a zero row of P gives a zero gain row).
  Eigen::Matrix<double, 1, kStateSize> h = Eigen::Matrix<double, 1, kStateSize>::Zero();
  h(0, kW) = 1.0;
  h(0, kGyroBias) = 1.0;
  return Update<1>(Eigen::Matrix<double, 1, 1>(w), h,
                   Eigen::Matrix<double, 1, 1>(options_.gyro_sigma * options_.gyro_sigma),
                   Eigen::Matrix<bool, 1, 1>(false));
}

bool PoseEkf::UpdateYaw(Time time, double imu_yaw) {
  Predict(time);
  if (!yaw_offset_known_) {
    state_[kYawOffset] = WrapAngle(imu_yaw - state_[kPsi]);
    covariance_.row(kYawOffset).setZero();
    covariance_.col(kYawOffset).setZero();
    covariance_(kYawOffset, kYawOffset) = options_.imu_yaw_sigma * options_.imu_yaw_sigma;
    yaw_offset_known_ = true;
    return true;
  }
  Eigen::Matrix<double, 1, kStateSize> h = Eigen::Matrix<double, 1, kStateSize>::Zero();
  h(0, kPsi) = 1.0;
  h(0, kYawOffset) = 1.0;
  // The residual z - (psi + b) is wrapped in Update; b itself is kept wrapped below.
  return Update<1>(Eigen::Matrix<double, 1, 1>(imu_yaw), h,
                   Eigen::Matrix<double, 1, 1>(options_.imu_yaw_sigma * options_.imu_yaw_sigma),
                   Eigen::Matrix<bool, 1, 1>(true));
}

bool PoseEkf::UpdateTilt(Time time, double roll, double pitch) {
  Predict(time);
  Eigen::Matrix<double, 2, kStateSize> h = Eigen::Matrix<double, 2, kStateSize>::Zero();
  h(0, kRoll) = 1.0;
  h(1, kPitch) = 1.0;
  const double var = options_.imu_tilt_sigma * options_.imu_tilt_sigma;
  return Update<2>(Eigen::Vector2d(roll, pitch), h, Eigen::Vector2d(var, var).asDiagonal().toDenseMatrix(),
                   Eigen::Matrix<bool, 2, 1>(true, true));
}

void PoseEkf::SetGyroBias(double bias, double variance) {
  if (!options_.estimate_gyro_bias || !std::isfinite(bias) || !(variance > 0.0)) return;
  state_[kGyroBias] = bias;
  covariance_.row(kGyroBias).setZero();
  covariance_.col(kGyroBias).setZero();
  covariance_(kGyroBias, kGyroBias) = variance;
}

Rigid3d PoseEkf::WorldFromBody() const {
  return Rigid3d::FromPose(state_[kX], state_[kY], 0.0, state_[kRoll], state_[kPitch],
                           state_[kPsi]);
}

}  // namespace sweepscan
