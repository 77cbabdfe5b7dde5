#include "scale_drift_slam/ros/slam_messages.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <sensor_msgs/image_encodings.h>

#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/image_conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

geometry::SE3 checkedPose(const geometry_msgs::Pose& pose, const std::string& what) {
  const geometry_msgs::Quaternion& q = pose.orientation;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!std::isfinite(norm) || norm < 1e-6 || !std::isfinite(pose.position.x) ||
      !std::isfinite(pose.position.y) || !std::isfinite(pose.position.z)) {
    throw std::invalid_argument(what + " is not a valid pose (non-finite or zero quaternion)");
  }
  return fromPoseMsg(pose);
}

}  // namespace

scale_drift_slam::Keyframe toKeyframeMsg(const map::KeyframeMessage& keyframe) {
  scale_drift_slam::Keyframe msg;
  msg.header.stamp = ros::Time(keyframe.keyframe.timestamp);
  msg.id = keyframe.keyframe.id;
  msg.T_kf_world = toPoseMsg(keyframe.keyframe.T_kf_world);
  msg.map_version = keyframe.map_version;
  msg.observations.reserve(keyframe.keyframe.observations.size());
  for (const map::Observation& o : keyframe.keyframe.observations) {
    scale_drift_slam::Observation observation;
    observation.point_id = o.point_id;
    observation.x = o.xy.x();
    observation.y = o.xy.y();
    msg.observations.push_back(observation);
  }
  msg.new_points.reserve(keyframe.new_points.size());
  for (const map::NewMapPoint& p : keyframe.new_points) {
    scale_drift_slam::NewPoint point;
    point.id = p.id;
    point.position.x = p.p_world.x();
    point.position.y = p.p_world.y();
    point.position.z = p.p_world.z();
    point.reference_keyframe = p.reference_keyframe;
    msg.new_points.push_back(point);
  }
  msg.earlier_observations.reserve(keyframe.earlier_observations.size());
  for (const map::KeyframeObservation& o : keyframe.earlier_observations) {
    scale_drift_slam::KeyframeObservation observation;
    observation.keyframe_id = o.keyframe_id;
    observation.point_id = o.point_id;
    observation.x = o.xy.x();
    observation.y = o.xy.y();
    msg.earlier_observations.push_back(observation);
  }
  if (!keyframe.image.empty()) msg.image = toMono8Msg(keyframe.image, msg.header);
  return msg;
}

scale_drift_slam::Keyframe toKeyframeMsg(const map::KeyframeMessage& keyframe,
                                         const system::Envelope& address,
                                         const sensor_msgs::CameraInfo& camera) {
  scale_drift_slam::Keyframe msg = toKeyframeMsg(keyframe);
  setEnvelope(address, &msg);
  msg.camera = camera;
  msg.camera.header.stamp = msg.header.stamp;
  return msg;
}

map::KeyframeMessage fromKeyframeMsg(const scale_drift_slam::Keyframe& msg,
                                     std::string* image_problem) {
  map::KeyframeMessage keyframe;
  keyframe.keyframe.id = msg.id;
  keyframe.keyframe.timestamp = msg.header.stamp.toSec();
  keyframe.keyframe.T_kf_world =
      checkedPose(msg.T_kf_world, "keyframe " + std::to_string(msg.id) + " T_kf_world");
  keyframe.map_version = msg.map_version;
  keyframe.keyframe.observations.reserve(msg.observations.size());
  for (const scale_drift_slam::Observation& o : msg.observations) {
    keyframe.keyframe.observations.push_back({o.point_id, Eigen::Vector2d(o.x, o.y)});
  }
  keyframe.new_points.reserve(msg.new_points.size());
  for (const scale_drift_slam::NewPoint& p : msg.new_points) {
    const Eigen::Vector3d position(p.position.x, p.position.y, p.position.z);
    if (!finite(position)) {
      throw std::invalid_argument("keyframe " + std::to_string(msg.id) + ": new point " +
                                  std::to_string(p.id) + " has a non-finite position");
    }
    keyframe.new_points.push_back({p.id, position, p.reference_keyframe});
  }
  keyframe.earlier_observations.reserve(msg.earlier_observations.size());
  for (const scale_drift_slam::KeyframeObservation& o : msg.earlier_observations) {
    keyframe.earlier_observations.push_back({o.keyframe_id, o.point_id, Eigen::Vector2d(o.x, o.y)});
  }
  if (image_problem) image_problem->clear();
  if (!msg.image.data.empty()) {
    try {
      keyframe.image = fromMono8Msg(msg.image);
    } catch (const std::invalid_argument& e) {
      if (!image_problem) throw;
      *image_problem = e.what();
    }
  }
  return keyframe;
}

