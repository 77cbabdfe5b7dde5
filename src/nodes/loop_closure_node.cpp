// loop_closure_node: loop detection and relocalisation as a ROS node (doc/ros.md). A thin adapter
// over the core's loop::LoopCloser, exactly as system::SlamSystem's loop thread drives it
// offline: Keyframes (tracking node) and MapUpdates (mapping node) keep its copy of the map; for
// every keyframe it runs place recognition and, for an accepted candidate, loop verification, and
// publishes a verified loop as a Sim3Constraint for the mapping node; it answers the tracking
// node's RelocalisationRequests. The subscriber callbacks (main thread) only convert and queue; one
// worker thread owns the LoopCloser and does the heavy work in arrival order, so no message waits
// in roscpp's queues, and a relocalisation request overtakes the keyframes still queued (a lost
// camera should not wait for a backlog). A keyframe of a new tracker session starts a new
// LoopCloser (with the camera the keyframe carries); a restarted mapping node is followed through
// map version epochs (ros/map_versions.h), the map copy is kept.

#include <thread>
#include <variant>

#include <ros/ros.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/common/message_queue.h"
#include "scale_drift_slam/loop/loop_closer.h"
#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/map_versions.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/slam_messages.h"

namespace {

using namespace scale_drift_slam;

/// What the callbacks hand to the worker: converted, not yet checked against the session.
struct KeyframeInput {
  std::uint32_t session = 0, mapper_id = 0;
  map::KeyframeMessage keyframe;
  sensor_msgs::CameraInfo camera;
  std::string image_problem;  ///< Why the image was left out ("" when fine or absent).
  ros::Time stamp;
};
struct UpdateInput {
  std::uint32_t session = 0, mapper_id = 0;
  map::MapUpdate update;
};
struct RequestInput {
  std::uint32_t session = 0;
  map::RelocalisationRequest request;
  ros::Time stamp;
};
using Input = std::variant<KeyframeInput, UpdateInput, RequestInput>;

class LoopClosureNode {
 public:
  LoopClosureNode(ros::NodeHandle& nh, ros_conversions::LoopClosureNodeConfig config)
      : config_(std::move(config)) {
    keyframe_sub_ = nh.subscribe("keyframes", config_.node.keyframe_queue_size,
                                 &LoopClosureNode::onKeyframe, this);
    update_sub_ = nh.subscribe("map_updates", 100, &LoopClosureNode::onMapUpdate, this);
    request_sub_ = nh.subscribe("relocalisation_requests", 5, &LoopClosureNode::onRequest, this);
    constraint_pub_ = nh.advertise<scale_drift_slam::Sim3Constraint>("loop_constraints", 10);
    answer_pub_ = nh.advertise<scale_drift_slam::RelocalisationAnswer>("relocalisation_answers", 5);
    worker_ = std::thread([this] {
      while (std::optional<Input> input = inbox_.waitPop()) {
        if (!ros::ok()) break;  // shutting down: the backlog is dropped
        try {  // the worker must outlive any message: a refused one is logged and skipped
          std::visit([this](auto& in) { handle(in); }, *input);
        } catch (const std::exception& e) {
          ROS_ERROR_THROTTLE(5, "a message was skipped: %s", e.what());
        }
      }
    });
  }
  ~LoopClosureNode() {
    inbox_.close();
    worker_.join();
  }
  LoopClosureNode(const LoopClosureNode&) = delete;
  LoopClosureNode& operator=(const LoopClosureNode&) = delete;

 private:
  // ---- main thread: convert and queue ----
  void onKeyframe(const scale_drift_slam::KeyframeConstPtr& msg) {
    std::string image_problem;
    map::KeyframeMessage keyframe;
    try {
      keyframe = ros_conversions::fromKeyframeMsg(*msg, &image_problem);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring keyframe %u: %s", msg->id, e.what());
      return;
    }
    queue(KeyframeInput{msg->session, msg->mapper_id, std::move(keyframe), msg->camera,
                        std::move(image_problem), msg->header.stamp});
  }

