#pragma once
// Rotations: the SO(3) exponential and logarithm on unit quaternions, templated on the scalar so
// that Ceres autodiff (ceres::Jet) flows through them. Formulas: doc/algorithm.md, "Lie groups".

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace scale_drift_slam::geometry {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

/// Below this squared angle (or squared sigma) the closed forms are replaced by Taylor series.
/// The truncation error of the series used is then below 1e-16 relative.
constexpr double kSmallAngleSq = 1e-10;

/// [w]x: the skew-symmetric matrix with [w]x v = w x v.
template <typename T>
Mat3<T> hatSO3(const Vec3<T>& w) {
  Mat3<T> W;
  W << T(0), -w.z(), w.y(), w.z(), T(0), -w.x(), -w.y(), w.x(), T(0);
  return W;
}

/// The inverse of hatSO3 (reads the skew-symmetric part).
template <typename T>
Vec3<T> veeSO3(const Mat3<T>& W) {
  return Vec3<T>(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1)) * T(0.5);
}

/// exp_SO3(omega) as a unit quaternion: (cos(theta/2), sin(theta/2) omega/theta).
template <typename T>
Eigen::Quaternion<T> expSO3(const Vec3<T>& omega) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_sq = omega.squaredNorm();
  if (theta_sq < T(kSmallAngleSq)) {
    // cos(x/2) = 1 - x^2/8, sin(x/2)/x = 1/2 - x^2/48.
    const T real = T(1) - theta_sq / T(8);
    const T imag_factor = T(0.5) - theta_sq / T(48);
    return Eigen::Quaternion<T>(real, imag_factor * omega.x(), imag_factor * omega.y(),
                                imag_factor * omega.z());
  }
  const T theta = sqrt(theta_sq);
  const T half = theta / T(2);
  const T imag_factor = sin(half) / theta;
  return Eigen::Quaternion<T>(cos(half), imag_factor * omega.x(), imag_factor * omega.y(),
                              imag_factor * omega.z());
}

/// log_SO3(q): the rotation vector with |omega| in [0, pi]. Uses atan2, so it stays accurate near
/// theta = pi where the matrix formula acos((tr R - 1)/2) loses precision.
template <typename T>
Vec3<T> logSO3(const Eigen::Quaternion<T>& q_in) {
  using std::atan2;
  using std::sqrt;
  // q and -q are the same rotation; take the one with w >= 0 so that theta <= pi.
  Eigen::Quaternion<T> q = q_in;
  if (q.w() < T(0)) q.coeffs() = -q.coeffs();
  const Vec3<T> v = q.vec();
  const T n_sq = v.squaredNorm();
  const T w = q.w();
  if (n_sq < T(kSmallAngleSq)) {
    // theta = 2 atan(n / w) = 2 n / w (1 - n^2 / (3 w^2)) + O(n^5).
    return v * (T(2) / w * (T(1) - n_sq / (T(3) * w * w)));
  }
  const T n = sqrt(n_sq);
  return v * (T(2) * atan2(n, w) / n);
}

/// Rotation matrix of exp_SO3(omega) (Rodrigues).
template <typename T>
Mat3<T> expSO3Matrix(const Vec3<T>& omega) {
  return expSO3(omega).toRotationMatrix();
}

}  // namespace scale_drift_slam::geometry