scale_drift_slam::MapUpdate toMapUpdateMsg(const map::MapUpdate& update) {
  scale_drift_slam::MapUpdate msg;
  msg.map_version = update.map_version;
  msg.has_loop_correction = update.S_new_old.has_value();
  msg.S_new_old = toSim3Msg(update.S_new_old.value_or(geometry::Sim3()));
  msg.keyframe_ids.reserve(update.keyframe_poses.size());
  msg.keyframe_poses.reserve(update.keyframe_poses.size());
  for (const auto& [id, T_kf_world] : update.keyframe_poses) {
    msg.keyframe_ids.push_back(id);
    msg.keyframe_poses.push_back(toPoseMsg(T_kf_world));
  }
  msg.point_ids.reserve(update.point_positions.size());
  msg.point_positions.reserve(update.point_positions.size());
  for (const auto& [id, p_world] : update.point_positions) {
    msg.point_ids.push_back(id);
    geometry_msgs::Point32 point;
    point.x = static_cast<float>(p_world.x());
    point.y = static_cast<float>(p_world.y());
    point.z = static_cast<float>(p_world.z());
    msg.point_positions.push_back(point);
  }
  msg.removed_points = update.removed_points;
  msg.culled_keyframes = update.culled_keyframes;
  for (const auto& [id, C] : update.keyframe_corrections) {
    msg.corrected_keyframe_ids.push_back(id);
    msg.keyframe_corrections.push_back(toSim3Msg(C));
  }
  for (const auto& [from, to] : update.loop_links) {
    msg.loop_link_from.push_back(from);
    msg.loop_link_to.push_back(to);
  }
  return msg;
}

map::MapUpdate fromMapUpdateMsg(const scale_drift_slam::MapUpdate& msg) {
  if (msg.keyframe_ids.size() != msg.keyframe_poses.size() ||
      msg.point_ids.size() != msg.point_positions.size() ||
      msg.corrected_keyframe_ids.size() != msg.keyframe_corrections.size() ||
      msg.loop_link_from.size() != msg.loop_link_to.size()) {
    throw std::invalid_argument(
        "MapUpdate arrays of different lengths (keyframe_ids/keyframe_poses, "
        "point_ids/point_positions, corrected_keyframe_ids/keyframe_corrections or "
        "loop_link_from/loop_link_to)");
  }
  map::MapUpdate update;
  update.map_version = msg.map_version;
  if (msg.has_loop_correction) update.S_new_old = fromSim3Msg(msg.S_new_old);
  update.keyframe_poses.reserve(msg.keyframe_ids.size());
  for (std::size_t i = 0; i < msg.keyframe_ids.size(); ++i) {
    update.keyframe_poses.emplace_back(
        msg.keyframe_ids[i],
        checkedPose(msg.keyframe_poses[i],
                    "MapUpdate pose of keyframe " + std::to_string(msg.keyframe_ids[i])));
  }
  update.point_positions.reserve(msg.point_ids.size());
  for (std::size_t i = 0; i < msg.point_ids.size(); ++i) {
    const geometry_msgs::Point32& p = msg.point_positions[i];
    const Eigen::Vector3d position(p.x, p.y, p.z);
    if (!finite(position)) {
      throw std::invalid_argument("MapUpdate: point " + std::to_string(msg.point_ids[i]) +
                                  " has a non-finite position");
    }
    update.point_positions.emplace_back(msg.point_ids[i], position);
  }
  update.removed_points = msg.removed_points;
  update.culled_keyframes = msg.culled_keyframes;
  for (std::size_t i = 0; i < msg.corrected_keyframe_ids.size(); ++i) {
    update.keyframe_corrections.emplace_back(msg.corrected_keyframe_ids[i],
                                             fromSim3Msg(msg.keyframe_corrections[i]));
  }
  for (std::size_t i = 0; i < msg.loop_link_from.size(); ++i)
    update.loop_links.emplace_back(msg.loop_link_from[i], msg.loop_link_to[i]);
  return update;
}

