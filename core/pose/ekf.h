// Extended Kalman filter fusing wheel odometry and the IMU (Miao et al. 2022,
// section 2.2, Eq. 6-10), in the robot_localization style: the filter core
// knows nothing about devices; each sensor says which state it measures.
//
// State (9):  s = [x, y, psi, v, w, roll, pitch, b, g]
//   x, y   position of the body origin in the world (m)
//   psi    yaw (rad), wrapped to (-pi, pi]
//   v, w   forward speed (m/s) and yaw rate (rad/s) in the body frame
//   roll, pitch  platform tilt (rad); constant on a flat floor
//   b      offset of the IMU's heading reference from the world's (rad). The
//          start pose defines the world, so psi starts known and b is learnt
//          from every yaw reading instead of being frozen at the first one
//          (whose 0.5 deg of noise would otherwise bias the whole map).
//   g      the gyro's z bias (rad/s): the gyro reads w + g. A random walk
//          (g' = g, variance growing by gyro_bias_sigma^2 dt). Unmodelled,
//          a bias of 2 mrad/s bends a 26 s circle drive's heading by up to
//          ~50 mrad against the yaw readings and the filter lags between
//          them; the mounting calibration then absorbs the bent circle in
//          alpha (-2 mrad on the lab circle). g is observable from the IMU
//          yaw (psi + b drifts by g t if g is wrong) and, at a standstill,
//          from the gyro alone (w = 0): PoseEstimator seeds it with the
//          mean gyro z of a standstill at the start of a drive
//          (SetGyroBias).
//
// Process model (Eq. 6), a constant-velocity unicycle integrated with the
// midpoint rule of the odometry (Eq. 4-5), h = psi + w dt / 2:
//   x' = x + v dt cos h,  y' = y + v dt sin h,  psi' = psi + w dt,
//   v' = v,  w' = w,  roll' = roll,  pitch' = pitch,  b' = b,  g' = g.
// Covariance prediction (Eq. 7): P' = F P F^T + Q dt, F = df/ds, and Q the
// diagonal of white accelerations on v and w, random walks on the rest; the
// tilt's random walk grows with the distance driven (|v| dt), as the wheels
// roll over the floor's unevenness, plus a small term in time.
//
// Measurement models (all linear, z = H s + n):
//   wheels  z = [v, w]       from the encoders via Eq. 2-3
//   gyro    z = w + g        IMU z rate, biased
//   yaw     z = psi + b      IMU heading in its own reference
//   tilt    z = [roll, pitch]
// Update (Eq. 8-10), numbered as in the code:
//   (1) innovation y = z - H s (angles wrapped), S = H P H^T + R
//   (2) Mahalanobis gate: reject if y^T S^-1 y > chi2(dof, 99.9 %)
//   (3) gain K = P H^T S^-1, state s += K y
//   (4) Joseph form P = (I - K H) P (I - K H)^T + K R K^T, which stays
//       symmetric positive definite under rounding.
//
// Smoothing (offline, a whole recording): with KeepHistory(true) the filter
// keeps its estimate (s_k, P_k) after the updates at every time t_k, and
// Smooth() runs the Rauch-Tung-Striebel backward pass over them:
//   s-_{k+1} = f(s_k),  P-_{k+1} = F_k P_k F_k^T + Q dt_k      (Eq. 6-7 again)
//   C_k   = P_k F_k^T (P-_{k+1})^-1
//   s^_k  = s_k + C_k (s^_{k+1} - s-_{k+1})                   (angles wrapped)
//   P^_k  = P_k + C_k (P^_{k+1} - P-_{k+1}) C_k^T
// from s^_N = s_N, P^_N = P_N. Why: each forward estimate knows only the
// readings before it. The IMU's yaw is white noise of 0.5 deg in a heading
// reference b the filter learns as it goes, so the forward heading carries
// an error that wanders over the drive; the two sightings of a wall, half a
// circle apart, then disagree by it, and the mounting calibration reads it
// as alpha. The smoothed heading at every time uses every reading of the
// drive, before and after. Updates that are not Kalman updates (the first
// yaw reading setting b, SetGyroBias) are part of the filtered estimate at
// their time; the backward pass needs only the predictions between times.
//
// Gaps in the data (docs/models.md, "Gaps in the data"): ResumeAfterGap
// moves the filter over a hole in the records without the motion model
// (which would invent v dt of travel) and inflates P by what the robot can
// have done meanwhile. The estimate after the gap is marked (after_gap) and
// the backward pass does not cross it: the last estimate before a gap is
// the smoothed one of its segment, as the last of the drive is.
#ifndef SWEEPSCAN_CORE_POSE_EKF_H_
#define SWEEPSCAN_CORE_POSE_EKF_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/common/time.h"
#include "core/geometry/transform.h"

