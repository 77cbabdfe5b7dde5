#pragma once
// The keyframe map: keyframe poses, 3D points and the observations that tie them together. Plain
// data with bookkeeping; the estimators (mapping/, loop/) read it and return corrections, which
// the owner applies. Not thread-safe: one owner (the mapping thread or node) mutates it.

#include <cstdint>
#include <map>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "scale_drift_slam/geometry/se3.h"

namespace scale_drift_slam::map {

using KeyframeId = std::uint32_t;
using PointId = std::uint32_t;

/// One measurement of a map point in a keyframe, in undistorted normalised image coordinates
/// (the ray through the feature meets the plane z = 1 at (x, y, 1)). Residuals in pixels are
/// these differences times the focal length. Held in single precision: the mapper and the loop
/// closer each keep every observation of the run (12 bytes each, not 24), and 1e-7 of a
/// normalised coordinate is ~1e-4 pixel.
struct Observation {
  Observation() = default;
  Observation(PointId point, const Eigen::Vector2d& normalised)
      : point_id(point), xy(normalised.cast<float>()) {}
  PointId point_id = 0;
  Eigen::Vector2f xy = Eigen::Vector2f::Zero();
  Eigen::Vector2d xyd() const { return xy.cast<double>(); }
};

struct Keyframe {
  KeyframeId id = 0;
  double timestamp = 0.0;
  geometry::SE3 T_kf_world;  ///< Maps world points into this keyframe's camera frame.
  std::vector<Observation> observations;
};

struct MapPoint {
  PointId id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  /// The keyframe the point is anchored to: loop correction moves the point with it.
  KeyframeId reference_keyframe = 0;
  std::vector<KeyframeId> observed_by;  ///< Keyframes holding an observation of this point.
};

class Map {
 public:
  /// Adds a keyframe with its observations (whose points must exist). Throws
  /// std::invalid_argument on a duplicate id or an observation of an unknown point.
  Keyframe& addKeyframe(Keyframe keyframe);
  /// Adds a point. Throws std::invalid_argument on a duplicate id or a non-finite position.
  MapPoint& addPoint(MapPoint point);
  /// Records that `keyframe_id` observes `point_id` at `xy`. Throws std::invalid_argument when
  /// either is unknown.
  void addObservation(KeyframeId keyframe_id, PointId point_id, const Eigen::Vector2d& xy);
  /// Removes a point and its observations; an unknown id is ignored.
  void removePoint(PointId id);
  /// Removes every observation a keyframe holds (a culled keyframe: its pose stays, the anchor
  /// of its points and frames). Returns the points it observed, in increasing id order. An
  /// unknown id is ignored.
  std::vector<PointId> clearObservations(KeyframeId id);

  bool hasKeyframe(KeyframeId id) const { return keyframes_.count(id) != 0; }
  bool hasPoint(PointId id) const { return points_.count(id) != 0; }
  /// Throw std::out_of_range naming the id when it is unknown.
  const Keyframe& keyframe(KeyframeId id) const;
  Keyframe& keyframe(KeyframeId id);
  const MapPoint& point(PointId id) const;
  MapPoint& point(PointId id);

  /// Keyframes in increasing id order.
  const std::map<KeyframeId, Keyframe>& keyframes() const { return keyframes_; }
  std::map<KeyframeId, Keyframe>& keyframes() { return keyframes_; }
  const std::unordered_map<PointId, MapPoint>& points() const { return points_; }
  std::unordered_map<PointId, MapPoint>& points() { return points_; }

  std::size_t numKeyframes() const { return keyframes_.size(); }
  std::size_t numPoints() const { return points_.size(); }
  std::size_t numObservations() const { return num_observations_; }

  /// Incremented by every change a consumer must see (estimators call bumpVersion()).
  std::uint64_t version() const { return version_; }
  void bumpVersion() { ++version_; }

 private:
  std::map<KeyframeId, Keyframe> keyframes_;
  std::unordered_map<PointId, MapPoint> points_;
  std::size_t num_observations_ = 0;
  std::uint64_t version_ = 0;
};

}  // namespace scale_drift_slam::map
