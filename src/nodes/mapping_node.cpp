// mapping_node: the back-end as a ROS node (doc/ros.md). Owns the global map through the core's
// mapping::Mapper: each Keyframe from the tracking node is added and the sliding-window BA runs;
// each Sim3Constraint from the loop-closure node closes a loop (Sim(3) pose graph, point
// correction, structure-only BA). Every correction goes out as a MapUpdate (to the tracking and
// loop-closure nodes). Publishes the map as a latched PointCloud2 and the keyframes and loop edges
// as markers. A keyframe of a new tracker session (the tracker was reset or restarted) starts a
// new map; constraints of another session are refused. Services: ~save_trajectory (TUM file of
// the keyframes), ~reset (a new, empty map). Everything runs on the main thread, one message at a
// time, so the map needs no lock.

#include <random>

#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include "scale_drift_slam/SaveTrajectory.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/slam_messages.h"
#include "scale_drift_slam/ros/visualization.h"

namespace {

using namespace scale_drift_slam;

class MappingNode {
 public:
  MappingNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, ros_conversions::MappingNodeConfig config)
      : config_(std::move(config)),
        params_(config_.node),
        T_map_world_(ros_conversions::mapFromWorld(params_.map_z_up)) {
    keyframe_sub_ =
        nh.subscribe("keyframes", params_.keyframe_queue_size, &MappingNode::onKeyframe, this);
    constraint_sub_ = nh.subscribe("loop_constraints", 10, &MappingNode::onLoopConstraint, this);
    update_pub_ = nh.advertise<scale_drift_slam::MapUpdate>("map_updates", 20);
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
    marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("map_markers", 1, true);
    save_srv_ = pnh.advertiseService("save_trajectory", &MappingNode::onSaveTrajectory, this);
    reset_srv_ = pnh.advertiseService("reset", &MappingNode::onReset, this);
    mapper_id_ = newMapperId();
  }

 private:
  static std::uint32_t newMapperId() { return std::random_device{}() | 1u; }

  void resetMap(const std::string& why) {
    ROS_WARN("starting a new map: %s", why.c_str());
    mapper_.reset();
    mapper_id_ = newMapperId();
    std_msgs::Header header;
    header.stamp = last_stamp_;
    header.frame_id = params_.map_frame;
    cloud_pub_.publish(ros_conversions::mapCloud(map::Map(), T_map_world_, header));
    marker_pub_.publish(ros_conversions::deleteAllMarkers(header));
  }

  void onKeyframe(const scale_drift_slam::KeyframeConstPtr& msg) {
    if (has_session_ && msg->session != session_) {
      resetMap("keyframe " + std::to_string(msg->id) +
               " is of a new tracker session (the tracker was reset or restarted)");
    }
    has_session_ = true;
    session_ = msg->session;
    try {
      if (!mapper_) {
        const geometry::CameraCalibration camera =
            ros_conversions::calibrationFromCameraInfo(msg->camera);
        mapper_ = std::make_unique<mapping::Mapper>(config_.slam.mapper, camera.meanFocalLength());
        ROS_INFO("new map from keyframe %u; camera %s", msg->id, camera.describe().c_str());
      }
      if (mapper_->map().hasKeyframe(msg->id)) {
        ROS_WARN_THROTTLE(5, "keyframe %u is already in the map: ignored", msg->id);
        return;
      }
      std::string image_problem;  // the mapper needs no image: a bad one is not its business
      const map::KeyframeMessage keyframe = ros_conversions::fromKeyframeMsg(*msg, &image_problem);
      features::BundleStatistics statistics;
      const ros::WallTime start = ros::WallTime::now();
      const map::MapUpdate update = mapper_->addKeyframe(keyframe, &statistics);
      const double ms = (ros::WallTime::now() - start).toSec() * 1e3;
      last_stamp_ = msg->header.stamp;
      publishUpdate(update);
      ROS_DEBUG(
          "keyframe %u: added in %.1f ms, window BA %.1f ms (%d iterations, RMS %.2f -> %.2f "
          "px, %zu of %zu observations inliers)%s%s",
          msg->id, ms, statistics.time_ms, statistics.iterations, statistics.initial_rmse_px,
          statistics.final_rmse_px, statistics.num_inliers, statistics.num_observations,
          statistics.message.empty() ? "" : ": ", statistics.message.c_str());
      if (mapper_->map().numKeyframes() % 20 == 0) {
        ROS_INFO("map: %zu keyframes, %zu points (keyframe %u, window BA %.1f ms)",
                 mapper_->map().numKeyframes(), mapper_->map().numPoints(), msg->id, ms);
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "keyframe %u not added: %s", msg->id, e.what());
    }
  }

