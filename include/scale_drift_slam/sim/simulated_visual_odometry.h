#pragma once
// The paper's back-end run as visual odometry on a simulated world, data association given
// (doc/algorithm.md, "The paper's evidence": "the full system with feature initialisation and a
// fixed window BA of 10 keyframes, data association given"). Per frame: a constant-velocity
// guess, motion-only BA against the local map, inverse-depth filter updates; at keyframes (the
// keyframe rule): promotion of certain filters (BA against the surrounding keyframes), new
// filters spread over the image by a grid, and the sliding-window BA.
//
// It never closes a loop by itself: a point is tracked only while one of the newest
// `local_map_keyframes` keyframes observes it; a point seen again after that starts a new map
// point (as a VO would), which is what lets scale drift show at the loop. The first keyframes take
// the true pose (bootstrap: they fix the gauge, the scale included). One thread; owns its map.

#include <cstddef>
#include <unordered_map>
#include <vector>

#include "scale_drift_slam/features/motion_only_bundle_adjustment.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/mapping/window_bundle_adjustment.h"
#include "scale_drift_slam/sim/simulated_world.h"
#include "scale_drift_slam/tracking/inverse_depth_filter.h"
#include "scale_drift_slam/tracking/keyframe_rule.h"

namespace scale_drift_slam::sim {

struct SimulatedVoParams {
  mapping::WindowBundleAdjustmentParams window;
  features::MotionOnlyBundleAdjustmentParams motion;
  /// The simulation's filters promote at 5 % depth uncertainty, as its experiments (the circle
  /// and sphere drift and their Sim(3) against SE(3) checks) were set up; the image tracker's
  /// default is 10 %, chosen on forward driving, where the map starves at open junctions.
  tracking::InverseDepthFilterParams filter = [] {
    tracking::InverseDepthFilterParams p;
    p.max_relative_depth_sigma = 0.05;
    return p;
  }();
  tracking::KeyframeRuleParams keyframe_rule;
  int local_map_keyframes = 10;         ///< Points seen by one of the newest this many are tracked.
  int max_features_per_keyframe = 150;  ///< Tracked plus filtered, spread by the grid below.
  int grid_columns = 8;
  int grid_rows = 6;
  int promotion_keyframes = 3;       ///< Keyframes a feature is bundle adjusted against.
  int max_filter_age_keyframes = 8;  ///< Uncertain filters older than this are dropped.
  int bootstrap_keyframes = 2;       ///< Keyframes that take the true pose.
  int min_bootstrap_points = 30;     ///< ... and bootstrap lasts until the map has this many.
  int min_tracked_points = 8;        ///< Fewer: the frame keeps its constant-velocity guess.
  double initial_scene_depth = 1.0;  ///< Until points exist; also the filters' first depth.
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// `params` adapted to Gaussian pixel noise of `noise_px`: the filters' measurement sigma is the
/// noise (at least 0.5 px, so that a noise-free run still gates its updates), and the pixel
/// thresholds, whose defaults suit noise up to 1 px (kernel widths, inlier gates, the promotion
/// gate), grow in proportion to the noise above 1 px. Without that, 1.2 px noise rejects ~13 % of
/// good promotions at the 3 px gate and the map can starve.
SimulatedVoParams voParamsForNoise(SimulatedVoParams params, double noise_px);

struct SimulatedVoStatistics {
  std::size_t frames = 0;
  std::size_t lost_frames = 0;  ///< Frames with too few tracked points.
  std::size_t filters_started = 0;
  std::size_t promoted = 0;
  std::size_t promotions_rejected = 0;
  std::size_t window_ba_runs = 0;
  double window_ba_ms = 0.0;  ///< Summed.
  double motion_ba_ms = 0.0;  ///< Summed.
};

/// A keyframe of the run: its id in the map, the frame it was taken at, and every measurement of
/// that frame (sim point id -> normalised xy), for promotion and loop constraints.
struct KeyframeRecord {
  map::KeyframeId id = 0;
  std::size_t frame = 0;
  std::unordered_map<int, Eigen::Vector2d> measurements;
};

/// How a frame hangs off the keyframe map: its reference keyframe (the newest keyframe when the
/// frame was tracked; a keyframe is its own reference) and the pose relative to it at that time,
/// T_frame_kf = T_frame_world T_kf_world^-1. A frame follows its keyframe when the keyframe moves
/// later (window BA, loop correction): T_frame_world = T_frame_kf T_kf_world.
struct FrameRecord {
  std::size_t keyframe = 0;  ///< Index into SimulatedVisualOdometry::keyframes().
  geometry::SE3 T_frame_kf;
};

class SimulatedVisualOdometry {
 public:
  SimulatedVisualOdometry(const PinholeCamera& camera, const SimulatedVoParams& params);

  /// Processes frame `frame` (frames in order, starting at 0). `T_true_cam_world` is used only
  /// while bootstrapping.
  void processFrame(std::size_t frame, const std::vector<Measurement>& measurements,
                    const geometry::SE3& T_true_cam_world);

  const map::Map& map() const { return map_; }
  const std::vector<KeyframeRecord>& keyframes() const { return keyframes_; }
  /// The simulated point a map point stands for.
  int simPointOf(map::PointId id) const { return point_to_sim_.at(id); }
  /// The estimated pose of every processed frame (keyframes: after window BA).
  const std::vector<geometry::SE3>& framePoses() const { return frame_poses_; }
  /// Per processed frame: its reference keyframe and relative pose (see FrameRecord).
  const std::vector<FrameRecord>& frameRecords() const { return frame_records_; }
  /// Every frame's pose through its reference keyframe's current pose in the map.
  std::vector<geometry::SE3> framePosesThroughKeyframes() const;
  const SimulatedVoStatistics& statistics() const { return stats_; }

 private:
  struct Tracked {
    map::PointId point;
    Eigen::Vector2d xy;
  };
  geometry::SE3 predictPose() const;
  bool bootstrapping() const;
  bool isActive(map::PointId id) const;
  std::vector<Tracked> track(const std::vector<Measurement>& measurements, geometry::SE3* pose);
  void updateFilters(const std::vector<Measurement>& measurements, const geometry::SE3& pose);
  double sceneDepth(const geometry::SE3& pose, const std::vector<Tracked>& tracked) const;
  bool keyframeDue(const geometry::SE3& pose, double depth) const;
  void addKeyframe(std::size_t frame, const std::vector<Measurement>& measurements,
                   const std::vector<Tracked>& tracked, const geometry::SE3& pose, double depth);
  void promoteFilters();
  void startFilters(const std::vector<Measurement>& measurements,
                    const std::vector<Tracked>& tracked, double depth);
  void runWindowBundleAdjustment();

  PinholeCamera camera_;
  SimulatedVoParams params_;
  map::Map map_;
  std::vector<KeyframeRecord> keyframes_;
  std::vector<geometry::SE3> frame_poses_;
  std::vector<FrameRecord> frame_records_;
  std::unordered_map<int, map::PointId> sim_to_point_;  ///< The newest map point of a sim point.
  std::unordered_map<map::PointId, int> point_to_sim_;
  std::unordered_map<map::PointId, std::size_t> last_seen_;        ///< Index into keyframes_.
  std::unordered_map<int, tracking::InverseDepthFilter> filters_;  ///< By sim point.
  std::unordered_map<map::KeyframeId, std::size_t> keyframe_index_;
  map::PointId next_point_id_ = 0;
  SimulatedVoStatistics stats_;
};

}  // namespace scale_drift_slam::sim
