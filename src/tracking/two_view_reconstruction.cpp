#include "scale_drift_slam/tracking/two_view_reconstruction.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "scale_drift_slam/common/statistics.h"
#include "scale_drift_slam/geometry/so3.h"

namespace scale_drift_slam::tracking {

void TwoViewParams::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0))
      throw std::invalid_argument(std::string("initializer.") + name + " must be > 0");
  };
  positive(ransac_threshold_px, "ransac_threshold_px");
  positive(sigma_px, "sigma_px");
  positive(max_reprojection_px, "max_reprojection_px");
  positive(min_median_parallax_deg, "min_median_parallax_deg");
  if (!(min_point_parallax_deg >= 0.0)) {
    throw std::invalid_argument("initializer.min_point_parallax_deg must be >= 0");
  }
  if (min_points < 8) throw std::invalid_argument("initializer.min_points must be >= 8");
  if (!(min_good_fraction >= 0.0 && min_good_fraction <= 1.0)) {
    throw std::invalid_argument("initializer.min_good_fraction must be in [0, 1]");
  }
  if (!(ambiguity_ratio > 0.0 && ambiguity_ratio <= 1.0)) {
    throw std::invalid_argument("initializer.ambiguity_ratio must be in (0, 1]");
  }
  if (!(ambiguity_sigmas >= 0.0)) {
    throw std::invalid_argument("initializer.ambiguity_sigmas must be >= 0");
  }
  positive(max_rotation_sigma_ratio, "max_rotation_sigma_ratio");
  if (bundle_adjustment_iterations < 0) {
    throw std::invalid_argument("initializer.bundle_adjustment_iterations must be >= 0");
  }
}

Eigen::Vector3d triangulateTwoView(const Eigen::Vector2d& xy_first,
                                   const Eigen::Vector2d& xy_second,
                                   const geometry::SE3& T_second_first) {
  // Rows x P3 - P1 and y P3 - P2 of both cameras; the null vector of A is the point.
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero();
  P1.leftCols<3>().setIdentity();
  const Eigen::Matrix<double, 3, 4> P2 = T_second_first.matrix3x4();
  Eigen::Matrix4d A;
  A.row(0) = xy_first.x() * P1.row(2) - P1.row(0);
  A.row(1) = xy_first.y() * P1.row(2) - P1.row(1);
  A.row(2) = xy_second.x() * P2.row(2) - P2.row(0);
  A.row(3) = xy_second.y() * P2.row(2) - P2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X[3]) < 1e-12) return Eigen::Vector3d::Constant(std::nan(""));
  return X.head<3>() / X[3];
}

