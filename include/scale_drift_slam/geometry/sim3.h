#pragma once
// Sim(3): similarities S = [s R t; 0 1], x' = s R x + t, with s = exp(sigma) and sigma stored.
// Tangent vector (omega, sigma, upsilon) in R^7 (doc/algorithm.md, "Lie groups"):
//   exp(omega, sigma, upsilon) = [e^sigma exp_SO3(omega), W upsilon; 0 1],
//   W = integral_0^1 e^(t sigma) exp_SO3(t omega) dt = a I + b [w]x + c [w]x^2.
// Updates are left-multiplied, S <- exp(delta) S. Templated on the scalar for Ceres autodiff.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::geometry {

namespace internal {

/// M_k(sigma) = integral_0^1 t^k e^(t sigma) dt for k = 0..6. A power series for moderate sigma
/// (the closed form cancels badly near 0), the stable upward recursion for large |sigma|.
template <typename T>
void expMoments(const T& sigma, T* moments) {
  using std::abs;
  using std::exp;
  if (abs(sigma) < T(4)) {
    // M_k = sum_n sigma^n / (n! (n + k + 1)); 4^45/45! < 1e-28. The sum stops once
    // |sigma|^n / n! < 1e-20 (and n >= 5): the dropped terms, and their derivatives
    // (n / sigma) sigma^n / n! for autodiff, are then below 1e-17 of M_k >= e^-4 / 7.
    for (int k = 0; k <= 6; ++k) {
      moments[k] = T(0);
    }
    T term = T(1);  // sigma^n / n!
    for (int n = 0; n < 45; ++n) {
      if (n >= 5 && abs(term) < T(1e-20)) {
        break;
      }
      for (int k = 0; k <= 6; ++k) {
        moments[k] += term / T(n + k + 1);
      }
      term = term * sigma / T(n + 1);
    }
    return;
  }
  const T e = exp(sigma);
  moments[0] = (e - T(1)) / sigma;
  for (int k = 1; k <= 6; ++k) {
    moments[k] = (e - T(k) * moments[k - 1]) / sigma;
  }
}

/// The coefficients (a, b, c) of W for the rotation vector omega and the log-scale sigma.
template <typename T>
Eigen::Matrix<T, 3, 1> sim3WCoefficients(const Vec3<T>& omega, const T& sigma) {
  using std::abs;
  using std::cos;
  using std::exp;
  using std::sin;
  using std::sqrt;
  const T theta_sq = omega.squaredNorm();
  if (theta_sq < T(1e-4)) {
    // sin(t x)/x and (1 - cos(t x))/x^2 to order x^4; the x^6 terms are below 1e-16.
    T m[7];
    expMoments(sigma, m);
    const T a = m[0];
    const T b = m[1] - theta_sq / T(6) * m[3] + theta_sq * theta_sq / T(120) * m[5];
    const T c = m[2] / T(2) - theta_sq / T(24) * m[4] + theta_sq * theta_sq / T(720) * m[6];
    return Eigen::Matrix<T, 3, 1>(a, b, c);
  }
  T a;
  if (abs(sigma) < T(1e-3)) {
    a = T(1) + sigma / T(2) + sigma * sigma / T(6) + sigma * sigma * sigma / T(24) +
        sigma * sigma * sigma * sigma / T(120);
  } else {
    a = (exp(sigma) - T(1)) / sigma;
  }
  // The closed forms of doc/algorithm.md; regular at sigma = 0 once theta is not small.
  const T theta = sqrt(theta_sq);
  const T A = exp(sigma) * sin(theta);
  // 1 - B = 1 - e^sigma cos(theta) = (1 - e^sigma) + 2 e^sigma sin^2(theta/2), free of the
  // cancellation of 1 - cos(theta) at small angles.
  const T half_sin = sin(theta / T(2));
  const T one_minus_B = -(a * sigma) + T(2) * exp(sigma) * half_sin * half_sin;
  const T B = T(1) - one_minus_B;
  const T denom = sigma * sigma + theta_sq;
  const T b = (A * sigma + one_minus_B * theta) / (theta * denom);
  const T c = (a - ((B - T(1)) * sigma + A * theta) / denom) / theta_sq;
  return Eigen::Matrix<T, 3, 1>(a, b, c);
}

template <typename T>
Mat3<T> sim3W(const Vec3<T>& omega, const T& sigma) {
  const Eigen::Matrix<T, 3, 1> abc = sim3WCoefficients(omega, sigma);
  const Mat3<T> W = hatSO3(omega);
  return Mat3<T>::Identity() * abc[0] + W * abc[1] + W * W * abc[2];
}

}  // namespace internal

/// A similarity transform. S_world_kf-style names: maps kf coordinates into world coordinates,
/// up to the scale. Used for keyframe poses in loop closure, where the scale is a free variable.
template <typename T>
class Sim3T {
 public:
  using Scalar = T;
  using Tangent = Eigen::Matrix<T, 7, 1>;
  using Matrix4 = Eigen::Matrix<T, 4, 4>;
  using Adjoint = Eigen::Matrix<T, 7, 7>;
  static constexpr int kNumParameters = 8;  ///< qx qy qz qw tx ty tz sigma (see data()).

