#include "scale_drift_slam/tracking/two_view_reconstruction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "scale_drift_slam/common/statistics.h"

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
  std::vector<double> parallaxes;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!inlier[i]) continue;
    const Eigen::Vector3d p = triangulateTwoView(a[i], b[i], T);
    if (!p.allFinite() || p.z() <= 0.0) continue;
    const Eigen::Vector3d q = T * p;
    if (q.z() <= 0.0) continue;
    if ((p.hnormalized() - a[i]).squaredNorm() > max_err_sq) continue;
    if ((q.hnormalized() - b[i]).squaredNorm() > max_err_sq) continue;
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

}  // namespace

TwoViewResult reconstructTwoView(const Correspondences& a, const Correspondences& b, double focal,
                                 const TwoViewParams& params) {
  TwoViewResult result;
  const int n = static_cast<int>(a.size());
  if (n != static_cast<int>(b.size())) return refuse(result, "correspondence lists differ in size");
  if (n < params.min_points) {
    return refuse(result, "only " + std::to_string(n) + " correspondences");
  }
  const std::vector<cv::Point2d> pa = toCv(a), pb = toCv(b);
  const double threshold = params.ransac_threshold_px / focal;
  cv::Mat H, E, mask_h, mask_e;
  try {
    H = cv::findHomography(pa, pb, cv::RANSAC, threshold, mask_h, 2000, 0.999);
    E = cv::findEssentialMat(pa, pb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999, threshold,
                             mask_e);
  } catch (const cv::Exception& e) {
    return refuse(result, std::string("model fitting failed: ") + e.what());
  }
  if (H.empty() || E.empty() || E.rows < 3) return refuse(result, "no model fits");
  if (E.rows > 3) E = E.rowRange(0, 3).clone();
  Eigen::Matrix3d H_e, E_e;
  cv::cv2eigen(H, H_e);
  cv::cv2eigen(E, E_e);
  const double inv_sigma_sq = focal * focal / (params.sigma_px * params.sigma_px);
  result.gric_homography = gricHomography(H_e, a, b, inv_sigma_sq);
  result.gric_essential = gricEssential(E_e, a, b, inv_sigma_sq);
  result.used_homography = result.gric_homography < result.gric_essential;

  const cv::Mat& mask = result.used_homography ? mask_h : mask_e;
  std::vector<bool> inlier(n);
  int num_inliers = 0;
  for (int i = 0; i < n; ++i)
    num_inliers += (inlier[i] = mask.at<unsigned char>(i) != 0);
  const std::vector<geometry::SE3> motions =
      result.used_homography ? motionsFromHomography(H) : motionsFromEssential(E);

  std::vector<Hypothesis> hypotheses;
  hypotheses.reserve(motions.size());
  for (const geometry::SE3& T : motions)
    hypotheses.push_back(evaluate(T, a, b, inlier, focal, params));
  std::sort(hypotheses.begin(), hypotheses.end(),
            [](const Hypothesis& x, const Hypothesis& y) { return x.num_good > y.num_good; });
  const Hypothesis& best = hypotheses.front();
  const int second = hypotheses.size() > 1 ? hypotheses[1].num_good : 0;
  result.median_parallax_deg = best.median_parallax_deg;
  const std::string model = result.used_homography ? "homography" : "essential matrix";
  if (best.num_good < params.min_points || best.num_good < params.min_good_fraction * num_inliers) {
    return refuse(result, model + ": only " + std::to_string(best.num_good) + " of " +
                              std::to_string(num_inliers) +
                              " inliers triangulate with parallax (too little baseline?)");
  }
  if (best.median_parallax_deg < params.min_median_parallax_deg) {
    return refuse(result, model + ": median parallax " + std::to_string(best.median_parallax_deg) +
                              " deg is too small");
  }
  if (second >= params.ambiguity_ratio * best.num_good) {
    return refuse(result, model + ": ambiguous motion (" + std::to_string(best.num_good) + " vs " +
                              std::to_string(second) + " good points)");
  }

  geometry::SE3 T = best.T_second_first;
  std::vector<Eigen::Vector3d> points = best.points;
  bundleAdjustTwoView(a, b, best.good, focal, params.max_reprojection_px,
                      params.bundle_adjustment_iterations, &T, &points);
  // Re-check the adjusted points, then fix the scale: median depth in the first view = 1.
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

}  // namespace scale_drift_slam::tracking