namespace sweepscan {

struct EkfOptions {
  // Process noise (continuous-time standard deviations).
  double accel_sigma = 0.5;          // m/s^2 on v
  double angular_accel_sigma = 0.5;  // rad/s^2 on w
  double position_sigma = 0.002;     // m/sqrt(s), unmodelled motion
  // psi changes only through w, which the gyro measures; a large random walk
  // here would let psi and the IMU heading offset b trade places.
  double yaw_sigma = 0.0002;         // rad/sqrt(s)
  // The platform's tilt changes as the wheels roll over an uneven floor, so
  // its random walk grows with the distance driven, not with time:
  //   var(roll) and var(pitch) grow by (tilt_sigma^2 + tilt_sigma_per_metre^2 |v|) dt.
  // 2.24 mrad/sqrt(m) lets the tilt wander by 2.2 mrad over a metre driven
  // (0.7 mm of height across the 0.3 m track; ordinary floors are allowed
  // 4 mm over 1 m); at 0.2 m/s it is the 1 mrad/sqrt(s) the filter used
  // before. At the calibration target's 0.05 m/s it is 0.5: the
  // filter then averages the IMU's tilt noise over ~1 s instead of ~0.5 s,
  // and the refined picks' worst alpha over 60 drives went from 4.1 to 3.3
  // mrad (docs/results.md). tilt_sigma is what is left at a standstill: the
  // IMU's own tilt reference settling.
  double tilt_sigma = 0.0001;             // rad/sqrt(s)
  double tilt_sigma_per_metre = 0.00224;  // rad/sqrt(m)
  double yaw_offset_sigma = 0.0001;  // rad/sqrt(s), wander of the IMU heading reference
  // Gyro z bias g: random walk (rad/s/sqrt(s)) and the prior 1-sigma at the
  // start of a drive without a standstill (the HI219's turn-on bias is a
  // few mrad/s). estimate_gyro_bias = false freezes g at 0 (variance 0, no
  // random walk): the filter before the bias state.
  // On by default since the automatic calibration estimates the path's
  // distance scale (AutoCalibrationOptions::estimate_path_scale), which the
  // wheel scale errors had hidden in alpha: over the robustness sweep (30
  // drives, gyro bias up to 2 mrad/s, docs/results.md, "Robustness") the
  // pair took alpha from 3.1 to 1.0 mrad RMS, beta from 0.9 to 0.3.
  double gyro_bias_sigma = 1e-5;
  double gyro_bias_prior_sigma = 0.003;  // rad/s
  bool estimate_gyro_bias = true;
  // Measurement noise (standard deviations).
  double wheel_v_sigma = 0.01;       // m/s
  double wheel_w_sigma = 0.05;       // rad/s; wheels slip, so trust them little for yaw rate
  double gyro_sigma = 0.005;         // rad/s
  double imu_yaw_sigma = 0.0087;     // rad (0.5 deg, HI219 Table 2)
  double imu_tilt_sigma = 0.0052;    // rad (0.3 deg)
  // Chi-square gates at 99.9 % for one and two degrees of freedom; 0 disables.
  double gate_chi2_1dof = 10.83;
  double gate_chi2_2dof = 13.82;

  bool IsValid(std::string* error) const;
};

class PoseEkf {
 public:
  static constexpr int kStateSize = 9;
  enum Index { kX = 0, kY, kPsi, kV, kW, kRoll, kPitch, kYawOffset, kGyroBias };
  using State = Eigen::Matrix<double, kStateSize, 1>;
  using Covariance = Eigen::Matrix<double, kStateSize, kStateSize>;

  struct Counters {
    int updates = 0;
    int rejected = 0;  // by the Mahalanobis gate
  };

