// tracking_node: the front-end as a ROS node (doc/ros.md). Camera images (image_transport raw,
// or compressed) and a calibration (CameraInfo or ~calibration_file) go into the core's
// tracking::Tracker; out come the pose on tf (map -> odom -> base -> camera body, static body ->
// optical; doc/ros.md "tf on a robot"), nav_msgs/Odometry (covariance, twist) and Path
// (corrected by loop closures), TrackingStatus, a debug
// image, every new Keyframe and, when lost, RelocalisationRequests. MapUpdates (mapping node) and
// RelocalisationAnswers (loop-closure node) arrive on their own callback queue and thread and wait
// in a common::MessageQueue that the image callback drains before each frame, as
// system::SlamSystem does offline: the camera never waits for the other nodes. Images and
// services run on the main thread.

#include <random>

#include <image_transport/image_transport.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/GetMapPart.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/image_conversions.h"
#include "scale_drift_slam/ros/image_stamps.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/node_shutdown.h"
#include "scale_drift_slam/ros/pose_publisher.h"
#include "scale_drift_slam/ros/slam_messages.h"
#include "scale_drift_slam/ros/visualization.h"
#include "scale_drift_slam/system/map_snapshot.h"
#include "scale_drift_slam/system/tracker_inbox.h"

namespace {

using namespace scale_drift_slam;

class TrackingNode {
 public:
  TrackingNode(ros::NodeHandle& nh, ros::NodeHandle& pnh,
               ros_conversions::TrackingNodeConfig config)
      : config_(std::move(config)), params_(config_.node), it_(nh), poses_(nh, params_) {
    inbox_.startSession(newSession());
    if (!params_.map_file.empty()) loadMap();  // throws what is wrong with it: main exits
    if (config_.calibration) setCamera(*config_.calibration);
    subscribeImages(nh);
    info_sub_ = nh.subscribe("camera_info", 5, &TrackingNode::onCameraInfo, this);
    update_sub_ =
        subscribeToInbox(nh, "map_updates", 20, &ros_conversions::fromMapUpdateMsg, "a map update");
    answer_sub_ =
        subscribeToInbox(nh, "relocalisation_answers", 5,
                         &ros_conversions::fromRelocalisationAnswerMsg, "a relocalisation answer");
    keyframe_pub_ =
        nh.advertise<scale_drift_slam::Keyframe>("keyframes", params_.keyframe_publish_queue_size);
    request_pub_ =
        nh.advertise<scale_drift_slam::RelocalisationRequest>("relocalisation_requests", 2);
    status_pub_ = nh.advertise<scale_drift_slam::TrackingStatus>("tracking_status", 10);
    debug_pub_ = it_.advertise("debug_image", 1);
    reset_srv_ = pnh.advertiseService("reset", &TrackingNode::onReset, this);
    map_part_srv_ = pnh.advertiseService("get_map_part", &TrackingNode::onGetMapPart, this);
    // Wall time: with use_sim_time the clock stops when a bag ends, the last keyframe must not.
    keyframe_timer_ =
        nh.createWallTimer(ros::WallDuration(0.01), &TrackingNode::onKeyframeTimer, this);
    update_spinner_.start();
  }
  ~TrackingNode() { update_spinner_.stop(); }  // before the queue it pushes into goes

  /// Takes no more images (on shutdown, while the mapping node may still ask for the map).
  void stopTracking() {
    image_sub_.shutdown();
    compressed_sub_.shutdown();
  }
  TrackingNode(const TrackingNode&) = delete;
  TrackingNode& operator=(const TrackingNode&) = delete;

 private:
  void subscribeImages(ros::NodeHandle& nh) {
    const std::string topic = nh.resolveName("image");
    image_topic_ = topic;
    if (params_.transport == "compressed") {  // decoded here: Debian ships no compressed plugin
      image_topic_ = topic + "/compressed";
      compressed_sub_ = nh.subscribe(image_topic_, params_.image_queue_size,
                                     &TrackingNode::onCompressedImage, this);
    } else {
      image_sub_ = it_.subscribe(topic, params_.image_queue_size, &TrackingNode::onImage, this,
                                 image_transport::TransportHints(params_.transport));
    }
    ROS_INFO("tracking images on %s (transport %s)", topic.c_str(), params_.transport.c_str());
  }

