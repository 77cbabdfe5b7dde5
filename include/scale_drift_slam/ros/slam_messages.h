#pragma once
// Conversions between the core's typed SLAM messages (map/keyframe_message.h, tracking/tracker.h)
// and the package's ROS messages (msg/). Field for field: a keyframe or map update that goes
// through a topic reaches the mapper or the tracker as the offline system::SlamSystem hands it
// over, apart from map-point positions of MapUpdate (float32 on the wire). ROS-only fields
// (header, session, mapper id, camera) are set and read by the nodes. Malformed messages are
// refused with std::invalid_argument naming the problem, never half converted.

#include <string>

#include "scale_drift_slam/Keyframe.h"
#include "scale_drift_slam/MapUpdate.h"
#include "scale_drift_slam/RelocalisationAnswer.h"
#include "scale_drift_slam/RelocalisationRequest.h"
#include "scale_drift_slam/Sim3Constraint.h"
#include "scale_drift_slam/TrackingStatus.h"
#include "scale_drift_slam/loop/loop_constraint.h"
#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/system/envelope.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::ros_conversions {

/// The keyframe as a message: id, stamp, pose, observations, new points, earlier observations,
/// map version and the grey image (mono8). Leaves session, mapper id and camera to the caller.
/// Throws std::invalid_argument when the image is not 8-bit grey.
scale_drift_slam::Keyframe toKeyframeMsg(const map::KeyframeMessage& keyframe);
/// The core keyframe of a message (the image copied). Throws std::invalid_argument naming the
/// problem: an image other than mono8, data smaller than the image, a non-finite pose or point.
/// With `image_problem`, an unusable image does not throw: the keyframe comes without it and the
/// reason is written there (empty when the image was fine or absent).
/// The keyframe as the tracking node sends it: toKeyframeMsg addressed (session, mapper id, map
/// version) and with the camera, stamped as the keyframe.
scale_drift_slam::Keyframe toKeyframeMsg(const map::KeyframeMessage& keyframe,
                                         const system::Envelope& address,
                                         const sensor_msgs::CameraInfo& camera);
map::KeyframeMessage fromKeyframeMsg(const scale_drift_slam::Keyframe& msg,
                                     std::string* image_problem = nullptr);

/// Leaves header, session and mapper id to the caller.
scale_drift_slam::MapUpdate toMapUpdateMsg(const map::MapUpdate& update);
/// Throws std::invalid_argument for arrays of different lengths, non-finite values or a bad
/// similarity.
map::MapUpdate fromMapUpdateMsg(const scale_drift_slam::MapUpdate& msg);

/// The loop constraint as a Sim3Constraint: from = current keyframe, to = loop keyframe,
/// measurement S_current_loop, identity information, the support figures. Leaves header and
/// session to the caller.
scale_drift_slam::Sim3Constraint toSim3ConstraintMsg(const loop::LoopConstraint& constraint);
/// Throws std::invalid_argument for a bad similarity (scale not positive and finite, non-finite
/// rotation or translation), keyframe ids out of range or naming the same keyframe twice.
loop::LoopConstraint fromSim3ConstraintMsg(const scale_drift_slam::Sim3Constraint& msg);

/// Frame index, stamp, map version and the grey image (mono8). Leaves session and mapper id to the
/// caller. Throws std::invalid_argument when the image is not 8-bit grey.
scale_drift_slam::RelocalisationRequest toRelocalisationRequestMsg(
    const map::RelocalisationRequest& request);
/// Throws std::invalid_argument when the image is missing, not mono8 or truncated.
map::RelocalisationRequest fromRelocalisationRequestMsg(
    const scale_drift_slam::RelocalisationRequest& msg);
/// Every field of the answer, found points included. Leaves session and mapper id to the caller.
scale_drift_slam::RelocalisationAnswer toRelocalisationAnswerMsg(
    const map::RelocalisationAnswer& answer);
/// Throws std::invalid_argument for a non-finite pose of a successful answer or non-finite points.
map::RelocalisationAnswer fromRelocalisationAnswerMsg(
    const scale_drift_slam::RelocalisationAnswer& msg);

/// The address (system/envelope.h) in a message's session, mapper_id and map_version fields.
template <typename Message>
system::Envelope envelopeOf(const Message& msg) {
  return {msg.session, msg.mapper_id, msg.map_version};
}
/// A loop constraint names its session only: it is applied to that session's map as it is.
inline system::Envelope envelopeOf(const scale_drift_slam::Sim3Constraint& msg) {
  return {msg.session, 0, 0};
}
/// Writes the address into the message's session, mapper_id and map_version fields.
template <typename Message>
void setEnvelope(const system::Envelope& from, Message* msg) {
  msg->session = from.session;
  msg->mapper_id = from.mapper_id;
  msg->map_version = from.map_version;
}
inline void setEnvelope(const system::Envelope& from, scale_drift_slam::Sim3Constraint* msg) {
  msg->session = from.session;
}

/// The frame's verdict; header, session, map sizes and map version are the caller's.
scale_drift_slam::TrackingStatus toTrackingStatusMsg(const tracking::FrameResult& result);
/// The tracking node's full status of a frame: the verdict, the tracker's map sizes and the
/// address of its map (`map_address`: session and map version in the mapper's numbering), stamped
/// with the image's time in `frame_id` (the camera's optical frame).
scale_drift_slam::TrackingStatus toTrackingStatusMsg(const tracking::FrameResult& result,
                                                     const tracking::Tracker& tracker,
                                                     const system::Envelope& map_address,
                                                     const ros::Time& stamp,
                                                     const std::string& frame_id);

}  // namespace scale_drift_slam::ros_conversions