scale_drift_slam::Sim3Constraint toSim3ConstraintMsg(const loop::LoopConstraint& constraint) {
  scale_drift_slam::Sim3Constraint msg;
  msg.from_keyframe_id = constraint.current_id;
  msg.to_keyframe_id = constraint.loop_id;
  msg.measurement = toSim3Msg(constraint.S_current_loop);
  for (std::size_t i = 0; i < 7; ++i)
    msg.information[8 * i] = 1.0;  // identity, row-major 7x7
  msg.inliers = static_cast<std::uint32_t>(std::max(0, constraint.num_inliers));
  msg.matches = static_cast<std::uint32_t>(std::max(0, constraint.num_matches));
  msg.scale_pairs = static_cast<std::uint32_t>(std::max(0, constraint.num_scale_pairs));
  msg.rmse_px = constraint.rmse_px;
  return msg;
}

loop::LoopConstraint fromSim3ConstraintMsg(const scale_drift_slam::Sim3Constraint& msg) {
  constexpr std::uint64_t kMaxId = std::numeric_limits<map::KeyframeId>::max();
  if (msg.from_keyframe_id > kMaxId || msg.to_keyframe_id > kMaxId) {
    throw std::invalid_argument("Sim3Constraint: keyframe id out of range (" +
                                std::to_string(msg.from_keyframe_id) + " -> " +
                                std::to_string(msg.to_keyframe_id) + ")");
  }
  if (msg.from_keyframe_id == msg.to_keyframe_id) {
    throw std::invalid_argument("Sim3Constraint: from and to are the same keyframe " +
                                std::to_string(msg.from_keyframe_id));
  }
  loop::LoopConstraint constraint;
  constraint.current_id = static_cast<map::KeyframeId>(msg.from_keyframe_id);
  constraint.loop_id = static_cast<map::KeyframeId>(msg.to_keyframe_id);
  constraint.S_current_loop = fromSim3Msg(msg.measurement);
  constraint.scale = constraint.S_current_loop.scale();
  constraint.T_current_loop =
      geometry::SE3(constraint.S_current_loop.rotation(),
                    constraint.S_current_loop.translation() / constraint.scale);
  constraint.num_inliers = static_cast<int>(msg.inliers);
  constraint.num_matches = static_cast<int>(msg.matches);
  constraint.num_scale_pairs = static_cast<int>(msg.scale_pairs);
  constraint.rmse_px = msg.rmse_px;
  return constraint;
}

scale_drift_slam::RelocalisationRequest toRelocalisationRequestMsg(
    const map::RelocalisationRequest& request) {
  scale_drift_slam::RelocalisationRequest msg;
  msg.header.stamp = ros::Time(request.timestamp);
  msg.frame_index = request.frame_index;
  msg.map_version = request.map_version;
  msg.image = toMono8Msg(request.image, msg.header);
  return msg;
}

map::RelocalisationRequest fromRelocalisationRequestMsg(
    const scale_drift_slam::RelocalisationRequest& msg) {
  if (msg.image.data.empty()) {
    throw std::invalid_argument("relocalisation request of frame " +
                                std::to_string(msg.frame_index) + " carries no image");
  }
  map::RelocalisationRequest request;
  request.frame_index = msg.frame_index;
  request.timestamp = msg.header.stamp.toSec();
  request.map_version = msg.map_version;
  request.image = fromMono8Msg(msg.image);
  return request;
}

scale_drift_slam::RelocalisationAnswer toRelocalisationAnswerMsg(
    const map::RelocalisationAnswer& answer) {
  scale_drift_slam::RelocalisationAnswer msg;
  msg.header.stamp = ros::Time(answer.timestamp);
  msg.frame_index = answer.frame_index;
  msg.success = answer.success;
  msg.reason = answer.reason;
  msg.keyframe_id = answer.keyframe_id;
  msg.T_cam_world = toPoseMsg(answer.T_cam_world);
  msg.map_version = answer.map_version;
  msg.inliers = static_cast<std::uint32_t>(std::max(0, answer.inliers));
  msg.points.reserve(answer.points.size());
  for (const map::RelocalisationAnswer::FoundPoint& p : answer.points) {
    scale_drift_slam::FoundPoint point;
    point.point_id = p.id;
    point.u = p.px.x();
    point.v = p.px.y();
    point.x = p.xy.x();
    point.y = p.xy.y();
    msg.points.push_back(point);
  }
  return msg;
}

