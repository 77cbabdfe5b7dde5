// MapSnapshot's check, and SlamSystem's snapshot() and restore() (the rest is slam_system.cpp).

#include "scale_drift_slam/system/map_snapshot.h"

#include <stdexcept>
#include <string>

#include "scale_drift_slam/loop/vocabulary.h"
#include "scale_drift_slam/system/slam_system.h"

namespace scale_drift_slam::system {

namespace {

void fail(const std::string& reason) {
  throw std::invalid_argument("saved map: " + reason);
}

void validateMap(const map::Map& map) {
  if (map.numKeyframes() == 0) fail("no keyframe");
  for (const auto& [id, keyframe] : map.keyframes()) {
    if (!keyframe.T_kf_world.matrix().allFinite()) {
      fail("keyframe " + std::to_string(id) + " has a non-finite pose");
    }
    for (const map::Observation& o : keyframe.observations) {
      if (!map.hasPoint(o.point_id)) {
        fail("keyframe " + std::to_string(id) + " observes unknown point " +
             std::to_string(o.point_id));
      }
      if (!o.xy.allFinite()) fail("keyframe " + std::to_string(id) + ": a non-finite observation");
    }
  }
  for (const auto& [id, point] : map.points()) {
    if (!point.p_world.allFinite()) fail("point " + std::to_string(id) + " is not finite");
    if (!map.hasKeyframe(point.reference_keyframe)) {
      fail("point " + std::to_string(id) + " has unknown reference keyframe " +
           std::to_string(point.reference_keyframe));
    }
    for (const map::KeyframeId observer : point.observed_by) {
      if (!map.hasKeyframe(observer)) {
        fail("point " + std::to_string(id) + " is observed by unknown keyframe " +
             std::to_string(observer));
      }
    }
  }
}

}  // namespace

void MapSnapshot::validate() const {
  validateMap(map);
  for (const loop::PoseGraphEdge& edge : loop_edges) {
    if (!map.hasKeyframe(edge.from) || !map.hasKeyframe(edge.to)) {
      fail("loop edge " + std::to_string(edge.from) + " - " + std::to_string(edge.to) +
           " names an unknown keyframe");
    }
    if (!edge.S_from_to.matrix().allFinite() || !edge.information.allFinite()) {
      fail("loop edge " + std::to_string(edge.from) + " - " + std::to_string(edge.to) +
           " is not finite");
    }
  }
  for (const auto& [id, appearance] : point_appearances) {
    if (!map.hasPoint(id)) fail("an appearance of unknown point " + std::to_string(id));
  }
  for (const loop::SavedPlace& place : places) {
    if (!map.hasKeyframe(place.id)) fail("a place of unknown keyframe " + std::to_string(place.id));
    try {
      place.appearance.validate();
    } catch (const std::exception& e) {
      fail("the place of keyframe " + std::to_string(place.id) + ": " + e.what());
    }
  }
  for (const auto& entry : keyframe_images) {
    if (!map.hasKeyframe(entry.first)) {
      fail("an image of unknown keyframe " + std::to_string(entry.first));
    }
  }
}

MapSnapshot trackerPart(const tracking::Tracker& tracker) {
  MapSnapshot part;
  const tracking::TrackingMap& tracked = tracker.trackingMap();
  for (const auto& [id, keyframe] : tracked.keyframes()) {
    for (const map::PointId point : keyframe.points) {
      if (tracked.hasPoint(point) && !tracked.point(point).appearance.empty()) {
        part.point_appearances.emplace(point, tracked.point(point).appearance);
      }
    }
  }
  return part;
}

MapSnapshot loopCloserPart(const loop::LoopCloser& closer) {
  MapSnapshot part;
  const loop::PlaceRecognizer& recognizer = closer.recognizer();
  if (recognizer.vocabularyReady()) part.vocabulary = recognizer.vocabulary()->toBytes();
  for (const loop::PlaceRecognizer::Place& place : recognizer.places()) {
    loop::SavedPlace kept{place.id, place.timestamp, *place.appearance, false, {}, {}};
    if (place.bow && place.groups) {
      kept.indexed = true;
      kept.bow = *place.bow;
      kept.groups = *place.groups;
    }
    part.places.push_back(std::move(kept));
  }
  part.keyframe_images = closer.keyframeImages();
  return part;
}

MapSnapshot joinParts(const map::Map& map, std::vector<loop::PoseGraphEdge> loop_edges,
                      const MapSnapshot& tracker_part, const MapSnapshot& loop_closer_part) {
  MapSnapshot saved;
  saved.map = map;
  saved.loop_edges = std::move(loop_edges);
  for (const auto& [id, appearance] : tracker_part.point_appearances) {
    if (map.hasPoint(id)) saved.point_appearances.emplace(id, appearance);
  }
  saved.vocabulary = loop_closer_part.vocabulary;
  for (const loop::SavedPlace& place : loop_closer_part.places) {
    if (map.hasKeyframe(place.id)) saved.places.push_back(place);
  }
  for (const auto& [id, jpeg] : loop_closer_part.keyframe_images) {
    if (map.hasKeyframe(id)) saved.keyframe_images.emplace(id, jpeg);
  }
  return saved;
}

MapSnapshot SlamSystem::snapshot() const {
  if (!finished_) throw std::logic_error("SlamSystem::snapshot: call finish() first");
  const map::Map& map = mapper_.map();
  if (map.numKeyframes() == 0) throw std::logic_error("SlamSystem::snapshot: there is no map");
  const loop::LoopCloser* closer = loop_closer_.closer();
  return joinParts(map, mapper_.loopEdges(), trackerPart(tracker_),
                   closer ? loopCloserPart(*closer) : MapSnapshot());
}

void SlamSystem::restore(MapSnapshot snapshot, bool localization_only) {
  if (started_ || finished_ || restored_keyframes_ != 0) {
    throw std::logic_error("SlamSystem::restore: only before the first frame");
  }
  snapshot.validate();
  std::shared_ptr<const loop::Vocabulary> vocabulary;
  if (!snapshot.vocabulary.empty()) {
    try {
      vocabulary = std::make_shared<const loop::Vocabulary>(
          loop::Vocabulary::fromBytes(snapshot.vocabulary, "in the saved map"));
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(std::string("saved map: ") + e.what());
    }
  }
  std::vector<std::pair<map::KeyframeId, map::KeyframeId>> loop_links;
  for (const loop::PoseGraphEdge& edge : snapshot.loop_edges)
    loop_links.emplace_back(edge.from, edge.to);
  // The loop closer first: it rebuilds the database and may still refuse the snapshot.
  loop_closer_.restore(session_, camera_, snapshot.map, std::move(vocabulary),
                       std::move(snapshot.places), std::move(snapshot.keyframe_images));
  tracker_.restoreMap(snapshot.map, snapshot.point_appearances, loop_links);
  tracker_.setLocalizationOnly(localization_only);
  restored_keyframes_ = snapshot.map.numKeyframes();
  mapper_.restore(session_, camera_->calibration().meanFocalLength(), std::move(snapshot.map),
                  std::move(snapshot.loop_edges));
}

}  // namespace scale_drift_slam::system