  Sim3T() : q_(Eigen::Quaternion<T>::Identity()), t_(Vec3<T>::Zero()), sigma_(T(0)) {}
  Sim3T(const Eigen::Quaternion<T>& q, const Vec3<T>& t, const T& sigma)
      : q_(q.normalized()), t_(t), sigma_(sigma) {}
  /// A rigid transform as a similarity with s = 1.
  explicit Sim3T(const SE3T<T>& T_rigid) : Sim3T(T_rigid.rotation(), T_rigid.translation(), T(0)) {}

  static Sim3T identity() { return Sim3T(); }
  /// From rotation, translation and scale s > 0.
  static Sim3T fromScale(const Eigen::Quaternion<T>& q, const Vec3<T>& t, const T& scale) {
    using std::log;
    return Sim3T(q, t, log(scale));
  }

  static Sim3T fromData(const T* data) {
    return Sim3T(Eigen::Quaternion<T>(data[3], data[0], data[1], data[2]),
                 Vec3<T>(data[4], data[5], data[6]), data[7]);
  }
  void toData(T* data) const {
    data[0] = q_.x();
    data[1] = q_.y();
    data[2] = q_.z();
    data[3] = q_.w();
    data[4] = t_.x();
    data[5] = t_.y();
    data[6] = t_.z();
    data[7] = sigma_;
  }

  static Sim3T exp(const Tangent& xi) {
    const Vec3<T> omega = xi.template head<3>();
    const T sigma = xi[3];
    const Vec3<T> upsilon = xi.template tail<3>();
    return Sim3T(expSO3(omega), internal::sim3W(omega, sigma) * upsilon, sigma);
  }

  /// The inverse of exp: omega = log_SO3(R), sigma = log s, upsilon = W^-1 t.
  Tangent log() const {
    const Vec3<T> omega = logSO3(q_);
    const Mat3<T> W = internal::sim3W(omega, sigma_);
    Tangent xi;
    xi << omega, sigma_, W.inverse() * t_;
    return xi;
  }

  /// hat(omega, sigma, upsilon) = [[omega]x + sigma I, upsilon; 0 0].
  static Matrix4 hat(const Tangent& xi) {
    Matrix4 M = Matrix4::Zero();
    M.template topLeftCorner<3, 3>() =
        hatSO3<T>(xi.template head<3>()) + Mat3<T>::Identity() * xi[3];
    M.template topRightCorner<3, 1>() = xi.template tail<3>();
    return M;
  }
  static Tangent vee(const Matrix4& M) {
    Tangent xi;
    xi << veeSO3<T>(M.template topLeftCorner<3, 3>()),
        M.template topLeftCorner<3, 3>().trace() / T(3), M.template topRightCorner<3, 1>();
    return xi;
  }

  Sim3T inverse() const {
    using std::exp;
    const Eigen::Quaternion<T> q_inv = q_.conjugate();
    return Sim3T(q_inv, -(q_inv * t_) * exp(-sigma_), -sigma_);
  }
  Sim3T operator*(const Sim3T& other) const {
    return Sim3T(q_ * other.q_, (q_ * other.t_) * scale() + t_, sigma_ + other.sigma_);
  }
  Vec3<T> operator*(const Vec3<T>& x) const { return (q_ * x) * scale() + t_; }

  /// Adj_S with S exp(xi) S^-1 = exp(Adj_S xi):
  /// [[R, 0, 0], [0, 1, 0], [[t]x R, -t, s R]] in the (omega, sigma, upsilon) order.
  Adjoint adjoint() const {
    const Mat3<T> R = rotationMatrix();
    Adjoint A = Adjoint::Zero();
    A.template block<3, 3>(0, 0) = R;
    A(3, 3) = T(1);
    A.template block<3, 3>(4, 0) = hatSO3(t_) * R;
    A.template block<3, 1>(4, 3) = -t_;
    A.template block<3, 3>(4, 4) = R * scale();
    return A;
  }

  /// d(exp(delta) S x)/d(delta) at delta = 0, for y = S x: [-[y]x, y, I]. A 3x7 matrix.
  static Eigen::Matrix<T, 3, 7> actionJacobian(const Vec3<T>& y) {
    Eigen::Matrix<T, 3, 7> J;
    J << -hatSO3(y), y, Mat3<T>::Identity();
    return J;
  }

  Matrix4 matrix() const {
    Matrix4 M = Matrix4::Identity();
    M.template topLeftCorner<3, 3>() = rotationMatrix() * scale();
    M.template topRightCorner<3, 1>() = t_;
    return M;
  }

  /// The rigid pose with the same rotation and the translation divided by the scale, so that
  /// the camera centre is unchanged (doc/algorithm.md, "Loop closure correction").
  SE3T<T> toSE3() const {
    using std::exp;
    return SE3T<T>(q_, t_ * exp(-sigma_));
  }

  const Eigen::Quaternion<T>& rotation() const { return q_; }
  Mat3<T> rotationMatrix() const { return q_.toRotationMatrix(); }
  const Vec3<T>& translation() const { return t_; }
  T logScale() const { return sigma_; }
  T scale() const {
    using std::exp;
    return exp(sigma_);
  }

  template <typename U>
  Sim3T<U> cast() const {
    return Sim3T<U>(q_.template cast<U>(), t_.template cast<U>(), U(sigma_));
  }

 private:
  Eigen::Quaternion<T> q_;
  Vec3<T> t_;
  T sigma_;
};

using Sim3 = Sim3T<double>;

}  // namespace scale_drift_slam::geometry
