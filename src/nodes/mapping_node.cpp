// mapping_node: the back-end as a ROS node (doc/ros.md). Owns the global map through the core's
// system::MapperEndpoint (the mapping::Mapper with the session rule SlamSystem uses): each Keyframe
// from the tracking node is added and the sliding-window BA runs; each Sim3Constraint from the
// loop-closure node closes a loop (Sim(3) pose graph, point correction, structure-only BA). Every
// correction goes out as a MapUpdate (to the tracking and loop-closure nodes). Publishes the map as
// a latched PointCloud2 and the keyframes and loop edges as markers. The first keyframe of a new
// tracker session (the tracker was reset or restarted) starts a new map; constraints of another
// session are refused. Services: ~save_trajectory (TUM file of the keyframes), ~reset (a new, empty
// map), ~save_map (a map file, with the parts the tracking and loop-closure nodes hold, asked
// for through their ~get_map_part); ~map_file starts in a saved map (doc/map_file.md, "In ROS").
// Everything runs on the main thread, one message at a time, so the map needs no lock.

#include <filesystem>
#include <optional>
#include <random>
#include <utility>

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include "scale_drift_slam/GetMapPart.h"
#include "scale_drift_slam/SaveMap.h"
#include "scale_drift_slam/SaveTrajectory.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/io/slam_params_io.h"
#include "scale_drift_slam/io/trajectory_io.h"
#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/node_shutdown.h"
#include "scale_drift_slam/ros/slam_messages.h"
#include "scale_drift_slam/ros/visualization.h"
#include "scale_drift_slam/system/map_snapshot.h"
#include "scale_drift_slam/system/mapper_endpoint.h"

namespace {

using namespace scale_drift_slam;

class MappingNode {
 public:
  MappingNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, ros_conversions::MappingNodeConfig config)
      : config_(std::move(config)),
        params_(config_.node),
        T_map_world_(ros_conversions::mapFromWorld(params_.map_z_up)),
        endpoint_(config_.slam.mapper, newMapperId(), config_.slam.messages) {
    if (!params_.map_file.empty()) loadMap();  // throws what is wrong with it: main exits
    keyframe_sub_ =
        nh.subscribe("keyframes", params_.keyframe_queue_size, &MappingNode::onKeyframe, this);
    constraint_sub_ = nh.subscribe("loop_constraints", 10, &MappingNode::onLoopConstraint, this);
    update_pub_ = nh.advertise<scale_drift_slam::MapUpdate>("map_updates", 20);
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
    marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("map_markers", 1, true);
    save_srv_ = pnh.advertiseService("save_trajectory", &MappingNode::onSaveTrajectory, this);
    reset_srv_ = pnh.advertiseService("reset", &MappingNode::onReset, this);
    save_map_srv_ = pnh.advertiseService("save_map", &MappingNode::onSaveMap, this);
    if (endpoint_.map().numKeyframes() > 0) publishMap();
  }

  /// ~save_map_on_shutdown: before ros::shutdown. The tracking and loop-closure nodes stopped at
  /// the same time stay until this node has gone (ros/node_shutdown.h); nodes that have gone
  /// already make the save fail with the reason (doc/map_file.md "In ROS").
  void saveOnShutdown() {
    if (params_.save_map_on_shutdown.empty()) return;
    const std::string path = params_.save_map_on_shutdown == "true" ? params_.save_map_file
                                                                    : params_.save_map_on_shutdown;
    const SaveResult result = saveMap(path, 3.0);
    if (result.success) {
      ROS_INFO("on shutdown: %s", result.message.c_str());
    } else {
      ROS_ERROR("on shutdown: the map was not saved: %s", result.message.c_str());
    }
  }

 private:
  static std::uint32_t newMapperId() { return std::random_device{}() | 1u; }