map::RelocalisationAnswer fromRelocalisationAnswerMsg(
    const scale_drift_slam::RelocalisationAnswer& msg) {
  map::RelocalisationAnswer answer;
  answer.frame_index = msg.frame_index;
  answer.timestamp = msg.header.stamp.toSec();
  answer.success = msg.success;
  answer.reason = msg.reason;
  answer.keyframe_id = msg.keyframe_id;
  answer.map_version = msg.map_version;
  answer.inliers = static_cast<int>(msg.inliers);
  if (msg.success) {
    answer.T_cam_world = checkedPose(
        msg.T_cam_world, "relocalisation answer of frame " + std::to_string(msg.frame_index));
  }
  answer.points.reserve(msg.points.size());
  for (const scale_drift_slam::FoundPoint& p : msg.points) {
    const Eigen::Vector2d px(p.u, p.v), xy(p.x, p.y);
    if (!px.allFinite() || !xy.allFinite()) {
      throw std::invalid_argument("relocalisation answer: point " + std::to_string(p.point_id) +
                                  " has non-finite coordinates");
    }
    answer.points.push_back({p.point_id, px, xy});
  }
  return answer;
}

scale_drift_slam::TrackingStatus toTrackingStatusMsg(const tracking::FrameResult& result) {
  scale_drift_slam::TrackingStatus msg;
  switch (result.state) {
    case tracking::TrackingState::kInitializing:
      msg.state = scale_drift_slam::TrackingStatus::INITIALIZING;
      break;
    case tracking::TrackingState::kGood:
      msg.state = scale_drift_slam::TrackingStatus::GOOD;
      break;
    case tracking::TrackingState::kWeak:
      msg.state = scale_drift_slam::TrackingStatus::WEAK;
      break;
    case tracking::TrackingState::kLost:
      msg.state = scale_drift_slam::TrackingStatus::LOST;
      break;
  }
  msg.state_name = tracking::trackingStateName(result.state);
  msg.rejected = result.rejected;
  msg.has_pose = result.has_pose;
  msg.visible = static_cast<std::uint32_t>(std::max(0, result.num_visible));
  msg.matches = static_cast<std::uint32_t>(std::max(0, result.num_found));
  msg.inliers = static_cast<std::uint32_t>(std::max(0, result.num_inliers));
  msg.prepare_ms = static_cast<float>(result.times.prepare);
  msg.flow_ms = static_cast<float>(result.times.flow);
  msg.search_ms = static_cast<float>(result.times.search);
  msg.motion_ba_ms = static_cast<float>(result.times.motion_ba);
  msg.filters_ms = static_cast<float>(result.times.filters);
  msg.keyframe_ms = static_cast<float>(result.times.keyframe);
  msg.total_ms = static_cast<float>(result.times.total);
  msg.cpu_ms = static_cast<float>(result.times.cpu);
  msg.message = result.message;
  return msg;
}

scale_drift_slam::TrackingStatus toTrackingStatusMsg(const tracking::FrameResult& result,
                                                     const tracking::Tracker& tracker,
                                                     const system::Envelope& map_address,
                                                     const ros::Time& stamp,
                                                     const std::string& frame_id) {
  scale_drift_slam::TrackingStatus msg = toTrackingStatusMsg(result);
  msg.header.stamp = stamp;
  msg.header.frame_id = frame_id;
  msg.session = map_address.session;
  msg.keyframes = static_cast<std::uint32_t>(tracker.trackingMap().numKeyframes());
  msg.map_points = static_cast<std::uint32_t>(tracker.trackingMap().numPoints());
  msg.candidates = static_cast<std::uint32_t>(tracker.numCandidates());
  msg.map_version = map_address.map_version;
  return msg;
}

}  // namespace scale_drift_slam::ros_conversions