  /// Map updates and relocalisation answers arrive on the update queue's own thread: there they
  /// are only converted and queued in the inbox, never applied to the tracker.
  template <typename Message, typename Core>
  ros::Subscriber subscribeToInbox(ros::NodeHandle& nh, const std::string& topic, int queue_size,
                                   Core (*convert)(const Message&), const char* what) {
    ros::SubscribeOptions options = ros::SubscribeOptions::create<Message>(
        topic, queue_size,
        [this, convert, what](const boost::shared_ptr<const Message>& msg) {
          try {
            inbox_.push(system::Addressed<Core>{ros_conversions::envelopeOf(*msg), convert(*msg)});
          } catch (const std::exception& e) {
            ROS_ERROR_THROTTLE(5, "ignoring %s: %s", what, e.what());
          }
        },
        ros::VoidPtr(), &update_queue_);
    return nh.subscribe(options);
  }

  static std::uint32_t newSession() { return std::random_device{}() | 1u; }

  void setCamera(const geometry::CameraCalibration& calibration) {
    calibration_ = calibration;
    camera_ = geometry::makeCameraModel(calibration);
    camera_info_ = ros_conversions::cameraInfoFromCalibration(calibration);
    camera_info_.header.frame_id = params_.frames.optical;
    ROS_INFO("camera: %s", calibration.describe().c_str());
    resetTracker("");
  }

  void resetTracker(const std::string& why) {
    if (!why.empty()) ROS_WARN("resetting the tracker: %s", why.c_str());
    tracker_ = std::make_unique<tracking::Tracker>(camera_, config_.slam.tracker);
    if (loaded_map_) {
      restoreLoadedMap();
      return;
    }
    startSession();
  }

  /// ~map_file (doc/map_file.md, "In ROS"): read and checked at start, restored into each new
  /// tracker once the camera is known.
  void loadMap() {
    loaded_map_ = io::loadMapFile(params_.map_file);
    if (config_.calibration) {
      io::checkMapCamera(*loaded_map_, *config_.calibration, params_.map_file);
    }
    ROS_INFO("map file %s: %zu keyframes, %zu points (session %u)%s", params_.map_file.c_str(),
             loaded_map_->snapshot.map.numKeyframes(), loaded_map_->snapshot.map.numPoints(),
             io::mapFileSession(*loaded_map_),
             params_.localization_only ? "; localization only: no keyframe will be made" : "");
  }

  /// The tracker starts lost in the loaded map, under the session the mapping and loop-closure
  /// nodes restored it with, and asks for relocalisation. Localisation only: every later reset
  /// (~reset, a time jump) comes back to it; mapping: a later reset starts a new map as usual.
  void restoreLoadedMap() {
    const io::MapFile& file = *loaded_map_;
    try {
      io::checkMapCamera(file, calibration_, params_.map_file);
    } catch (const io::MapFileError& e) {
      ROS_FATAL("%s: not tracking, shutting down", e.what());
      tracker_.reset();
      ros::shutdown();
      return;
    }
    std::vector<std::pair<map::KeyframeId, map::KeyframeId>> loop_links;
    for (const loop::PoseGraphEdge& edge : file.snapshot.loop_edges)
      loop_links.emplace_back(edge.from, edge.to);
    tracker_->restoreMap(file.snapshot.map, file.snapshot.point_appearances, loop_links);
    tracker_->setLocalizationOnly(params_.localization_only);
    inbox_.startSession(io::mapFileSession(file));
    poses_.reset();
    last_state_.reset();
    ROS_INFO("tracking in the map of %s: lost until relocalised by place recognition",
             params_.map_file.c_str());
    if (!params_.localization_only) loaded_map_.reset();
  }

  /// A new map: its keyframes carry a new session, on which the mapper and the loop closer
  /// start afresh; what they still send about the old map is dropped.
  void startSession() {
    inbox_.startSession(newSession());
    poses_.reset();
    last_state_.reset();
  }

  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg) {
    if (config_.calibration) return;  // the calibration file wins
    try {
      geometry::CameraCalibration calibration = ros_conversions::calibrationFromCameraInfo(*msg);
      calibration.rolling_shutter_readout_s = params_.rolling_shutter_readout_s;
      if (!camera_) {
        setCamera(calibration);
      } else if (!calibration.sameCameraAs(calibration_)) {  // jitter below 0.5 px is ignored
        ROS_WARN("the CameraInfo changed (%s): tracking restarts", calibration.describe().c_str());
        setCamera(calibration);
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring the CameraInfo on %s: %s", info_sub_.getTopic().c_str(),
                         e.what());
    }
  }

  void onImage(const sensor_msgs::ImageConstPtr& msg) { process(msg->header, msg); }  // shared
  void onCompressedImage(const sensor_msgs::CompressedImageConstPtr& msg) {
    process(msg->header, *msg);
  }

