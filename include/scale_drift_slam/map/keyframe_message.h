#pragma once
// The typed messages between the SLAM's threads (offline) or nodes (ROS): the tracker emits a
// KeyframeMessage for every keyframe it drops; the mapper answers with MapUpdates (window BA
// results, later loop corrections). Plain values: they are copied or moved across a queue
// (common/message_queue.h) or converted to ROS messages (src/ros/), never shared by pointer.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/geometry/sim3.h"
#include "scale_drift_slam/map/map.h"

namespace scale_drift_slam::map {

/// An observation of a point in a keyframe other than the message's own (normalised xy).
struct KeyframeObservation {
  KeyframeId keyframe_id = 0;
  PointId point_id = 0;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
};

/// A point the tracker promoted to the map at this keyframe.
struct NewMapPoint {
  PointId id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  KeyframeId reference_keyframe = 0;
};

/// Everything the mapper and the loop closer learn about a new keyframe.
struct KeyframeMessage {
  /// Id, stamp, pose T_kf_world and the keyframe's observations (of old and new points).
  Keyframe keyframe;
  /// Points promoted at this keyframe (add them before the keyframe's observations).
  std::vector<NewMapPoint> new_points;
  /// Observations of the new points in earlier keyframes (e.g. the feature's origin keyframe).
  std::vector<KeyframeObservation> earlier_observations;
  /// The grey image as captured (distorted). The loop closer extracts its place-recognition
  /// features and cuts the patches of loop verification from it, off the camera's thread.
  cv::Mat image;
  /// The version of the last MapUpdate the tracker had applied when it made this keyframe. A
  /// message made before a loop correction is in the old world frame: the receivers bring it
  /// into the corrected frame (map/map_update.h, CorrectionHistory).
  std::uint64_t map_version = 0;
};

/// A correction of the tracker's map by the mapper. Applied by the tracker at the start of its
/// next frame; `map_version` orders updates (older ones are ignored).
struct MapUpdate {
  std::uint64_t map_version = 0;
  /// Applied first, to every keyframe and point of the tracker's map (loop closure): maps old
  /// world coordinates into corrected ones. Absent for window BA results.
  std::optional<geometry::Sim3> S_new_old;
  std::vector<std::pair<KeyframeId, geometry::SE3>> keyframe_poses;  ///< T_kf_world.
  std::vector<std::pair<PointId, Eigen::Vector3d>> point_positions;  ///< p_world.
  std::vector<PointId> removed_points;  ///< Dropped by the mapper (outliers, weak points).
  /// Keyframes the mapper culled as redundant (mapping/keyframe_culling.h): they lose their
  /// observations (and the loop closer their image and place), keep their poses. Applied after
  /// removed_points.
  std::vector<KeyframeId> culled_keyframes;
  /// Loop closure only: for each corrected keyframe k, the similarity C_k mapping old world
  /// coordinates near k into corrected ones (p_new = C_k p_old). Anything anchored to k (a frame
  /// of the trajectory, a point) moves with it; S_new_old is C of the newest keyframe.
  std::vector<std::pair<KeyframeId, geometry::Sim3>> keyframe_corrections;
  /// Loop closure only: the keyframe pairs of the loop constraint(s): the tracker may search the
  /// points of one from the other's neighbourhood from now on.
  std::vector<std::pair<KeyframeId, KeyframeId>> loop_links;

  bool isLoopCorrection() const { return S_new_old.has_value(); }
};

/// The tracker is lost: where is this frame? Answered by the loop closer (place recognition and
/// P3P against the map), asynchronously: the tracker keeps the frame and goes on meanwhile.
struct RelocalisationRequest {
  std::uint64_t frame_index = 0;  ///< The tracker's frame counter, to match the answer.
  double timestamp = 0.0;
  std::uint64_t map_version = 0;  ///< Of the last MapUpdate the tracker had applied.
  cv::Mat image;                  ///< Grey, as captured (distorted).
};

struct RelocalisationAnswer {
  std::uint64_t frame_index = 0;
  double timestamp = 0.0;
  bool success = false;
  std::string reason;             ///< Why it failed; empty on success.
  KeyframeId keyframe_id = 0;     ///< The keyframe it was localised against.
  geometry::SE3 T_cam_world;      ///< The frame's pose (on success).
  std::uint64_t map_version = 0;  ///< The loop closer's view of the map version.
  struct FoundPoint {
    PointId id = 0;
    Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< Raw pixel in the frame.
    Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< Undistorted normalised coordinates.
  };
  std::vector<FoundPoint> points;  ///< Map points found in the frame (inliers of the pose).
  int inliers = 0;                 ///< 2D-3D inliers of the pose.
};

}  // namespace scale_drift_slam::map
