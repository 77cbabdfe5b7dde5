#pragma once
// Everything a finished SLAM run leaves that a later run needs to go on in the same map (relocalise
// in it, track against it, extend it, close loops into it): the state the tracker, the mapper and
// the loop closer hold, gathered from the three of them by SlamSystem::snapshot() and handed back
// to a new SlamSystem by SlamSystem::restore(). Plain values; io/map_file.h writes and reads it.
//
// What is kept and what is rebuilt on restore:
// - the mapper's map (keyframes with poses and observations, points with their reference keyframe
//   and observers) and its loop edges, as they are;
// - the co-visibility graph of the tracker's local map and the loop closer's co-visible
//   exclusions are recomputed from the observations (they are a function of them), the tracker's
//   loop links from the loop edges;
// - the tracker's point appearances (the patches active search matches);
// - the loop closer's place-recognition database: the vocabulary (online-trained or loaded; none
//   when fewer keyframes than needed for training were seen) and every keyframe's ORB features in
//   the order they were added (the bags of words are recomputed with the vocabulary), and each
//   keyframe's JPEG image (for the warped patches of loop and relocalisation verification);
// - not kept: per-frame state (motion, feature candidates, point search statistics), the place
//   recogniser's consistency bookkeeping over consecutive queries, the map-version counters (a
//   restored map starts a new version numbering).

#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "scale_drift_slam/features/active_search.h"
#include "scale_drift_slam/loop/appearance.h"
#include "scale_drift_slam/loop/loop_closer.h"
#include "scale_drift_slam/loop/place_recognizer.h"
#include "scale_drift_slam/loop/pose_graph.h"
#include "scale_drift_slam/map/map.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::system {

struct MapSnapshot {
  map::Map map;                                 ///< The mapper's.
  std::vector<loop::PoseGraphEdge> loop_edges;  ///< The mapper's, in the order applied.
  /// The tracker's appearance of each point it can search (points without one are not tracked).
  std::unordered_map<map::PointId, features::PointAppearance> point_appearances;
  std::string vocabulary;                ///< loop::Vocabulary::toBytes(); empty: not trained yet.
  std::vector<loop::SavedPlace> places;  ///< In the order they were added.
  std::unordered_map<map::KeyframeId, std::vector<std::uint8_t>> keyframe_images;  ///< JPEG.

  /// Throws std::invalid_argument naming the first inconsistency: an observation, loop edge,
  /// appearance, place or image of an unknown keyframe or point, a point whose observers disagree
  /// with the observations, a non-finite pose or position, an invalid appearance.
  void validate() const;
};

/// The parts of a snapshot each part of the SLAM holds (SlamSystem::snapshot joins them in one
/// process; the ROS mapping node joins the parts the other nodes send, doc/map_file.md "In ROS"):
/// the tracker's point appearances (of the points of its keyframes),
MapSnapshot trackerPart(const tracking::Tracker& tracker);
/// the loop closer's vocabulary, places and keyframe images,
MapSnapshot loopCloserPart(const loop::LoopCloser& closer);
/// and the mapper's map and loop edges, with what the two parts hold of its keyframes and points
/// (what they hold of others, removed or not yet added by the mapper, is left out).
MapSnapshot joinParts(const map::Map& map, std::vector<loop::PoseGraphEdge> loop_edges,
                      const MapSnapshot& tracker_part, const MapSnapshot& loop_closer_part);

}  // namespace scale_drift_slam::system
