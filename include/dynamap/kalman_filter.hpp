// ConstantVelocityKalman: the per-track Kalman filter of the tracker, in the map frame's top view.
// State X = [x, y, vx, vy]; measurement Z = [x, y, vx_meas, vy_meas] (velocity from the last two
// measured positions). The transition uses the real time difference, never an assumed rate.
#pragma once

#include <Eigen/Core>

#include "dynamap/status.hpp"

namespace dynamap {

/// Noise model of ConstantVelocityKalman. Q is given per `q_reference_dt` seconds and scaled by
/// dt / q_reference_dt, so irregular frame intervals add proportionally more or less uncertainty.
/// The defaults are tuned for σ ≈ 5 cm position noise at 30 Hz (see docs/tracker.md);
/// `original()` gives the original code's P0 = 0.3 I, Q = 0.002 I, R = 0.3 I.
struct KalmanConfig {
  float p0_position = 0.3f;             ///< initial position variance (m^2)
  float p0_velocity = 1.0f;             ///< initial velocity variance ((m/s)^2): starts at v = 0
  float q_position = 1e-5f;             ///< position process noise per reference interval (m^2)
  float q_velocity = 5e-3f;             ///< velocity process noise per reference interval ((m/s)^2)
  float r_position = 2.5e-4f;           ///< position measurement variance (m^2), 1.6 cm std
  float r_velocity = 0.45f;             ///< velocity measurement variance: 2 σ^2 / dt^2 at 30 Hz
  float q_reference_dt = 1.0f / 30.0f;  ///< seconds that q_position / q_velocity refer to

  /// The original implementation's constants (per frame at 30 Hz).
  static constexpr KalmanConfig original() noexcept {
    KalmanConfig c;
    c.p0_position = c.p0_velocity = 0.3f;
    c.q_position = c.q_velocity = 0.002f;
    c.r_position = c.r_velocity = 0.3f;
    return c;
  }
  /// kOk when every variance is positive and finite.
  Status validate() const noexcept;
};

class ConstantVelocityKalman {
 public:
  /// Starts at `state` with covariance P0 from `config` (config must be valid).
  void reset(const Eigen::Vector4f& state, const KalmanConfig& config) noexcept;
  /// X = A(dt) X, P = A P A^T + Q(dt). kInvalidArgument (nothing changes) unless 0 < dt finite.
  [[nodiscard]] Status predict(float dt) noexcept;
  /// Measurement update with H = I and R = noise_scale * R_config (a noisier measurement, e.g.
  /// a far one, gets noise_scale > 1). kNonFinite (nothing changes) for a NaN/inf measurement,
  /// kInvalidArgument for noise_scale not positive and finite.
  [[nodiscard]] Status update(const Eigen::Vector4f& z, float noise_scale = 1.f) noexcept;
  /// State X as predict(dt) would make it, without changing the filter.
  Eigen::Vector4f predicted(float dt) const noexcept;

  const Eigen::Vector4f& state() const noexcept { return x_; }
  const Eigen::Matrix4f& covariance() const noexcept { return p_; }
  Eigen::Vector2f position() const noexcept { return x_.head<2>(); }
  Eigen::Vector2f velocity() const noexcept { return x_.tail<2>(); }

 private:
  KalmanConfig config_{};
  Eigen::Vector4f x_ = Eigen::Vector4f::Zero();
  Eigen::Matrix4f p_ = Eigen::Matrix4f::Identity();
};

}  // namespace dynamap