double parallaxDeg(const Eigen::Vector3d& p_first, const geometry::SE3& T_second_first) {
  const Eigen::Vector3d ray_second = p_first - T_second_first.inverseTranslation();
  const double c = p_first.normalized().dot(ray_second.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

namespace {

using Correspondences = std::vector<Eigen::Vector2d>;

std::vector<cv::Point2d> toCv(const Correspondences& xy) {
  std::vector<cv::Point2d> out;
  out.reserve(xy.size());
  for (const auto& p : xy)
    out.emplace_back(p.x(), p.y());
  return out;
}

// Torr's Geometric Robust Information Criterion (GRIC) of a two-view relation: with e_i^2 the
// squared geometric error of correspondence i over sigma^2, data dimension r = 4 (two image
// points), model manifold dimension d and k model parameters,
//   GRIC = sum_i min(e_i^2 / sigma^2, 2 (r - d)) + log(r) d n + log(r n) k.
// Homography: d = 2, k = 8, e^2 ~ half the mean symmetric transfer error (both images are
// noisy). Essential matrix: d = 3, k = 5, e^2 = the Sampson error. The lower GRIC wins.
double gricHomography(const Eigen::Matrix3d& H, const Correspondences& a, const Correspondences& b,
                      double inv_sigma_sq) {
  const Eigen::Matrix3d H_inv = H.inverse();
  const double n = static_cast<double>(a.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector2d b_pred = (H * a[i].homogeneous()).hnormalized();
    const Eigen::Vector2d a_pred = (H_inv * b[i].homogeneous()).hnormalized();
    const double e_sq = 0.25 * ((b[i] - b_pred).squaredNorm() + (a[i] - a_pred).squaredNorm());
    sum += std::min(e_sq * inv_sigma_sq, 4.0);
  }
  return sum + std::log(4.0) * 2.0 * n + std::log(4.0 * n) * 8.0;
}

double gricEssential(const Eigen::Matrix3d& E, const Correspondences& a, const Correspondences& b,
                     double inv_sigma_sq) {
  const double n = static_cast<double>(a.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d line_b = E * a[i].homogeneous();
    const Eigen::Vector3d line_a = E.transpose() * b[i].homogeneous();
    const double d = b[i].homogeneous().dot(line_b);
    const double sampson =
        d * d / (line_b.head<2>().squaredNorm() + line_a.head<2>().squaredNorm() + 1e-300);
    sum += std::min(sampson * inv_sigma_sq, 2.0);
  }
  return sum + std::log(4.0) * 3.0 * n + std::log(4.0 * n) * 5.0;
}

struct Hypothesis {
  geometry::SE3 T_second_first;
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> good;
  /// Per inlier: squared reprojection error (pixels^2, both images), capped at twice
  /// max_reprojection_px^2; the cap also where the point is behind a camera.
  std::vector<double> error_sq;
  int num_good = 0;
  double median_parallax_deg = 0.0;
};

// Triangulates the inliers under one motion and keeps the points in front of both cameras that
// reproject within the threshold and have enough parallax.
Hypothesis evaluate(const geometry::SE3& T, const Correspondences& a, const Correspondences& b,
                    const std::vector<bool>& inlier, double focal, const TwoViewParams& params) {
  Hypothesis h;
  h.T_second_first = T;
  h.points.assign(a.size(), Eigen::Vector3d::Zero());
  h.good.assign(a.size(), false);
  const double max_err_sq = std::pow(params.max_reprojection_px / focal, 2);
  h.error_sq.assign(a.size(), 2.0 * params.max_reprojection_px * params.max_reprojection_px);
  std::vector<double> parallaxes;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!inlier[i]) continue;
    const Eigen::Vector3d p = triangulateTwoView(a[i], b[i], T);
    if (!p.allFinite() || p.z() <= 0.0) continue;
    const Eigen::Vector3d q = T * p;
    if (q.z() <= 0.0) continue;
    const double err_a = (p.hnormalized() - a[i]).squaredNorm();
    const double err_b = (q.hnormalized() - b[i]).squaredNorm();
    h.error_sq[i] = std::min(h.error_sq[i], (err_a + err_b) * focal * focal);
    if (err_a > max_err_sq || err_b > max_err_sq) continue;
    const double parallax = parallaxDeg(p, T);
    if (parallax < params.min_point_parallax_deg) continue;
    h.points[i] = p;
    h.good[i] = true;
    parallaxes.push_back(parallax);
  }
  h.num_good = static_cast<int>(parallaxes.size());
  if (!parallaxes.empty()) h.median_parallax_deg = common::upperMedian(std::move(parallaxes));
  return h;
}

std::vector<geometry::SE3> motionsFromHomography(const cv::Mat& H) {
  std::vector<cv::Mat> rotations, translations, normals;
  cv::decomposeHomographyMat(H, cv::Mat::eye(3, 3, CV_64F), rotations, translations, normals);
  std::vector<geometry::SE3> motions;
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    cv::cv2eigen(rotations[i], R);
    cv::cv2eigen(translations[i], t);
    if (t.norm() > 1e-12) t.normalize();
    motions.emplace_back(R, t);
  }
  return motions;
}

std::vector<geometry::SE3> motionsFromEssential(const cv::Mat& E) {
  cv::Mat R1, R2, t;
  cv::decomposeEssentialMat(E, R1, R2, t);
  Eigen::Matrix3d Ra, Rb;
  Eigen::Vector3d tv;
  cv::cv2eigen(R1, Ra);
  cv::cv2eigen(R2, Rb);
  cv::cv2eigen(t, tv);
  return {geometry::SE3(Ra, tv), geometry::SE3(Ra, -tv), geometry::SE3(Rb, tv),
          geometry::SE3(Rb, -tv)};
}

TwoViewResult refuse(TwoViewResult result, const std::string& reason) {
  result.success = false;
  result.reason = reason;
  return result;
}

// Why a hypothesis is too weak to start a map (too few points, too little parallax), or "".
std::string weakness(const Hypothesis& h, int num_inliers, const TwoViewParams& params) {
  if (h.num_good < params.min_points || h.num_good < params.min_good_fraction * num_inliers) {
    return "only " + std::to_string(h.num_good) + " of " + std::to_string(num_inliers) +
           " inliers triangulate with parallax (too little baseline?)";
  }
  if (h.median_parallax_deg < params.min_median_parallax_deg) {
    return "median parallax " + std::to_string(h.median_parallax_deg) + " deg is too small";
  }
  return "";
}

