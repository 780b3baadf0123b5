// The per-track motion filters of the tracker, in the map frame's top view. The transition uses
// the real time difference, never an assumed rate.
//  - ConstantVelocityKalman (the original): X = [x, y, vx, vy], Z = [x, y, vx_meas, vy_meas]
//    (velocity from the last two measured positions).
//  - TurnImmKalman: an interacting multiple model of a constant-velocity and a coordinated-turn
//    mode over X = [x, y, vx, vy, omega], Z = [x, y]; it follows walkers through turns.
//  - TrackFilter: the one the tracker holds, either of the two as KalmanConfig::model says.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/status.hpp"

namespace dynamap {

/// Which motion filter a track runs.
enum class MotionModel : std::uint8_t {
  kConstantVelocity = 0,  ///< ConstantVelocityKalman, the original filter
  kTurnImm = 1,           ///< TurnImmKalman: constant velocity + coordinated turn
};

/// Parameters of TurnImmKalman beyond the shared P0 and R (docs/tracker.md, "Motion filter").
/// Process noises are continuous-time densities, so they do not depend on the frame rate.
struct ImmConfig {
  /// White-acceleration density of the straight (CV) mode (m^2/s^3): a walker on a straight line
  /// keeps its speed to within a few cm/s over a second.
  float q_accel_straight = 0.02f;
  /// White-acceleration density of the turn mode (m^2/s^3): speed changes around corners.
  float q_accel_turn = 0.1f;
  /// Turn-rate acceleration density of the turn mode (rad^2/s^3): a walker entering a rounded
  /// corner goes from 0 to 2-4 rad/s within about half a second (omega-dot ~8 rad/s^2:
  /// 8^2 * 0.5 = 32).
  float q_turn_rate = 32.0f;
  /// Initial turn-rate variance (rad^2/s^2): a new track may already be turning.
  float p0_turn_rate = 1.0f;
  /// |omega| is clamped here (rad/s): one full turn per second is beyond any walker, and the
  /// clamp keeps a noisy far track from spinning the prediction.
  float max_turn_rate = 6.2832f;
  /// Expected time in the straight mode before the turn mode takes over (s). The turn mode
  /// contains straight motion too (omega = 0), so the chain leaves the low-noise straight mode
  /// quickly unless the measurements keep confirming it; a walker starts turning within a step.
  float mean_straight_time = 0.5f;
  /// Expected time in the turn mode (s): indoor walkers turn every few metres.
  float mean_turn_time = 3.0f;

  /// kOk when every value is positive and finite.
  Status validate() const noexcept;
};

/// Noise model of ConstantVelocityKalman. Q is given per `q_reference_dt` seconds and scaled by
/// dt / q_reference_dt, so irregular frame intervals add proportionally more or less uncertainty.
/// The defaults model the detector's measured centre noise (σ ≈ 1.6 cm) at 30 Hz and walkers'
/// turns (docs/tracker.md, "Motion filter"); for 5 cm detections see the same section;
/// `original()` gives the original code's P0 = 0.3 I, Q = 0.002 I, R = 0.3 I.
struct KalmanConfig {
  float p0_position = 0.3f;             ///< initial position variance (m^2)
  float p0_velocity = 1.0f;             ///< initial velocity variance ((m/s)^2): starts at v = 0
  float q_position = 1e-5f;             ///< position process noise per reference interval (m^2)
  float q_velocity = 5e-3f;             ///< velocity process noise per reference interval ((m/s)^2)
  float r_position = 2.5e-4f;           ///< position measurement variance (m^2), 1.6 cm std
  float r_velocity = 0.45f;             ///< velocity measurement variance: 2 σ^2 / dt^2 at 30 Hz
  float q_reference_dt = 1.0f / 30.0f;  ///< seconds that q_position / q_velocity refer to
  /// The filter the tracker runs. The constant-velocity filter lags every turn (docs/tracker.md);
  /// the IMM uses p0_position, p0_velocity and r_position from above and its own `imm` noises.
  MotionModel model = MotionModel::kTurnImm;
  ImmConfig imm{};

  /// The original implementation's constants (per frame at 30 Hz) and its CV filter.
  static constexpr KalmanConfig original() noexcept {
    KalmanConfig c;
    c.model = MotionModel::kConstantVelocity;
    c.p0_position = c.p0_velocity = 0.3f;
    c.q_position = c.q_velocity = 0.002f;
    c.r_position = c.r_velocity = 0.3f;
    return c;
  }
  /// kOk when every variance is positive and finite and the model is known.
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
  /// Moves the position estimate by d (a change of the measurement's reference point); the
  /// covariance is unchanged.
  void shift_position(const Eigen::Vector2f& d) noexcept { x_.head<2>() += d; }
  /// Replaces the velocity estimate by v; the covariance is unchanged.
  void set_velocity(const Eigen::Vector2f& v) noexcept { x_.tail<2>() = v; }

