#pragma once
// SE(3): rigid transforms T = [R t; 0 1], x' = R x + t. Tangent vector (omega, upsilon) in R^6,
// rotation first. Updates are left-multiplied: T <- exp(delta) T (doc/algorithm.md, "Lie
// groups"). Templated on the scalar for Ceres autodiff; SE3 is the double instance.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::geometry {

/// A rigid transform with a unit-quaternion rotation. Names carry frames: T_cam_world maps world
/// points into the camera frame.
template <typename T>
class SE3T {
 public:
  using Scalar = T;
  using Tangent = Eigen::Matrix<T, 6, 1>;
  using Matrix4 = Eigen::Matrix<T, 4, 4>;
  using Adjoint = Eigen::Matrix<T, 6, 6>;
  static constexpr int kNumParameters = 7;  ///< qx qy qz qw tx ty tz (see data()).

  SE3T() : q_(Eigen::Quaternion<T>::Identity()), t_(Vec3<T>::Zero()) {}
  SE3T(const Eigen::Quaternion<T>& q, const Vec3<T>& t) : q_(q.normalized()), t_(t) {}
  SE3T(const Mat3<T>& R, const Vec3<T>& t) : q_(Eigen::Quaternion<T>(R).normalized()), t_(t) {}

  static SE3T identity() { return SE3T(); }

  /// From the 7 numbers qx qy qz qw tx ty tz (the layout of a Ceres parameter block).
  static SE3T fromData(const T* data) {
    return SE3T(Eigen::Quaternion<T>(data[3], data[0], data[1], data[2]),
                Vec3<T>(data[4], data[5], data[6]));
  }
  void toData(T* data) const {
    data[0] = q_.x();
    data[1] = q_.y();
    data[2] = q_.z();
    data[3] = q_.w();
    data[4] = t_.x();
    data[5] = t_.y();
    data[6] = t_.z();
  }

  /// exp(omega, upsilon) = [exp_SO3(omega), V upsilon; 0 1],
  /// V = I + (1 - cos theta)/theta^2 [w]x + (theta - sin theta)/theta^3 [w]x^2.
  static SE3T exp(const Tangent& xi) {
    const Vec3<T> omega = xi.template head<3>();
    const Vec3<T> upsilon = xi.template tail<3>();
    return SE3T(expSO3(omega), leftJacobianSO3(omega) * upsilon);
  }

  /// The inverse of exp: omega = log_SO3(R), upsilon = V^-1 t.
  Tangent log() const {
    const Vec3<T> omega = logSO3(q_);
    Tangent xi;
    xi << omega, inverseLeftJacobianSO3(omega) * t_;
    return xi;
  }

  /// hat(omega, upsilon) = [[omega]x upsilon; 0 0].
  static Matrix4 hat(const Tangent& xi) {
    Matrix4 M = Matrix4::Zero();
    M.template topLeftCorner<3, 3>() = hatSO3<T>(xi.template head<3>());
    M.template topRightCorner<3, 1>() = xi.template tail<3>();
    return M;
  }
  static Tangent vee(const Matrix4& M) {
    Tangent xi;
    xi << veeSO3<T>(M.template topLeftCorner<3, 3>()), M.template topRightCorner<3, 1>();
    return xi;
  }

  SE3T inverse() const {
    const Eigen::Quaternion<T> q_inv = q_.conjugate();
    return SE3T(q_inv, -(q_inv * t_));
  }
  SE3T operator*(const SE3T& other) const { return SE3T(q_ * other.q_, q_ * other.t_ + t_); }
  Vec3<T> operator*(const Vec3<T>& x) const { return q_ * x + t_; }

  /// Adj_T with T exp(xi) T^-1 = exp(Adj_T xi): [[R, 0], [[t]x R, R]].
  Adjoint adjoint() const {
    const Mat3<T> R = rotationMatrix();
    Adjoint A = Adjoint::Zero();
    A.template topLeftCorner<3, 3>() = R;
    A.template bottomLeftCorner<3, 3>() = hatSO3(t_) * R;
    A.template bottomRightCorner<3, 3>() = R;
    return A;
  }

  /// d(exp(delta) T x)/d(delta) at delta = 0, for y = T x: [-[y]x, I]. A 3x6 matrix.
  static Eigen::Matrix<T, 3, 6> actionJacobian(const Vec3<T>& y) {
    Eigen::Matrix<T, 3, 6> J;
    J << -hatSO3(y), Mat3<T>::Identity();
    return J;
  }

  Matrix4 matrix() const {
    Matrix4 M = Matrix4::Identity();
    M.template topLeftCorner<3, 3>() = rotationMatrix();
    M.template topRightCorner<3, 1>() = t_;
    return M;
  }
  Eigen::Matrix<T, 3, 4> matrix3x4() const { return matrix().template topRows<3>(); }

  const Eigen::Quaternion<T>& rotation() const { return q_; }
  Mat3<T> rotationMatrix() const { return q_.toRotationMatrix(); }
  const Vec3<T>& translation() const { return t_; }
  Vec3<T>& translation() { return t_; }
  void setRotation(const Eigen::Quaternion<T>& q) { q_ = q.normalized(); }

  /// For a camera pose T_cam_world: the camera centre in the world, -R^T t.
  Vec3<T> inverseTranslation() const { return -(q_.conjugate() * t_); }

  template <typename U>
  SE3T<U> cast() const {
    return SE3T<U>(q_.template cast<U>(), t_.template cast<U>());
  }

  /// V(omega) of exp above; also the left Jacobian of SO(3). 1 - cos(theta) is computed as
  /// 2 sin^2(theta/2) to avoid cancellation; below theta^2 = 1e-4 the Taylor series is exact to
  /// 1e-16.
  static Mat3<T> leftJacobianSO3(const Vec3<T>& omega) {
    using std::sin;
    using std::sqrt;
    const T theta_sq = omega.squaredNorm();
    const Mat3<T> W = hatSO3(omega);
    if (theta_sq < T(1e-4)) {
      return Mat3<T>::Identity() + W * (T(0.5) - theta_sq / T(24) + theta_sq * theta_sq / T(720)) +
             W * W * (T(1) / T(6) - theta_sq / T(120) + theta_sq * theta_sq / T(5040));
    }
    const T theta = sqrt(theta_sq);
    const T half_sin = sin(theta / T(2));
    return Mat3<T>::Identity() + W * (T(2) * half_sin * half_sin / theta_sq) +
           W * W * ((theta - sin(theta)) / (theta_sq * theta));
  }

  /// V(omega)^-1 = I - 1/2 [w]x + (1 - (theta/2) cot(theta/2)) / theta^2 [w]x^2.
  static Mat3<T> inverseLeftJacobianSO3(const Vec3<T>& omega) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T theta_sq = omega.squaredNorm();
    const Mat3<T> W = hatSO3(omega);
    if (theta_sq < T(1e-4)) {
      return Mat3<T>::Identity() - W * T(0.5) +
             W * W * (T(1) / T(12) + theta_sq / T(720) + theta_sq * theta_sq / T(30240));
    }
    const T theta = sqrt(theta_sq);
    const T half = theta / T(2);
    const T c = (T(1) - half * cos(half) / sin(half)) / theta_sq;
    return Mat3<T>::Identity() - W * T(0.5) + W * W * c;
  }

 private:
  Eigen::Quaternion<T> q_;
  Vec3<T> t_;
};

using SE3 = SE3T<double>;

}  // namespace scale_drift_slam::geometry