struct ModelFit {
  cv::Mat H, E, mask_h, mask_e;
};

// RANSAC fits of both models; returns why they failed, or "".
std::string fitModels(const Correspondences& a, const Correspondences& b, double focal,
                      const TwoViewParams& params, ModelFit* fit) {
  const std::vector<cv::Point2d> pa = toCv(a), pb = toCv(b);
  const double threshold = params.ransac_threshold_px / focal;
  try {
    fit->H = cv::findHomography(pa, pb, cv::RANSAC, threshold, fit->mask_h, 2000, 0.999);
    fit->E = cv::findEssentialMat(pa, pb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999, threshold,
                                  fit->mask_e);
  } catch (const cv::Exception& e) {
    return std::string("model fitting failed: ") + e.what();
  }
  if (fit->H.empty() || fit->E.empty() || fit->E.rows < 3) return "no model fits";
  if (fit->E.rows > 3) fit->E = fit->E.rowRange(0, 3).clone();
  return "";
}

// Two-view BA of one hypothesis over its good points, then triangulated again: a homography's
// motion is fitted to the plane alone, and only the refined motion explains the points off it.
Hypothesis refine(const Hypothesis& h, const Correspondences& a, const Correspondences& b,
                  const std::vector<bool>& candidates, double focal, const TwoViewParams& params) {
  geometry::SE3 T = h.T_second_first;
  std::vector<Eigen::Vector3d> points = h.points;
  bundleAdjustTwoView(a, b, h.good, focal, params.max_reprojection_px,
                      params.bundle_adjustment_iterations, &T, &points);
  return evaluate(T, a, b, candidates, focal, params);
}

// Paired test of the per-point reprojection errors: with d_i = e_y,i^2 - e_x,i^2, x is clearly
// better when sum d >= sigmas * sqrt(sum d^2). Where the scene cannot tell the motions apart (a
// single plane) both fit every point and the d_i are noise of either sign; points off the plane
// fit only the true motion and push the sum one way. The statistic is free of the noise level.
bool clearlyBetter(const Hypothesis& x, const Hypothesis& y, double sigmas, double* z) {
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < x.error_sq.size(); ++i) {
    const double d = y.error_sq[i] - x.error_sq[i];
    sum += d;
    sum_sq += d * d;
  }
  *z = sum_sq > 0.0 ? sum / std::sqrt(sum_sq) : 0.0;
  return *z >= sigmas;
}

// Two refined motions are one when they differ by no more than BA's convergence: the mirror
// solution of a homography is tens of degrees away in its translation direction.
bool sameMotion(const geometry::SE3& x, const geometry::SE3& y) {
  const double rotation_deg = x.rotation().angularDistance(y.rotation()) * 180.0 / M_PI;
  const double cos_direction = x.translation().normalized().dot(y.translation().normalized());
  return rotation_deg < 0.1 && cos_direction > std::cos(1.0 * M_PI / 180.0);
}

struct Decision {
  bool resolved = false;
  Hypothesis winner;
  std::string detail;  ///< How many points told the two leaders apart.
};

// The homography's two-fold ambiguity does not fade with more motion on a mostly planar scene:
// instead of waiting, every contender (>= ambiguity_ratio of the best) is refined on all
// candidate points and the one the off-model points agree with wins, if it wins clearly.
Decision resolveAmbiguity(const std::vector<Hypothesis>& sorted, const Correspondences& a,
                          const Correspondences& b, const std::vector<bool>& candidates,
                          double focal, const TwoViewParams& params) {
  std::vector<Hypothesis> contenders;
  for (const Hypothesis& h : sorted) {
    if (h.num_good < params.ambiguity_ratio * sorted.front().num_good) break;
    contenders.push_back(refine(h, a, b, candidates, focal, params));
  }
  const auto total = [](const Hypothesis& h) {
    return std::accumulate(h.error_sq.begin(), h.error_sq.end(), 0.0);
  };
  std::sort(contenders.begin(), contenders.end(),
            [&](const Hypothesis& x, const Hypothesis& y) { return total(x) < total(y); });
  Decision decision;
  decision.winner = contenders.front();
  for (std::size_t k = 1; k < contenders.size(); ++k) {
    if (sameMotion(decision.winner.T_second_first, contenders[k].T_second_first)) continue;
    double z = 0.0;
    const bool clear = clearlyBetter(decision.winner, contenders[k], params.ambiguity_sigmas, &z);
    char detail[64];
    std::snprintf(detail, sizeof(detail), "reprojection errors differ by %.1f sigma", z);
    decision.detail = detail;
    if (!clear) return decision;
  }
  decision.resolved = true;
  return decision;
}

