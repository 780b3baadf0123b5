#include "dynamap/kalman_filter.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace dynamap {

namespace {
bool positive_finite(float v) noexcept {
  return std::isfinite(v) && v > 0.f;
}
}  // namespace

Status KalmanConfig::validate() const noexcept {
  const bool good = positive_finite(p0_position) && positive_finite(p0_velocity) &&
                    positive_finite(q_position) && positive_finite(q_velocity) &&
                    positive_finite(r_position) && positive_finite(r_velocity) &&
                    positive_finite(q_reference_dt);
  return good ? Status::kOk : Status::kInvalidArgument;
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

}  // namespace dynamap
