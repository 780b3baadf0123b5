#include "dynamap/track/kalman_filter.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "dynamap/track/track_params.hpp"

namespace dynamap {

Status ImmConfig::validate() const noexcept {
  return all_in_range(*this, params::kImm) ? Status::kOk : Status::kInvalidArgument;
}

Status KalmanConfig::validate() const noexcept {
  return all_in_range(*this, params::kKalman) && ok(imm.validate()) ? Status::kOk
                                                                    : Status::kInvalidArgument;
}

void ConstantVelocityKalman::reset(const Eigen::Vector4f& state,
                                   const KalmanConfig& config) noexcept {
  config_ = config;
  x_ = state;
  p_.setZero();
  p_.diagonal() << config.p0_position, config.p0_position, config.p0_velocity, config.p0_velocity;
}

Eigen::Vector4f ConstantVelocityKalman::predicted(float dt) const noexcept {
  Eigen::Vector4f x = x_;
  x.head<2>() += dt * x_.tail<2>();
  return x;
}

Status ConstantVelocityKalman::predict(float dt) noexcept {
  if (!(dt > 0.f) || !std::isfinite(dt)) return Status::kInvalidArgument;
  Eigen::Matrix4f a = Eigen::Matrix4f::Identity();
  a(0, 2) = dt;
  a(1, 3) = dt;
  const float scale = dt / config_.q_reference_dt;
  x_ = a * x_;
  p_ = a * p_ * a.transpose();
  p_(0, 0) += scale * config_.q_position;
  p_(1, 1) += scale * config_.q_position;
  p_(2, 2) += scale * config_.q_velocity;
  p_(3, 3) += scale * config_.q_velocity;
  return Status::kOk;
}

Status ConstantVelocityKalman::update(const Eigen::Vector4f& z, float noise_scale) noexcept {
  if (!z.allFinite()) return Status::kNonFinite;
  if (!std::isfinite(noise_scale) || noise_scale <= 0.f) return Status::kInvalidArgument;
  Eigen::Matrix4f r = Eigen::Matrix4f::Zero();
  r.diagonal() << config_.r_position, config_.r_position, config_.r_velocity, config_.r_velocity;
  r *= noise_scale;
  const Eigen::Matrix4f s = p_ + r;
  // K = P S^-1; S is symmetric positive definite, so solve with Cholesky (fixed size, no heap).
  const Eigen::Matrix4f k = s.llt().solve(p_).transpose();
  x_ += k * (z - x_);
  // Joseph form keeps P symmetric positive definite in float.
  const Eigen::Matrix4f i_k = Eigen::Matrix4f::Identity() - k;
  p_ = i_k * p_ * i_k.transpose() + k * r * k.transpose();
  return Status::kOk;
}

namespace {

using State5 = TurnImmKalman::State;
using Cov5 = TurnImmKalman::Covariance;

/// White-acceleration noise of density q on the position/velocity blocks of both axes.
void add_acceleration_noise(float q, float dt, Cov5* p) noexcept {
  const float dt2 = dt * dt;
  const float pp = q * dt2 * dt / 3.f, pv = q * dt2 / 2.f, vv = q * dt;
  for (int a = 0; a < 2; ++a) {
    (*p)(a, a) += pp;
    (*p)(a, a + 2) += pv;
    (*p)(a + 2, a) += pv;
    (*p)(a + 2, a + 2) += vv;
  }
}

/// Straight mode: constant velocity, omega forced to 0 (its variance is the noise added below).
void predict_straight(float dt, State5* x, Cov5* p) noexcept {
  Cov5 f = Cov5::Identity();
  f(0, 2) = dt;
  f(1, 3) = dt;
  f(4, 4) = 0.f;
  *x = f * *x;
  *p = f * *p * f.transpose();
}

/// Coordinated turn: the velocity rotates at omega; f(x) and its Jacobian, with the omega -> 0
/// limits (Taylor terms) where the divisions by omega lose precision.
void predict_turn(float dt, State5* x, Cov5* p) noexcept {
  const float vx = (*x)(2), vy = (*x)(3), w = (*x)(4);
  const float wt = w * dt;
  const float s = std::sin(wt), c = std::cos(wt);
  float a, b, da, db;  // a = sin(wt)/w, b = (1 - cos(wt))/w and their derivatives by w
  if (std::fabs(wt) < 1e-3f) {
    a = dt;
    b = 0.5f * w * dt * dt;
    da = -w * dt * dt * dt / 3.f;
    db = 0.5f * dt * dt;
  } else {
    a = s / w;
    b = (1.f - c) / w;
    da = (dt * c - a) / w;
    db = (dt * s - b) / w;
  }
  Cov5 f = Cov5::Identity();
  f(0, 2) = a;
  f(0, 3) = -b;
  f(1, 2) = b;
  f(1, 3) = a;
  f(2, 2) = c;
  f(2, 3) = -s;
  f(3, 2) = s;
  f(3, 3) = c;
  f(0, 4) = da * vx - db * vy;
  f(1, 4) = db * vx + da * vy;
  f(2, 4) = -dt * (s * vx + c * vy);
  f(3, 4) = dt * (c * vx - s * vy);
  State5 next = *x;
  next(0) += a * vx - b * vy;
  next(1) += b * vx + a * vy;
  next(2) = c * vx - s * vy;
  next(3) = s * vx + c * vy;
  *x = next;
  *p = f * *p * f.transpose();
}

}  // namespace

void TurnImmKalman::reset(const Eigen::Vector4f& state, const KalmanConfig& config) noexcept {
  config_ = config;
  State x;
  x << state, 0.f;
  Covariance p = Covariance::Zero();
  p.diagonal() << config.p0_position, config.p0_position, config.p0_velocity, config.p0_velocity,
      config.imm.p0_turn_rate;
  for (int m = 0; m < kModes; ++m) {
    xm_[m] = x;
    pm_[m] = p;
  }
  const float ts = config.imm.mean_straight_time, tt = config.imm.mean_turn_time;
  mu_ = Eigen::Vector2f(ts / (ts + tt), tt / (ts + tt));  // stationary distribution of the chain
  combine();
}

void TurnImmKalman::combine() noexcept {
  x_ = mu_(0) * xm_[0] + mu_(1) * xm_[1];
  p_.setZero();
  for (int m = 0; m < kModes; ++m) {
    const State d = xm_[m] - x_;
    p_ += mu_(m) * (pm_[m] + d * d.transpose());
  }
}

Status TurnImmKalman::predict(float dt) noexcept {
  if (!(dt > 0.f) || !std::isfinite(dt)) return Status::kInvalidArgument;
  const ImmConfig& c = config_.imm;
  // Switching probabilities over dt of a continuous-time two-state Markov chain (approximated
  // per step by the exponential sojourn times).
  const float to_turn = 1.f - std::exp(-dt / c.mean_straight_time);
  const float to_straight = 1.f - std::exp(-dt / c.mean_turn_time);
  Eigen::Matrix2f pi;  // pi(i, j): from mode i to mode j
  pi << 1.f - to_turn, to_turn, to_straight, 1.f - to_straight;
  // Mixing: each mode starts from the estimates of both, weighted by where it came from.
  const Eigen::Vector2f predicted_mu = pi.transpose() * mu_;
  std::array<State, kModes> x0;
  std::array<Covariance, kModes> p0;
  for (int j = 0; j < kModes; ++j) {
    const float cj = std::max(predicted_mu(j), 1e-12f);
    x0[j].setZero();
    for (int i = 0; i < kModes; ++i) x0[j] += (pi(i, j) * mu_(i) / cj) * xm_[i];
    p0[j].setZero();
    for (int i = 0; i < kModes; ++i) {
      const State d = xm_[i] - x0[j];
      p0[j] += (pi(i, j) * mu_(i) / cj) * (pm_[i] + d * d.transpose());
    }
  }
  predict_straight(dt, &x0[0], &p0[0]);
  add_acceleration_noise(c.q_accel_straight, dt, &p0[0]);
  p0[0](4, 4) += c.q_turn_rate * dt;
  predict_turn(dt, &x0[1], &p0[1]);
  add_acceleration_noise(c.q_accel_turn, dt, &p0[1]);
  p0[1](4, 4) += c.q_turn_rate * dt;
  for (int m = 0; m < kModes; ++m) {
    x0[m](4) = std::clamp(x0[m](4), -c.max_turn_rate, c.max_turn_rate);
    xm_[m] = x0[m];
    pm_[m] = p0[m];
  }
  mu_ = predicted_mu / predicted_mu.sum();
  combine();
  return Status::kOk;
}

Status TurnImmKalman::update(const Eigen::Vector2f& z, float noise_scale) noexcept {
  if (!z.allFinite()) return Status::kNonFinite;
  if (!std::isfinite(noise_scale) || noise_scale <= 0.f) return Status::kInvalidArgument;
  const float r = noise_scale * config_.r_position;
  std::array<float, kModes> log_likelihood{};
  for (int m = 0; m < kModes; ++m) {
    const Eigen::Vector2f nu = z - xm_[m].head<2>();
    Eigen::Matrix2f s = pm_[m].topLeftCorner<2, 2>();
    s(0, 0) += r;
    s(1, 1) += r;
    const Eigen::Matrix2f s_inv = s.inverse();  // 2 x 2, closed form
    const Eigen::Matrix<float, 5, 2> k = pm_[m].leftCols<2>() * s_inv;
    xm_[m] += k * nu;
    xm_[m](4) = std::clamp(xm_[m](4), -config_.imm.max_turn_rate, config_.imm.max_turn_rate);
    // Joseph form with H = [I 0]: (I - K H) P (I - K H)^T + r K K^T.
    Covariance i_kh = Covariance::Identity();
    i_kh.leftCols<2>() -= k;
    pm_[m] = i_kh * pm_[m] * i_kh.transpose() + r * k * k.transpose();
    log_likelihood[m] =
        -0.5f * nu.dot(s_inv * nu) - 0.5f * std::log(std::max(s.determinant(), 1e-30f));
  }
  // Mode probabilities from the likelihoods, in the log domain so neither underflows.
  const float top = std::max(log_likelihood[0], log_likelihood[1]);
  Eigen::Vector2f w;
  for (int m = 0; m < kModes; ++m) w(m) = mu_(m) * std::exp(log_likelihood[m] - top);
  const float sum = w.sum();
  if (sum > 0.f && std::isfinite(sum)) mu_ = w / sum;
  // Neither mode may die out: the chain must be able to switch back within a frame or two.
  mu_ = mu_.cwiseMax(1e-4f);
  mu_ /= mu_.sum();
  combine();
  return Status::kOk;
}

void TurnImmKalman::shift_position(const Eigen::Vector2f& d) noexcept {
  for (int m = 0; m < kModes; ++m) xm_[m].head<2>() += d;
  x_.head<2>() += d;
}

void TurnImmKalman::set_velocity(const Eigen::Vector2f& v) noexcept {
  for (int m = 0; m < kModes; ++m) {
    xm_[m].segment<2>(2) = v;
    xm_[m](4) = 0.f;
  }
  combine();
}

void TrackFilter::set_velocity(const Eigen::Vector2f& v) noexcept {
  if (model_ == MotionModel::kTurnImm) {
    imm_.set_velocity(v);
  } else {
    cv_.set_velocity(v);
  }
}

void TrackFilter::shift_position(const Eigen::Vector2f& d) noexcept {
  if (model_ == MotionModel::kTurnImm) {
    imm_.shift_position(d);
  } else {
    cv_.shift_position(d);
  }
}

void TrackFilter::reset(const Eigen::Vector4f& state, const KalmanConfig& config) noexcept {
  model_ = config.model;
  if (model_ == MotionModel::kTurnImm) {
    imm_.reset(state, config);
  } else {
    cv_.reset(state, config);
  }
}

Status TrackFilter::predict(float dt) noexcept {
  return model_ == MotionModel::kTurnImm ? imm_.predict(dt) : cv_.predict(dt);
}

Status TrackFilter::update(const Eigen::Vector4f& z, float noise_scale) noexcept {
  if (model_ == MotionModel::kTurnImm) {
    // The velocity part must be finite too, so both filters refuse the same inputs.
    if (!z.allFinite()) return Status::kNonFinite;
    return imm_.update(z.head<2>(), noise_scale);
  }
  return cv_.update(z, noise_scale);
}

Eigen::Vector2f TrackFilter::position() const noexcept {
  return model_ == MotionModel::kTurnImm ? imm_.position() : cv_.position();
}

Eigen::Vector2f TrackFilter::velocity() const noexcept {
  return model_ == MotionModel::kTurnImm ? imm_.velocity() : cv_.velocity();
}

Eigen::Matrix2f TrackFilter::velocity_covariance() const noexcept {
  return model_ == MotionModel::kTurnImm ? Eigen::Matrix2f(imm_.covariance().block<2, 2>(2, 2))
                                         : Eigen::Matrix2f(cv_.covariance().block<2, 2>(2, 2));
}

}  // namespace dynamap