// Standard deviation (degrees, the largest over axes) of the rotation of a two-view
// reconstruction, from the Gauss-Newton information of the second view's reprojection errors
// (sigma_px each) with every point's inverse depth along its first-view ray marginalised out and
// the translation free on its sphere. Small baselines seen through a narrow lens leave the
// rotation and the translation across the view nearly interchangeable (the bas-relief
// ambiguity): the points' depths absorb the difference, the reprojection errors hardly change,
// and this deviation is large.
double rotationSigmaDeg(const geometry::SE3& T, const std::vector<Eigen::Vector3d>& points,
                        const std::vector<bool>& use, double focal, double sigma_px) {
  const Eigen::Matrix3d R = T.rotation().toRotationMatrix();
  const Eigen::Vector3d t = T.translation();
  if (t.norm() < 1e-12) return std::numeric_limits<double>::infinity();
  Eigen::Vector3d e1 = t.unitOrthogonal(), e2 = t.normalized().cross(e1);
  Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!use[i] || !(points[i].z() > 0.0)) continue;
    const double rho = 1.0 / points[i].z();
    const Eigen::Vector3d bearing = points[i] * rho;  // (x, y, 1) of the first view
    const Eigen::Vector3d Rp = R * points[i];
    const Eigen::Vector3d q = Rp + t;
    if (!(q.z() > 0.0)) continue;
    Eigen::Matrix<double, 2, 3> dpi;
    dpi << 1.0 / q.z(), 0.0, -q.x() / (q.z() * q.z()), 0.0, 1.0 / q.z(), -q.y() / (q.z() * q.z());
    dpi *= focal;
    Eigen::Matrix<double, 3, 5> dq;
    dq.leftCols<3>() = -geometry::hatSO3(Rp);
    dq.col(3) = e1;
    dq.col(4) = e2;
    const Eigen::Matrix<double, 2, 5> Jc = dpi * dq;
    const Eigen::Vector2d Jr = dpi * (R * (-bearing / (rho * rho)));
    const double hrr = Jr.squaredNorm();
    H += Jc.transpose() * Jc;
    if (hrr > 1e-18) H -= (Jc.transpose() * Jr) * (Jr.transpose() * Jc) / hrr;
  }
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0))
    return std::numeric_limits<double>::infinity();
  const Eigen::Matrix<double, 5, 5> cov = ldlt.solve(Eigen::Matrix<double, 5, 5>::Identity());
  const double max_var = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov.topLeftCorner<3, 3>())
                             .eigenvalues()
                             .maxCoeff();
  return sigma_px * std::sqrt(std::max(max_var, 0.0)) * 180.0 / M_PI;
}

// Two-view BA of the chosen hypothesis, a re-check of its points, and the scale fixed so that
// the median depth in the first view is 1.
TwoViewResult finish(TwoViewResult result, const Hypothesis& best, const Correspondences& a,
                     const Correspondences& b, double focal, const TwoViewParams& params) {
  const int n = static_cast<int>(a.size());
  geometry::SE3 T = best.T_second_first;
  std::vector<Eigen::Vector3d> points = best.points;
  bundleAdjustTwoView(a, b, best.good, focal, params.max_reprojection_px,
                      params.bundle_adjustment_iterations, &T, &points);
  const double max_err_sq = std::pow(params.max_reprojection_px / focal, 2);
  std::vector<bool> good(n, false);
  std::vector<double> depths;
  for (int i = 0; i < n; ++i) {
    if (!best.good[i]) continue;
    const Eigen::Vector3d& p = points[i];
    const Eigen::Vector3d q = T * p;
    if (!p.allFinite() || p.z() <= 0.0 || q.z() <= 0.0) continue;
    if ((p.hnormalized() - a[i]).squaredNorm() > max_err_sq) continue;
    if ((q.hnormalized() - b[i]).squaredNorm() > max_err_sq) continue;
    good[i] = true;
    depths.push_back(p.z());
  }
  if (static_cast<int>(depths.size()) < params.min_points) {
    return refuse(result, "too few points survive the two-view bundle adjustment");
  }
  const double scale = 1.0 / common::upperMedian(depths);
  result.rotation_sigma_deg = rotationSigmaDeg(T, points, good, focal, params.sigma_px);
  if (!(result.rotation_sigma_deg <= params.max_rotation_sigma_ratio * best.median_parallax_deg)) {
    char reason[160];
    std::snprintf(reason, sizeof(reason),
                  "rotation uncertain: std %.2f deg against a median parallax of %.2f deg "
                  "(rotation and translation barely told apart: more baseline needed)",
                  result.rotation_sigma_deg, best.median_parallax_deg);
    return refuse(result, reason);
  }
  result.T_second_first = geometry::SE3(T.rotation(), T.translation() * scale);
  result.points_first.assign(n, Eigen::Vector3d::Zero());
  result.triangulated = good;
  result.num_triangulated = static_cast<int>(depths.size());
  for (int i = 0; i < n; ++i) {
    if (good[i]) result.points_first[i] = points[i] * scale;
  }
  result.success = true;
  return result;
}

}  // namespace