  void onMapUpdate(const scale_drift_slam::MapUpdateConstPtr& msg) {
    try {
      queue(UpdateInput{msg->session, msg->mapper_id, ros_conversions::fromMapUpdateMsg(*msg)});
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring a map update: %s", e.what());
    }
  }

  void onRequest(const scale_drift_slam::RelocalisationRequestConstPtr& msg) {
    map::RelocalisationRequest request;
    try {
      request = ros_conversions::fromRelocalisationRequestMsg(*msg);
    } catch (const std::exception& e) {  // answered at once: the tracker may ask again
      ROS_ERROR_THROTTLE(5, "cannot relocalise frame %lu: %s",
                         static_cast<unsigned long>(msg->frame_index), e.what());
      map::RelocalisationAnswer failed;
      failed.frame_index = msg->frame_index;
      failed.reason = std::string("unusable request: ") + e.what();
      publishAnswer(failed, msg->session, msg->header.stamp);
      return;
    }
    inbox_.pushUrgent(RequestInput{msg->session, std::move(request), msg->header.stamp});
  }

  void queue(Input input) {
    inbox_.push(std::move(input));
    if (inbox_.size() > 50) {
      ROS_WARN_THROTTLE(10, "loop closure is %zu messages behind", inbox_.size());
    }
  }

  // ---- worker thread: owns the LoopCloser ----
  void handle(KeyframeInput& in) {
    const map::KeyframeId id = in.keyframe.keyframe.id;
    if (!closer_ || in.session != session_) {
      if (!startSession(in)) return;
    } else if (closer_->map().hasKeyframe(id)) {
      ROS_WARN_THROTTLE(5, "keyframe %u is already in the loop closer's map: ignored", id);
      return;
    }
    // Its map version in the loop closer's numbering; a mapper not met yet: no correction due.
    in.keyframe.map_version =
        versions_.toConsumer(in.mapper_id, in.keyframe.map_version).value_or(closer_->mapVersion());
    if (!in.image_problem.empty()) {
      ROS_WARN_THROTTLE(5,
                        "keyframe %u: its image is unusable (%s): stored without it, no loop "
                        "search for it",
                        id, in.image_problem.c_str());
    } else if (in.keyframe.image.empty()) {
      ROS_WARN_THROTTLE(5, "keyframe %u carries no image: stored without it, no loop search for it",
                        id);
    }
    try {
      const loop::LoopDetection detection = closer_->addKeyframe(std::move(in.keyframe));
      if (detection.verification || !detection.recognition.candidates.empty()) {
        ROS_INFO("keyframe %u: %s (%.0f + %.0f ms)", id, detection.describe().c_str(),
                 detection.recognition_ms, detection.verification_ms);
      }
      if (!detection.constraint) return;
      scale_drift_slam::Sim3Constraint out =
          ros_conversions::toSim3ConstraintMsg(*detection.constraint);
      out.header.stamp = in.stamp;
      out.session = session_;
      constraint_pub_.publish(out);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "keyframe %u not added: %s", id, e.what());
    }
  }