  template <typename Message>
  void process(const std_msgs::Header& header, const Message& msg) {
    if (!tracker_) {
      ROS_WARN_THROTTLE(5,
                        "no calibration yet: waiting for a valid CameraInfo on %s (or set "
                        "~calibration_file); images are dropped",
                        info_sub_.getTopic().c_str());
      return;
    }
    const ros_conversions::ImageStampCheck stamp_check =
        ros_conversions::checkImageStamp(last_stamp_, header.stamp, params_.time_jump_restart_s);
    if (stamp_check.duplicate || !stamp_check.drop_reason.empty()) {
      ROS_WARN_THROTTLE(5, "%s",
                        stamp_check.duplicate
                            ? "dropping an image with the stamp of the previous one"
                            : stamp_check.drop_reason.c_str());
      return;
    }
    if (!stamp_check.restart_reason.empty()) resetTracker(stamp_check.restart_reason);
    ros_conversions::CameraImage image;
    try {
      image = ros_conversions::cameraImageFromMsg(msg);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "dropping images on %s: %s", image_topic_.c_str(), e.what());
      return;
    }
    last_stamp_ = header.stamp;
    applyReceived();
    tracking::FrameResult result;
    const int mono16_bits = tracker_->mono16BitDepth();
    try {
      result = tracker_->processFrame(header.stamp.toSec(), image.image, image.encoding);
    } catch (const std::exception& e) {  // the core reports bad frames; anything else is a bug
      ROS_ERROR_THROTTLE(5, "tracking failed on the frame at %.6f s: %s", header.stamp.toSec(),
                         e.what());
      return;
    }
    if (tracker_->mono16BitDepth() != mono16_bits) {
      ROS_INFO("%s", tracker_->describeMono16BitDepth().c_str());
    }
    if (result.map_restarted) {
      ROS_WARN("%s", result.message.c_str());
      startSession();
    }
    publish(header, result, image);
  }

  /// Before each frame: the map updates and relocalisation answers that arrived since.
  void applyReceived() {
    const system::TrackerInbox::Report report = inbox_.drain(*tracker_, poses_.trajectory());
    if (report.new_mapper) {
      ROS_WARN(
          "map updates from a new mapper (restarted or reset): keeping the tracker's map, "
          "continuing with the new mapper's versions");
    }
    if (report.relocalised) {
      ROS_INFO("relocalised against keyframe %u (%d inliers): tracking resumes",
               report.relocalised->keyframe_id, report.relocalised->inliers);
    } else if (!report.relocalisation_failure.empty()) {
      ROS_INFO_THROTTLE(5, "no relocalisation yet: %s", report.relocalisation_failure.c_str());
    }
    for (const std::string& refusal : report.refused)
      ROS_WARN_THROTTLE(5, "refused: %s (ignored)", refusal.c_str());
  }

  void publish(const std_msgs::Header& header, const tracking::FrameResult& result,
               const ros_conversions::CameraImage& image) {
    logState(result);
    if (result.loop_correction) {  // the world moved: C (map -> odom) and the whole path follow
      poses_.applyCorrection(*result.loop_correction, header.stamp);
      ROS_INFO("loop correction applied (scale %.4f): map -> odom and the path moved",
               poses_.correction().scale());
    }
    publishKeyframes(result.keyframes);
    if (result.relocalisation_request) publishRequest(*result.relocalisation_request);
    status_pub_.publish(ros_conversions::toTrackingStatusMsg(
        result, *tracker_, inbox_.address(tracker_->trackingMap().version()), header.stamp,
        params_.frames.optical));
    if (result.has_pose)
      poses_.publish(header.stamp, result.T_cam_world, result.reference_keyframe,
                     result.pose_information);
    if (debug_pub_.getNumSubscribers() > 0 && !result.rejected) {
      debug_pub_.publish(
          ros_conversions::debugImageMsg(image, result, header, params_.frames.optical));
    }
  }

  void publishKeyframes(const std::vector<map::KeyframeMessage>& keyframes) {
    for (const map::KeyframeMessage& keyframe : keyframes) {
      keyframe_pub_.publish(ros_conversions::toKeyframeMsg(
          keyframe, inbox_.address(keyframe.map_version), camera_info_));
    }
  }

  /// A keyframe whose points the tracker's worker has found (tracker.keyframe_worker) goes out
  /// now, not with the next image (at the end of a bag there is none). In the image callback's
  /// thread: no map update is applied to the tracker between the keyframe's frame and this.
  void onKeyframeTimer(const ros::WallTimerEvent&) {
    if (tracker_ && tracker_->keyframeReady()) publishKeyframes(tracker_->finishKeyframes());
  }

  void publishRequest(const map::RelocalisationRequest& request) {
    scale_drift_slam::RelocalisationRequest msg =
        ros_conversions::toRelocalisationRequestMsg(request);
    ros_conversions::setEnvelope(inbox_.address(request.map_version), &msg);
    request_pub_.publish(msg);
    ROS_INFO_THROTTLE(5, "lost: relocalisation of frame %lu requested",
                      static_cast<unsigned long>(request.frame_index));
  }

  /// Logs state changes and rejected frames (throttled), not every frame.
  void logState(const tracking::FrameResult& result) {
    if (result.rejected) {
      ROS_WARN_THROTTLE(5, "%s", result.message.c_str());
      return;
    }
    if (last_state_ != result.state) {
      ROS_INFO("tracking: %s%s%s", tracking::trackingStateName(result.state).c_str(),
               result.message.empty() ? "" : " - ", result.message.c_str());
      last_state_ = result.state;
    }
  }

  bool onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
    if (!camera_) {
      response.message = "no camera yet: nothing to reset";
    } else {
      resetTracker("~reset was called");
      response.message = "tracker reset; new session " + std::to_string(inbox_.session());
    }
    response.success = true;
    return true;
  }

  /// ~get_map_part: the tracker's point appearances, for the mapping node's ~save_map.
  bool onGetMapPart(scale_drift_slam::GetMapPart::Request&,
                    scale_drift_slam::GetMapPart::Response& response) {
    response.session = inbox_.session();
    if (!tracker_) {
      response.success = false;
      response.message = "the tracking node has no camera yet, hence no map";
      return true;
    }
    publishKeyframes(tracker_->finishKeyframes());  // the map part holds all of the keyframe
    const system::MapSnapshot part = system::trackerPart(*tracker_);
    const std::string bytes = io::encodeSnapshotPart(part);
    response.part.assign(bytes.begin(), bytes.end());
    response.success = true;
    response.message = std::to_string(part.point_appearances.size()) + " point appearances";
    return true;
  }

  ros_conversions::TrackingNodeConfig config_;
  const ros_conversions::TrackingNodeParams& params_;
  ros::CallbackQueue update_queue_;  // outlives the subscription that uses it
  image_transport::ImageTransport it_;
  image_transport::Subscriber image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Subscriber compressed_sub_, info_sub_, update_sub_, answer_sub_;
  ros::Publisher keyframe_pub_, request_pub_, status_pub_;
  ros::ServiceServer reset_srv_, map_part_srv_;
  ros::WallTimer keyframe_timer_;
  std::optional<io::MapFile> loaded_map_;  ///< ~map_file, until restored (kept: localization)
  std::string image_topic_;
  ros_conversions::PosePublisher poses_;  ///< tf, odometry and path; the loop correction.

  geometry::CameraCalibration calibration_;
  std::shared_ptr<const geometry::CameraModel> camera_;
  sensor_msgs::CameraInfo camera_info_;
  std::unique_ptr<tracking::Tracker> tracker_;
  system::TrackerInbox inbox_{
      config_.slam.messages};  ///< Map updates and relocalisation answers; the session.
  ros::Time last_stamp_;
  std::optional<tracking::TrackingState> last_state_;
  ros::AsyncSpinner update_spinner_{1, &update_queue_};  // map updates and answers
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "tracking_node", ros::init_options::NoSigintHandler);
  ros_conversions::catchSigint();
  ros::NodeHandle nh, pnh("~");
  ros_conversions::TrackingNodeConfig config;
  try {
    config = ros_conversions::trackingNodeConfig(ros_conversions::privateParams(pnh));
  } catch (const std::exception& e) {
    ROS_FATAL("tracking_node: invalid parameter, not starting: %s", e.what());
    return 1;
  }
  ROS_INFO("tracking_node parameters:\n%s", ros_conversions::describe(config).c_str());
  for (const std::string& name : config.unknown)
    ROS_WARN("unknown parameter %s is ignored", name.c_str());
  cv::setNumThreads(1);  // one core for tracking; the mapping node has the other
  try {
    TrackingNode node(nh, pnh, std::move(config));
    ros_conversions::spinUntilSigint();
    node.stopTracking();  // the map stays as the mapping node may save it
    const std::string stayed = ros_conversions::stayForMapSaveOnShutdown();
    if (!stayed.empty()) ROS_INFO("on shutdown: %s", stayed.c_str());
  } catch (const std::exception& e) {  // e.g. an image_transport plugin that is not installed
    ROS_FATAL("tracking_node: %s", e.what());
    return 1;
  }
  return 0;
}
