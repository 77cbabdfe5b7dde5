// tracking_node: the front-end as a ROS node (doc/ros.md). Camera images (image_transport raw,
// or compressed) and a calibration (CameraInfo or ~calibration_file) go into the core's
// tracking::Tracker; out come the pose on tf (map -> odom -> camera body, static body ->
// optical), nav_msgs/Odometry and Path (corrected by loop closures), TrackingStatus, a debug
// image, every new Keyframe and, when lost, RelocalisationRequests. MapUpdates (mapping node) and
// RelocalisationAnswers (loop-closure node) arrive on their own callback queue and thread and wait
// in a common::MessageQueue that the image callback drains before each frame, as
// system::SlamSystem does offline: the camera never waits for the other nodes. Images and
// services run on the main thread.

#include <random>

#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/frames.h"
#include "scale_drift_slam/ros/image_conversions.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/slam_messages.h"
#include "scale_drift_slam/ros/visualization.h"
#include "scale_drift_slam/system/tracker_inbox.h"

namespace {

using namespace scale_drift_slam;

class TrackingNode {
 public:
  TrackingNode(ros::NodeHandle& nh, ros::NodeHandle& pnh,
               ros_conversions::TrackingNodeConfig config)
      : config_(std::move(config)), params_(config_.node), it_(nh), odom_(params_.map_z_up) {
    inbox_.startSession(newSession());
    if (config_.calibration) setCamera(*config_.calibration);
    subscribeImages(nh);
    info_sub_ = nh.subscribe("camera_info", 5, &TrackingNode::onCameraInfo, this);
    ros::SubscribeOptions options = ros::SubscribeOptions::create<scale_drift_slam::MapUpdate>(
        "map_updates", 20,
        [this](const scale_drift_slam::MapUpdateConstPtr& msg) { receive(*msg); }, ros::VoidPtr(),
        &update_queue_);
    update_sub_ = nh.subscribe(options);
    ros::SubscribeOptions answers =
        ros::SubscribeOptions::create<scale_drift_slam::RelocalisationAnswer>(
            "relocalisation_answers", 5,
            [this](const scale_drift_slam::RelocalisationAnswerConstPtr& msg) { receive(*msg); },
            ros::VoidPtr(), &update_queue_);
    answer_sub_ = nh.subscribe(answers);
    keyframe_pub_ = nh.advertise<scale_drift_slam::Keyframe>("keyframes", 20);
    request_pub_ =
        nh.advertise<scale_drift_slam::RelocalisationRequest>("relocalisation_requests", 2);
    status_pub_ = nh.advertise<scale_drift_slam::TrackingStatus>("tracking_status", 10);
    odometry_pub_ = nh.advertise<nav_msgs::Odometry>("odometry", 10);
    path_pub_ = nh.advertise<nav_msgs::Path>("path", 1, true);
    debug_pub_ = it_.advertise("debug_image", 1);
    reset_srv_ = pnh.advertiseService("reset", &TrackingNode::onReset, this);
    if (params_.publish_optical_transform) {
      static_broadcaster_.sendTransform(
          ros_conversions::toTransformStampedMsg(ros_conversions::bodyFromOptical(), ros::Time(0),
                                                 params_.frames.camera, params_.frames.optical));
    }
    update_spinner_.start();
  }
  ~TrackingNode() { update_spinner_.stop(); }  // before the queue it pushes into goes
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
    startSession();
  }