  /// A new LoopCloser for the keyframe's session and camera; false (logged) when unusable.
  bool startSession(const KeyframeInput& in) {
    const bool had_session = closer_ != nullptr;
    closer_.reset();
    versions_.reset();
    session_ = in.session;
    try {
      const geometry::CameraCalibration camera =
          ros_conversions::calibrationFromCameraInfo(in.camera);
      closer_ =
          std::make_unique<loop::LoopCloser>(geometry::makeCameraModel(camera), config_.slam.loop);
      const std::string text = "new loop closer from keyframe " +
                               std::to_string(in.keyframe.keyframe.id) + " of tracker session " +
                               std::to_string(in.session) + "; camera " + camera.describe();
      if (had_session) {
        ROS_WARN("%s (a new tracker session: the tracker was reset or restarted)", text.c_str());
      } else {
        ROS_INFO("%s", text.c_str());
      }
      return true;
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "keyframe %u: no loop closer: %s", in.keyframe.keyframe.id, e.what());
      return false;
    }
  }

  void handle(UpdateInput& in) {
    if (!closer_ || in.session != session_) return;  // built from another session's keyframes
    bool new_mapper = false;
    const std::optional<std::uint64_t> version = versions_.toTracker(
        in.mapper_id, in.update.map_version, closer_->mapVersion(), &new_mapper);
    if (new_mapper && closer_->mapVersion() > 0) {
      ROS_WARN(
          "map updates from a new mapper (restarted or reset): keeping the loop closer's "
          "map; loops to keyframes the new mapper does not hold will be refused by it");
    }
    if (!version) return;  // of a retired mapper
    in.update.map_version = *version;
    try {
      closer_->applyMapUpdate(in.update);
      if (in.update.isLoopCorrection()) {
        ROS_INFO("loop correction applied to the loop closer's map (version %lu)",
                 static_cast<unsigned long>(*version));
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "map update not applied: %s", e.what());
    }
  }

  void handle(RequestInput& in) {
    const ros::WallTime start = ros::WallTime::now();
    map::RelocalisationAnswer answer;
    if (!closer_ || in.session != session_) {
      answer.frame_index = in.request.frame_index;
      answer.reason = "the loop closer holds no keyframe of this tracker session";
    } else {
      try {
        answer = closer_->relocalise(in.request);
      } catch (const std::exception& e) {
        answer.frame_index = in.request.frame_index;
        answer.reason = e.what();
      }
    }
    const double ms = (ros::WallTime::now() - start).toSec() * 1e3;
    if (answer.success) {
      ROS_INFO("relocalised frame %lu against keyframe %u: %d inliers (%.0f ms)",
               static_cast<unsigned long>(answer.frame_index), answer.keyframe_id, answer.inliers,
               ms);
    } else {  // a lost tracker asks again at each frame once answered: one line a second
      ROS_INFO_THROTTLE(1, "relocalisation of frame %lu failed: %s (%.0f ms)",
                        static_cast<unsigned long>(answer.frame_index), answer.reason.c_str(), ms);
    }
    publishAnswer(answer, in.session, in.stamp);
  }

  /// Any thread: publishers are thread-safe; versions_ is read only on the worker (or unused).
  void publishAnswer(const map::RelocalisationAnswer& answer, std::uint32_t session,
                     const ros::Time& stamp) {
    scale_drift_slam::RelocalisationAnswer out = ros_conversions::toRelocalisationAnswerMsg(answer);
    out.header.stamp = stamp;
    out.session = session;
    if (answer.success) {
      out.mapper_id = versions_.mapperId();
      out.map_version = versions_.toMapper(answer.map_version);
    }
    answer_pub_.publish(out);
  }

  ros_conversions::LoopClosureNodeConfig config_;
  ros::Subscriber keyframe_sub_, update_sub_, request_sub_;
  ros::Publisher constraint_pub_, answer_pub_;
  common::MessageQueue<Input> inbox_;
  // The worker's:
  std::unique_ptr<loop::LoopCloser> closer_;  ///< Made at a session's first keyframe.
  std::uint32_t session_ = 0;
  ros_conversions::MapVersionTranslator versions_;
  std::thread worker_;  // last: starts after everything it uses
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "loop_closure_node");
  ros::NodeHandle nh, pnh("~");
  ros_conversions::LoopClosureNodeConfig config;
  try {
    config = ros_conversions::loopClosureNodeConfig(ros_conversions::privateParams(pnh));
  } catch (const std::exception& e) {
    ROS_FATAL("loop_closure_node: invalid parameter, not starting: %s", e.what());
    return 1;
  }
  ROS_INFO("loop_closure_node parameters:\n%s", ros_conversions::describe(config).c_str());
  for (const std::string& name : config.unknown)
    ROS_WARN("unknown parameter %s is ignored", name.c_str());
  cv::setNumThreads(1);  // the worker's OpenCV calls stay on its thread
  LoopClosureNode node(nh, std::move(config));
  ros::spin();  // the callbacks only queue: one thread is plenty
  return 0;
}
