#pragma once
// Conversions between the core's typed SLAM messages (map/keyframe_message.h, tracking/tracker.h)
// and the package's ROS messages (msg/). Field for field: a keyframe or map update that goes
// through a topic reaches the mapper or the tracker as the offline mapping::SlamSystem hands it
// over, apart from map-point positions of MapUpdate (float32 on the wire). ROS-only fields
// (header, session, mapper id, camera) are set and read by the nodes.

#include "scale_drift_slam/Keyframe.h"
#include "scale_drift_slam/MapUpdate.h"
#include "scale_drift_slam/TrackingStatus.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::ros_conversions {

/// The keyframe as a message: id, stamp, pose, observations, new points, earlier observations,
/// map version and the grey image (mono8). Leaves session and camera to the caller.
/// Throws std::invalid_argument when the image is not 8-bit grey.
scale_drift_slam::Keyframe toKeyframeMsg(const map::KeyframeMessage& keyframe);
/// The core keyframe of a message (the image is shared with the message, not copied). Throws
/// std::invalid_argument naming the problem: an image other than mono8, data smaller than the
/// image, a non-finite pose or point.
map::KeyframeMessage fromKeyframeMsg(const scale_drift_slam::Keyframe& msg);

/// Leaves header, session and mapper id to the caller.
scale_drift_slam::MapUpdate toMapUpdateMsg(const map::MapUpdate& update);
/// Throws std::invalid_argument for arrays of different lengths, non-finite values or a bad
/// similarity.
map::MapUpdate fromMapUpdateMsg(const scale_drift_slam::MapUpdate& msg);

/// The frame's verdict; header, session, map sizes and map version are the caller's.
scale_drift_slam::TrackingStatus toTrackingStatusMsg(const tracking::FrameResult& result);

}  // namespace scale_drift_slam::ros_conversions