  /// ~map_file: the saved map, under the session the tracking node restores it with.
  void loadMap() {
    io::MapFile file = io::loadMapFile(params_.map_file);
    const std::uint32_t session = io::mapFileSession(file);
    calibration_ = file.calibration;
    endpoint_.restore(session, file.calibration.meanFocalLength(), std::move(file.snapshot.map),
                      std::move(file.snapshot.loop_edges));
    ROS_INFO("map file %s: %zu keyframes, %zu points, %zu loop edges (session %u); camera %s",
             params_.map_file.c_str(), endpoint_.map().numKeyframes(), endpoint_.map().numPoints(),
             endpoint_.loopEdges().size(), session, file.calibration.describe().c_str());
  }

  struct SaveResult {
    bool success = false;
    std::string message;
    std::size_t keyframes = 0, points = 0, bytes = 0;
  };

  /// The part a node holds (its ~get_map_part), checked to be of this map's session.
  system::MapSnapshot mapPart(const std::string& node, double timeout_s) {
    ros::NodeHandle nh;
    const std::string name = node + "/get_map_part";
    ros::ServiceClient client = nh.serviceClient<scale_drift_slam::GetMapPart>(name);
    if (!client.waitForExistence(ros::Duration(timeout_s))) {
      throw std::runtime_error(nh.resolveName(name) + " is not there (is " + node + " running?)");
    }
    scale_drift_slam::GetMapPart call;
    if (!client.call(call)) throw std::runtime_error(nh.resolveName(name) + " failed");
    if (!call.response.success) throw std::runtime_error(node + ": " + call.response.message);
    if (call.response.session != endpoint_.session()) {
      throw std::runtime_error(node + " is on another map (tracker session " +
                               std::to_string(call.response.session) + ", the mapper's " +
                               std::to_string(endpoint_.session()) + ")");
    }
    ROS_INFO("%s: %s (%zu bytes)", node.c_str(), call.response.message.c_str(),
             call.response.part.size());
    return io::decodeSnapshotPart(
        std::string(call.response.part.begin(), call.response.part.end()));
  }

  /// Joins the map with the tracker's and the loop closer's parts and writes it atomically.
  SaveResult saveMap(const std::string& path, double timeout_s) {
    SaveResult result;
    try {
      if (path.empty()) throw std::runtime_error("no path given and ~save_map_file is not set");
      if (endpoint_.map().numKeyframes() == 0 || !calibration_) {
        throw std::runtime_error("there is no map yet");
      }
      io::MapFile file;
      file.calibration = *calibration_;
      file.params_yaml = io::formatSlamParams(config_.slam);
      file.map_version = endpoint_.map().version();
      file.snapshot = system::joinParts(endpoint_.map(), endpoint_.loopEdges(),
                                        mapPart("tracking_node", timeout_s),
                                        mapPart("loop_closure_node", timeout_s));
      file.snapshot.validate();
      io::saveMapFile(path, file);
      result.keyframes = file.snapshot.map.numKeyframes();
      result.points = file.snapshot.map.numPoints();
      result.bytes = std::filesystem::file_size(path);
      result.success = true;
      result.message = "map saved to " + path + ": " + std::to_string(result.keyframes) +
                       " keyframes, " + std::to_string(result.points) + " points, " +
                       std::to_string(result.bytes) + " bytes";
    } catch (const std::exception& e) {
      result.message = e.what();
    }
    return result;
  }

  bool onSaveMap(scale_drift_slam::SaveMap::Request& request,
                 scale_drift_slam::SaveMap::Response& response) {
    const SaveResult result =
        saveMap(request.path.empty() ? params_.save_map_file : request.path, 10.0);
    response.success = result.success;
    response.message = result.message;
    response.keyframes = static_cast<std::uint32_t>(result.keyframes);
    response.points = static_cast<std::uint32_t>(result.points);
    response.bytes = result.bytes;
    if (result.success) {
      ROS_INFO("%s", result.message.c_str());
    } else {
      ROS_ERROR("~save_map: %s", result.message.c_str());
    }
    return true;
  }