TwoViewResult reconstructTwoView(const Correspondences& a, const Correspondences& b, double focal,
                                 const TwoViewParams& params) {
  TwoViewResult result;
  const int n = static_cast<int>(a.size());
  if (n != static_cast<int>(b.size())) return refuse(result, "correspondence lists differ in size");
  if (n < params.min_points) {
    return refuse(result, "only " + std::to_string(n) + " correspondences");
  }
  ModelFit fit;
  const std::string failure = fitModels(a, b, focal, params, &fit);
  if (!failure.empty()) return refuse(result, failure);
  Eigen::Matrix3d H_e, E_e;
  cv::cv2eigen(fit.H, H_e);
  cv::cv2eigen(fit.E, E_e);
  const double inv_sigma_sq = focal * focal / (params.sigma_px * params.sigma_px);
  result.gric_homography = gricHomography(H_e, a, b, inv_sigma_sq);
  result.gric_essential = gricEssential(E_e, a, b, inv_sigma_sq);
  result.used_homography = result.gric_homography < result.gric_essential;

  // The chosen model's inliers set the bar for "enough points". A homography's motions are
  // triangulated over the essential matrix's inliers too: the points off its plane are its
  // outliers, and only they tell its two motions apart.
  const cv::Mat& mask = result.used_homography ? fit.mask_h : fit.mask_e;
  std::vector<bool> candidates(n);
  int num_inliers = 0;
  for (int i = 0; i < n; ++i) {
    num_inliers += mask.at<unsigned char>(i) != 0;
    candidates[i] = mask.at<unsigned char>(i) != 0 ||
                    (result.used_homography && fit.mask_e.at<unsigned char>(i) != 0);
  }
  const std::vector<geometry::SE3> motions =
      result.used_homography ? motionsFromHomography(fit.H) : motionsFromEssential(fit.E);
  std::vector<Hypothesis> hypotheses;
  hypotheses.reserve(motions.size());
  for (const geometry::SE3& T : motions)
    hypotheses.push_back(evaluate(T, a, b, candidates, focal, params));
  std::sort(hypotheses.begin(), hypotheses.end(),
            [](const Hypothesis& x, const Hypothesis& y) { return x.num_good > y.num_good; });
  Hypothesis best = hypotheses.front();
  const int second = hypotheses.size() > 1 ? hypotheses[1].num_good : 0;
  result.median_parallax_deg = best.median_parallax_deg;
  const std::string model = result.used_homography ? "homography" : "essential matrix";
  std::string weak = weakness(best, num_inliers, params);
  if (!weak.empty()) return refuse(result, model + ": " + weak);
  if (second >= params.ambiguity_ratio * best.num_good) {
    const Decision decision = resolveAmbiguity(hypotheses, a, b, candidates, focal, params);
    if (!decision.resolved) {
      return refuse(result, model + ": ambiguous motion (" + std::to_string(best.num_good) +
                                " vs " + std::to_string(second) + " good points; " +
                                decision.detail + ")");
    }
    best = decision.winner;
    result.ambiguity_resolved = true;
    result.median_parallax_deg = best.median_parallax_deg;
    weak = weakness(best, num_inliers, params);
    if (!weak.empty()) return refuse(result, model + " (ambiguity resolved): " + weak);
  }
  return finish(result, best, a, b, focal, params);
}

}  // namespace scale_drift_slam::tracking