  void onLoopConstraint(const scale_drift_slam::Sim3ConstraintConstPtr& msg) {
    const std::string loop = "loop " + std::to_string(msg->from_keyframe_id) + " -> " +
                             std::to_string(msg->to_keyframe_id);
    if (!mapper_ || msg->session != session_) {
      ROS_WARN_THROTTLE(5, "%s refused: it is of tracker session %u, %s", loop.c_str(),
                        msg->session,
                        mapper_ ? ("the map is of session " + std::to_string(session_)).c_str()
                                : "there is no map yet");
      return;
    }
    loop::LoopConstraint constraint;
    try {
      constraint = ros_conversions::fromSim3ConstraintMsg(*msg);
    } catch (const std::exception& e) {
      ROS_WARN_THROTTLE(5, "%s refused: %s", loop.c_str(), e.what());
      return;
    }
    mapping::LoopCorrectionStatistics statistics;
    try {
      const map::MapUpdate update = mapper_->closeLoop(constraint, &statistics);
      if (!statistics.applied) {
        const map::Map& map = mapper_->map();
        const map::KeyframeId missing =
            map.hasKeyframe(constraint.loop_id) ? constraint.current_id : constraint.loop_id;
        const bool older = map.numKeyframes() > 0 && missing < map.keyframes().begin()->first;
        ROS_WARN("%s%s", statistics.describe().c_str(),
                 older ? " (made before this map started: the mapper restarted or was reset)" : "");
        return;
      }
      ROS_INFO("%s (scale %.4f, %d inliers)", statistics.describe().c_str(), constraint.scale,
               constraint.num_inliers);
      last_stamp_ = std::max(last_stamp_, msg->header.stamp);
      publishUpdate(update);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "%s not applied: %s", loop.c_str(), e.what());
    }
  }

  void publishUpdate(const map::MapUpdate& update) {
    scale_drift_slam::MapUpdate out = ros_conversions::toMapUpdateMsg(update);
    out.header.stamp = last_stamp_;
    out.session = session_;
    out.mapper_id = mapper_id_;
    update_pub_.publish(out);
    publishMap();
  }

  void publishMap() {
    std_msgs::Header header;
    header.stamp = last_stamp_;
    header.frame_id = params_.map_frame;
    cloud_pub_.publish(ros_conversions::mapCloud(mapper_->map(), T_map_world_, header));
    std::vector<std::pair<map::KeyframeId, map::KeyframeId>> loops;
    for (const loop::PoseGraphEdge& edge : mapper_->loopEdges())
      loops.emplace_back(edge.from, edge.to);
    marker_pub_.publish(ros_conversions::keyframeMarkers(mapper_->map(), loops, T_map_world_,
                                                         header, params_.marker_scale));
  }

  bool onSaveTrajectory(scale_drift_slam::SaveTrajectory::Request& request,
                        scale_drift_slam::SaveTrajectory::Response& response) {
    const std::string path = request.path.empty() ? params_.trajectory_file : request.path;
    std::vector<io::StampedPose> poses;
    if (mapper_) {
      for (const auto& [id, keyframe] : mapper_->map().keyframes())
        poses.push_back({keyframe.timestamp, keyframe.T_kf_world.inverse()});
    }
    try {
      if (path.empty()) throw std::runtime_error("no path given and ~trajectory_file is not set");
      io::saveTumTrajectory(
          path, poses,
          "keyframes as the mapper holds them (window BA, loop corrections), T_world_cam");
      response.success = true;
      response.keyframes = static_cast<std::uint32_t>(poses.size());
      response.message = "wrote " + std::to_string(poses.size()) + " keyframes to " + path;
      ROS_INFO("%s", response.message.c_str());
    } catch (const std::exception& e) {
      response.success = false;
      response.message = e.what();
      ROS_ERROR("~save_trajectory: %s", e.what());
    }
    return true;
  }

  bool onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
    resetMap("~reset was called");
    response.success = true;
    response.message = "map cleared; new mapper id " + std::to_string(mapper_id_);
    return true;
  }

  ros_conversions::MappingNodeConfig config_;
  const ros_conversions::MappingNodeParams& params_;
  geometry::SE3 T_map_world_;
  ros::Subscriber keyframe_sub_, constraint_sub_;
  ros::Publisher update_pub_, cloud_pub_, marker_pub_;
  ros::ServiceServer save_srv_, reset_srv_;

  std::unique_ptr<mapping::Mapper> mapper_;  ///< Made at the first keyframe (its camera).
  std::uint32_t mapper_id_ = 0;
  bool has_session_ = false;
  std::uint32_t session_ = 0;
  ros::Time last_stamp_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "mapping_node");
  ros::NodeHandle nh, pnh("~");
  ros_conversions::MappingNodeConfig config;
  try {
    config = ros_conversions::mappingNodeConfig(ros_conversions::privateParams(pnh));
  } catch (const std::exception& e) {
    ROS_FATAL("mapping_node: invalid parameter, not starting: %s", e.what());
    return 1;
  }
  ROS_INFO("mapping_node parameters:\n%s", ros_conversions::describe(config).c_str());
  for (const std::string& name : config.unknown)
    ROS_WARN("unknown parameter %s is ignored", name.c_str());
  MappingNode node(nh, pnh, std::move(config));
  ros::spin();
  return 0;
}
