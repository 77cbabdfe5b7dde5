#pragma once
// The back-end's owner of the global map (paper/ALGORITHM.md, "Back-end: sliding-window bundle
// adjustment"): takes the tracker's keyframe messages, adds keyframes, new points and their
// observations to the map, runs the sliding-window BA (window_bundle_adjustment.h) and returns
// the corrections as a map::MapUpdate for the tracker. Runs on the mapping thread (offline) or
// in the mapping node; owns the map::Map; nothing else writes to it.

#include <vector>

#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/mapping/window_bundle_adjustment.h"

namespace scale_drift_slam::mapping {

struct MapperParams {
  WindowBundleAdjustmentParams window;
  bool run_window_ba = true;  ///< Off: keyframes are only collected (for tests and debugging).
  void validate() const;
};

class Mapper {
 public:
  Mapper(const MapperParams& params, double focal_length_px);

  /// Adds the keyframe (observations of points the map does not know are skipped), runs the
  /// window BA and returns the correction of the window's poses and points. `statistics`, when
  /// given, receives the BA's figures (time_ms = 0 when it did not run).
  map::MapUpdate addKeyframe(const map::KeyframeMessage& message,
                             BundleStatistics* statistics = nullptr);

  const map::Map& map() const { return map_; }

 private:
  MapperParams params_;
  double focal_length_px_;
  map::Map map_;
};

}  // namespace scale_drift_slam::mapping