  const Eigen::Vector4f& state() const noexcept { return x_; }
  const Eigen::Matrix4f& covariance() const noexcept { return p_; }
  Eigen::Vector2f position() const noexcept { return x_.head<2>(); }
  Eigen::Vector2f velocity() const noexcept { return x_.tail<2>(); }

 private:
  KalmanConfig config_{};
  Eigen::Vector4f x_ = Eigen::Vector4f::Zero();
  Eigen::Matrix4f p_ = Eigen::Matrix4f::Identity();
};

/// Interacting multiple model filter (Blom and Bar-Shalom) of two modes over the state
/// X = [x, y, vx, vy, omega]: straight (constant velocity, omega held at 0) and coordinated turn
/// (velocity rotating at omega, an extended Kalman filter). Each predict mixes the two mode
/// estimates by the Markov switching probabilities over dt; each update weighs the modes by the
/// likelihood of the measured position. Position-only measurement: the two-point velocity the
/// CV filter takes is a difference of the same positions, so it adds no information.
class TurnImmKalman {
 public:
  using State = Eigen::Matrix<float, 5, 1>;
  using Covariance = Eigen::Matrix<float, 5, 5>;
  static constexpr int kModes = 2;  ///< 0 = straight, 1 = turn

  /// Starts at [x, y, vx, vy] with omega = 0, covariance P0 and the stationary mode probabilities.
  void reset(const Eigen::Vector4f& state, const KalmanConfig& config) noexcept;
  /// Mixing and per-mode prediction. kInvalidArgument (nothing changes) unless 0 < dt finite.
  [[nodiscard]] Status predict(float dt) noexcept;
  /// Position update with R = noise_scale * r_position. kNonFinite (nothing changes) for a
  /// NaN/inf measurement, kInvalidArgument for noise_scale not positive and finite.
  [[nodiscard]] Status update(const Eigen::Vector2f& z, float noise_scale = 1.f) noexcept;
  /// Moves the position estimate of both modes by d; covariances and mode probabilities unchanged.
  void shift_position(const Eigen::Vector2f& d) noexcept;
  /// Replaces the velocity of both modes by v and the turn mode's rate by 0 (straight on);
  /// the modes' covariances and probabilities unchanged (the combined covariance loses the
  /// modes' spread).
  void set_velocity(const Eigen::Vector2f& v) noexcept;

  /// Combined (probability-weighted) estimate.
  const State& state() const noexcept { return x_; }
  const Covariance& covariance() const noexcept { return p_; }
  Eigen::Vector2f position() const noexcept { return x_.head<2>(); }
  Eigen::Vector2f velocity() const noexcept { return x_.segment<2>(2); }
  float turn_rate() const noexcept { return x_(4); }
  /// Probability of the turn mode.
  float turn_probability() const noexcept { return mu_(1); }

 private:
  void combine() noexcept;

  KalmanConfig config_{};
  std::array<State, kModes> xm_{};
  std::array<Covariance, kModes> pm_{};
  Eigen::Vector2f mu_ = Eigen::Vector2f(0.5f, 0.5f);
  State x_ = State::Zero();
  Covariance p_ = Covariance::Identity();
};

/// The tracker's per-track filter: the model chosen by KalmanConfig::model, one interface.
class TrackFilter {
 public:
  void reset(const Eigen::Vector4f& state, const KalmanConfig& config) noexcept;
  [[nodiscard]] Status predict(float dt) noexcept;
  /// z = [x, y, vx_meas, vy_meas]; the IMM uses the position only.
  [[nodiscard]] Status update(const Eigen::Vector4f& z, float noise_scale = 1.f) noexcept;
  /// Moves the position estimate by d (finite), covariance unchanged.
  void shift_position(const Eigen::Vector2f& d) noexcept;
  /// Replaces the velocity estimate by v (finite); the filter's (or the modes') covariance
  /// unchanged.
  void set_velocity(const Eigen::Vector2f& v) noexcept;
  Eigen::Vector2f position() const noexcept;
  Eigen::Vector2f velocity() const noexcept;
  /// Covariance of velocity() ((m/s)^2): the filter's own, combined over the IMM's modes.
  Eigen::Matrix2f velocity_covariance() const noexcept;
  MotionModel model() const noexcept { return model_; }
  const ConstantVelocityKalman& cv() const noexcept { return cv_; }
  const TurnImmKalman& imm() const noexcept { return imm_; }

 private:
  MotionModel model_ = MotionModel::kConstantVelocity;
  ConstantVelocityKalman cv_;
  TurnImmKalman imm_;
};

}  // namespace dynamap
