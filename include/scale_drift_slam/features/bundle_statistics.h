#pragma once
// What one bundle adjustment did (the window BA's, the motion-only BA's): cost and pixel error
// before and after, inliers, iterations, time. Shared by features/ and mapping/.

#include <cstddef>
#include <string>

namespace scale_drift_slam::features {

struct BundleStatistics {
  int iterations = 0;
  double initial_cost = 0.0;  ///< sum rho (pixels^2), at the start.
  double final_cost = 0.0;
  double initial_rmse_px = 0.0;  ///< RMS of the pixel errors of the inliers, before and after.
  double final_rmse_px = 0.0;
  std::size_t num_observations = 0;
  std::size_t num_inliers = 0;  ///< Final pixel error below the inlier threshold.
  double time_ms = 0.0;
  bool converged = false;
  std::string message;
};

}  // namespace scale_drift_slam::features