  // An estimate at one time: the filtered one (after every update at
  // `time`), or the smoothed one.
  struct Estimate {
    Time time;
    State state;
    Covariance covariance;
    bool after_gap = false;  // the first estimate after ResumeAfterGap
  };

  // What ResumeAfterGap does to the state (ekf.cc gives the math).
  struct GapReset {
    // 1-sigma of the travel (m, each of x and y) and of the turn (rad)
    // the robot can have made in the gap; added in quadrature to P.
    double position_sigma = 0.0;
    double heading_sigma = 0.0;
    // v and w restart at 0 with these variances (the next wheel and gyro
    // readings set them); roll and pitch keep their value with this
    // variance (the next tilt reading sets them).
    double velocity_variance = 0.25;
    double yaw_rate_variance = 0.25;
    double tilt_variance = 0.003;
  };

  explicit PoseEkf(const EkfOptions& options) : options_(options) {}

  void Initialize(Time time, const State& state, const Covariance& covariance);
  bool initialized() const { return initialized_; }

  // Advances the state to `time` (Eq. 6-7); no-op for times not after the
  // current one (out-of-order measurements are applied at the filter time).
  void Predict(Time time);

  // Each update predicts to `time` first. Returns false if gated out.
  bool UpdateWheels(Time time, double v, double w);
  bool UpdateGyro(Time time, double w);
  // z is the IMU's own heading; the first call, if the offset was never
  // set, initialises b = z - psi with the measurement's variance.
  bool UpdateYaw(Time time, double imu_yaw);
  bool UpdateTilt(Time time, double roll, double pitch);
  // Sets the gyro bias to `bias` with `variance`, forgetting its
  // correlations with the rest of the state (a measurement taken outside
  // the filter: the mean gyro z over a standstill). No-op when
  // options.estimate_gyro_bias is false.
  void SetGyroBias(double bias, double variance);

  // A gap in the data: moves the filter to `time` (after the current time)
  // without predicting, with the state and covariance reset as in ekf.cc.
  // The next updates (at `time`) belong to the estimate after the gap.
  void ResumeAfterGap(Time time, const GapReset& reset);
  bool yaw_offset_known() const { return yaw_offset_known_; }
  // P_psipsi += sigma^2 (the first IMU yaw after a gap disagreed with the
  // turn bound by more than the gate: the IMU heading is the reference).
  void InflateHeading(double sigma) { covariance_(kPsi, kPsi) += sigma * sigma; }

  // Keep every filtered estimate for Smooth() (about 730 bytes a filter
  // time: 150 a second with the IMU at 100 Hz and the wheels at 50 Hz).
  void KeepHistory(bool keep) { keep_history_ = keep; }
  const std::vector<Estimate>& history() const { return history_; }
  // The Rauch-Tung-Striebel pass (above) over the kept history and the
  // current estimate: one smoothed estimate per filter time, in time order.
  // Empty if the filter was never initialised.
  std::vector<Estimate> Smooth() const;

  // The prediction of Eq. 6-7 from `s`, `p` over dt: s' = f(s),
  // P' = F P F^T + Q dt, and F = df/ds.
  static void PredictState(const EkfOptions& options, const State& s, const Covariance& p,
                           double dt, State* s_pred, Covariance* p_pred, Covariance* f);

  Time time() const { return time_; }
  const State& state() const { return state_; }
  const Covariance& covariance() const { return covariance_; }
  const Counters& counters() const { return counters_; }
  Rigid3d WorldFromBody() const;

 private:
  template <int M>
  bool Update(const Eigen::Matrix<double, M, 1>& z, const Eigen::Matrix<double, M, kStateSize>& h,
              const Eigen::Matrix<double, M, M>& r, const Eigen::Matrix<bool, M, 1>& is_angle);

  EkfOptions options_;
  bool initialized_ = false;
  Time time_;
  State state_ = State::Zero();
  Covariance covariance_ = Covariance::Identity();
  Counters counters_;
  bool yaw_offset_known_ = false;
  bool keep_history_ = false;
  bool after_gap_ = false;  // the current estimate is the first after a gap
  std::vector<Estimate> history_;
};

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_POSE_EKF_H_