  void onKeyframe(const scale_drift_slam::KeyframeConstPtr& msg) {
    map::KeyframeMessage keyframe;
    try {
      std::string image_problem;  // the mapper needs no image: a bad one is not its business
      keyframe = ros_conversions::fromKeyframeMsg(*msg, &image_problem);
      ros_conversions::calibrationFromCameraInfo(msg->camera);  // its camera must be valid too
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "keyframe %u refused: %s", msg->id, e.what());
      return;
    }
    warnOfMissingKeyframes(*msg);
    const bool had_map = endpoint_.map().numKeyframes() > 0;
    std::string camera;  // described when the keyframe starts a map
    const ros::WallTime start = ros::WallTime::now();
    system::MapperEndpoint::KeyframeOutcome outcome =
        endpoint_.addKeyframe(ros_conversions::envelopeOf(*msg), std::move(keyframe), [&] {
          const geometry::CameraCalibration calibration =
              ros_conversions::calibrationFromCameraInfo(msg->camera);
          camera = calibration.describe();
          calibration_ = calibration;
          return calibration.meanFocalLength();
        });
    const double ms = (ros::WallTime::now() - start).toSec() * 1e3;
    if (!outcome.added) {
      ROS_WARN_THROTTLE(5, "%s: ignored", outcome.refusal.c_str());
      return;
    }
    if (outcome.new_map) {
      if (had_map) {
        ROS_WARN("keyframe %u is of a new tracker session (the tracker was reset or restarted)",
                 msg->id);
        clearPublishedMap();
      }
      ROS_INFO("new map from keyframe %u of session %u; camera %s", msg->id, msg->session,
               camera.c_str());
    }
    last_stamp_ = msg->header.stamp;
    publishUpdate(*outcome.update);
    const features::BundleStatistics& ba = outcome.window_ba;
    ROS_DEBUG(
        "keyframe %u: added in %.1f ms, window BA %.1f ms (%d iterations, RMS %.2f -> %.2f "
        "px, %zu of %zu observations inliers)%s%s",
        msg->id, ms, ba.time_ms, ba.iterations, ba.initial_rmse_px, ba.final_rmse_px,
        ba.num_inliers, ba.num_observations, ba.message.empty() ? "" : ": ", ba.message.c_str());
    if (endpoint_.map().numKeyframes() % 20 == 0) {
      ROS_INFO("map: %zu keyframes, %zu points (keyframe %u, window BA %.1f ms)",
               endpoint_.map().numKeyframes(), endpoint_.map().numPoints(), msg->id, ms);
    }
  }

  /// Keyframe ids of a session are consecutive: a gap is keyframes lost on the way (a link
  /// outage longer than the tracking node's ~keyframe_publish_queue_size covers).
  void warnOfMissingKeyframes(const scale_drift_slam::Keyframe& msg) {
    if (last_keyframe_ && last_keyframe_->first == msg.session &&
        msg.id > last_keyframe_->second + 1) {
      ROS_WARN(
          "keyframes %u to %u of session %u never arrived (dropped on the way: a link "
          "outage longer than the tracking node's ~keyframe_publish_queue_size covers?)",
          last_keyframe_->second + 1, msg.id - 1, msg.session);
    }
    last_keyframe_ = std::make_pair(msg.session, msg.id);
  }

  void onLoopConstraint(const scale_drift_slam::Sim3ConstraintConstPtr& msg) {
    const std::string loop = "loop " + std::to_string(msg->from_keyframe_id) + " -> " +
                             std::to_string(msg->to_keyframe_id);
    loop::LoopConstraint constraint;
    try {
      constraint = ros_conversions::fromSim3ConstraintMsg(*msg);
    } catch (const std::exception& e) {
      ROS_WARN_THROTTLE(5, "%s refused: %s", loop.c_str(), e.what());
      return;
    }
    system::MapperEndpoint::LoopOutcome outcome =
        endpoint_.closeLoop(ros_conversions::envelopeOf(*msg), constraint);
    const mapping::LoopCorrectionStatistics& statistics = outcome.statistics;
    if (outcome.stale || !outcome.refusal.empty()) {
      ROS_WARN_THROTTLE(5, "%s refused: %s", loop.c_str(), statistics.reason.c_str());
      return;
    }
    if (!statistics.applied) {
      const map::Map& map = endpoint_.map();
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
    publishUpdate(*outcome.update);
  }

  void publishUpdate(const system::Addressed<map::MapUpdate>& update) {
    scale_drift_slam::MapUpdate out = ros_conversions::toMapUpdateMsg(update.message);
    out.header.stamp = last_stamp_;
    ros_conversions::setEnvelope(update.from, &out);
    update_pub_.publish(out);
    publishMap();
  }

  /// rviz shows no map until the next keyframe builds one.
  void clearPublishedMap() {
    std_msgs::Header header;
    header.stamp = last_stamp_;
    header.frame_id = params_.map_frame;
    cloud_pub_.publish(ros_conversions::mapCloud(map::Map(), T_map_world_, header));
    marker_pub_.publish(ros_conversions::deleteAllMarkers(header));
  }

  void publishMap() {
    std_msgs::Header header;
    header.stamp = last_stamp_;
    header.frame_id = params_.map_frame;
    cloud_pub_.publish(ros_conversions::mapCloud(endpoint_.map(), T_map_world_, header));
    std::vector<std::pair<map::KeyframeId, map::KeyframeId>> loops;
    for (const loop::PoseGraphEdge& edge : endpoint_.loopEdges())
      loops.emplace_back(edge.from, edge.to);
    marker_pub_.publish(ros_conversions::keyframeMarkers(endpoint_.map(), loops, T_map_world_,
                                                         header, params_.marker_scale));
  }

  bool onSaveTrajectory(scale_drift_slam::SaveTrajectory::Request& request,
                        scale_drift_slam::SaveTrajectory::Response& response) {
    const std::string path = request.path.empty() ? params_.trajectory_file : request.path;
    std::vector<io::StampedPose> poses;
    for (const auto& [id, keyframe] : endpoint_.map().keyframes())
      poses.push_back({keyframe.timestamp, keyframe.T_kf_world.inverse()});
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
    endpoint_.reset(newMapperId());
    ROS_WARN("~reset was called: starting a new map (mapper id %u)", endpoint_.mapperId());
    clearPublishedMap();
    response.success = true;
    response.message = "map cleared; new mapper id " + std::to_string(endpoint_.mapperId());
    return true;
  }

  ros_conversions::MappingNodeConfig config_;
  const ros_conversions::MappingNodeParams& params_;
  geometry::SE3 T_map_world_;
  ros::Subscriber keyframe_sub_, constraint_sub_;
  ros::Publisher update_pub_, cloud_pub_, marker_pub_;
  ros::ServiceServer save_srv_, reset_srv_, save_map_srv_;
  std::optional<geometry::CameraCalibration> calibration_;  ///< The map's camera.

  /// The map and its session rule (system/mapper_endpoint.h), as SlamSystem's mapping thread has.
  system::MapperEndpoint endpoint_;
  ros::Time last_stamp_;
  std::optional<std::pair<std::uint32_t, std::uint32_t>> last_keyframe_;  ///< session, id
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "mapping_node", ros::init_options::NoSigintHandler);
  ros_conversions::catchSigint();
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
  try {
    MappingNode node(nh, pnh, std::move(config));
    // Our own SIGINT handling, so that ~save_map_on_shutdown runs while the node is still up.
    ros_conversions::spinUntilSigint();
    node.saveOnShutdown();
  } catch (const std::exception& e) {  // an unusable ~map_file
    ROS_FATAL("mapping_node: %s", e.what());
    ros::shutdown();
    return 1;
  }
  ros::shutdown();
  return 0;
}