  /// A new map: its keyframes carry a new session, on which the mapper and the loop closer
  /// start afresh; what they still send about the old map is dropped.
  void startSession() {
    inbox_.startSession(newSession());
    odom_.reset();
    path_.clear();
    last_state_.reset();
  }

  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg) {
    if (config_.calibration) return;  // the calibration file wins
    try {
      const geometry::CameraCalibration calibration =
          ros_conversions::calibrationFromCameraInfo(*msg);
      if (!camera_) {
        setCamera(calibration);
      } else if (calibration.describe() != calibration_.describe()) {
        ROS_WARN("the CameraInfo changed (%s)", calibration.describe().c_str());
        setCamera(calibration);
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring the CameraInfo on %s: %s", info_sub_.getTopic().c_str(),
                         e.what());
    }
  }

  void onImage(const sensor_msgs::ImageConstPtr& msg) { process(msg->header, *msg); }
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
    if (!last_stamp_.isZero() && header.stamp <= last_stamp_) {
      if (header.stamp == last_stamp_) {
        ROS_WARN_THROTTLE(5, "dropping an image with the stamp of the previous one (%.6f)",
                          header.stamp.toSec());
        return;
      }
      resetTracker("image time jumped backwards from " + std::to_string(last_stamp_.toSec()) +
                   " to " + std::to_string(header.stamp.toSec()) + " s (bag restarted?)");
    }
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
    try {
      result = tracker_->processFrame(header.stamp.toSec(), image.image, image.encoding);
    } catch (const std::exception& e) {  // the core reports bad frames; anything else is a bug
      ROS_ERROR_THROTTLE(5, "tracking failed on the frame at %.6f s: %s", header.stamp.toSec(),
                         e.what());
      return;
    }
    if (result.map_restarted) {
      ROS_WARN("%s", result.message.c_str());
      startSession();
    }
    publish(header, result, image);
  }

  /// Called on the update thread: convert and queue, never touch the tracker.
  void receive(const scale_drift_slam::MapUpdate& msg) {
    try {
      inbox_.push(system::Addressed<map::MapUpdate>{ros_conversions::envelopeOf(msg),
                                                    ros_conversions::fromMapUpdateMsg(msg)});
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring a map update: %s", e.what());
    }
  }
  void receive(const scale_drift_slam::RelocalisationAnswer& msg) {
    try {
      inbox_.push(system::Addressed<map::RelocalisationAnswer>{
          ros_conversions::envelopeOf(msg), ros_conversions::fromRelocalisationAnswerMsg(msg)});
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring a relocalisation answer: %s", e.what());
    }
  }

  /// Before each frame: the map updates and relocalisation answers that arrived since.
  void applyReceived() {
    const system::TrackerInbox::Report report = inbox_.drain(*tracker_, path_.trajectory());
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
  }

  void publish(const std_msgs::Header& header, const tracking::FrameResult& result,
               const ros_conversions::CameraImage& image) {
    logState(result);
    if (result.loop_correction) {  // the world moved: C (map -> odom) and the whole path follow
      odom_.applyCorrection(*result.loop_correction);
      path_.rebuild();
      path_pub_.publish(path_.message(header.stamp));
      frames_since_path_ = 0;
      ROS_INFO("loop correction applied (scale %.4f): map -> odom and the path moved",
               odom_.correction().scale());
    }
    for (const map::KeyframeMessage& keyframe : result.keyframes) {
      scale_drift_slam::Keyframe msg = ros_conversions::toKeyframeMsg(keyframe);
      ros_conversions::setEnvelope(inbox_.address(keyframe.map_version), &msg);
      msg.camera = camera_info_;
      msg.camera.header.stamp = msg.header.stamp;
      keyframe_pub_.publish(msg);
    }
    if (result.relocalisation_request) publishRequest(*result.relocalisation_request);
    scale_drift_slam::TrackingStatus status = ros_conversions::toTrackingStatusMsg(result);
    status.header.stamp = header.stamp;
    status.header.frame_id = params_.frames.optical;
    status.session = inbox_.session();
    status.keyframes = static_cast<std::uint32_t>(tracker_->trackingMap().numKeyframes());
    status.map_points = static_cast<std::uint32_t>(tracker_->trackingMap().numPoints());
    status.candidates = static_cast<std::uint32_t>(tracker_->numCandidates());
    status.map_version = inbox_.address(tracker_->trackingMap().version()).map_version;
    status_pub_.publish(status);
    if (result.has_pose) {
      path_.add(header.stamp.toSec(), result.T_cam_world, result.reference_keyframe);
      publishPose(header.stamp, result.T_cam_world);
    }
    if (debug_pub_.getNumSubscribers() > 0 && !result.rejected) {
      std_msgs::Header debug_header = header;
      debug_header.frame_id = params_.frames.optical;
      const cv::Mat grey = features::toGrey(image.image, image.encoding);
      debug_pub_.publish(
          ros_conversions::toBgr8Msg(ros_conversions::debugImage(grey, result), debug_header));
    }
  }

  void publishPose(const ros::Time& stamp, const geometry::SE3& T_cam_world) {
    const ros_conversions::CameraTransforms t = odom_.transforms(T_cam_world);
    const ros_conversions::FrameNames& f = params_.frames;
    broadcaster_.sendTransform(
        {ros_conversions::toTransformStampedMsg(t.T_map_odom, stamp, f.map, f.odom),
         ros_conversions::toTransformStampedMsg(t.T_odom_body, stamp, f.odom, f.camera)});
    nav_msgs::Odometry odometry;  // pose only: no covariance or twist is estimated
    odometry.header.stamp = stamp;
    odometry.header.frame_id = f.odom;
    odometry.child_frame_id = f.camera;
    odometry.pose.pose = ros_conversions::toPoseMsg(t.T_odom_body);
    odometry_pub_.publish(odometry);
    if (++frames_since_path_ >= params_.path_publish_every) {
      frames_since_path_ = 0;
      path_pub_.publish(path_.message(stamp));
    }
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

  ros_conversions::TrackingNodeConfig config_;
  const ros_conversions::TrackingNodeParams& params_;
  ros::CallbackQueue update_queue_;  // outlives the subscription that uses it
  image_transport::ImageTransport it_;
  image_transport::Subscriber image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Subscriber compressed_sub_, info_sub_, update_sub_, answer_sub_;
  ros::Publisher keyframe_pub_, request_pub_, status_pub_, odometry_pub_, path_pub_;
  ros::ServiceServer reset_srv_;
  std::string image_topic_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;

  geometry::CameraCalibration calibration_;
  std::shared_ptr<const geometry::CameraModel> camera_;
  sensor_msgs::CameraInfo camera_info_;
  std::unique_ptr<tracking::Tracker> tracker_;
  system::TrackerInbox inbox_;  ///< Map updates and relocalisation answers; the session.
  ros_conversions::OdomFrame odom_;
  ros::Time last_stamp_;
  std::optional<tracking::TrackingState> last_state_;
  ros_conversions::CameraPath path_{odom_.mapFromWorld(), params_.frames.map,
                                    static_cast<std::size_t>(params_.path_max_poses)};
  int frames_since_path_ = 0;
  ros::AsyncSpinner update_spinner_{1, &update_queue_};  // map updates and answers
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "tracking_node");
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
    ros::spin();
  } catch (const std::exception& e) {  // e.g. an image_transport plugin that is not installed
    ROS_FATAL("tracking_node: %s", e.what());
    return 1;
  }
  return 0;
}
