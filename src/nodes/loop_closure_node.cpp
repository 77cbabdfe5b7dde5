// loop_closure_node: loop detection and relocalisation as a ROS node (doc/ros.md). A thin adapter
// over the core's loop::LoopCloser, exactly as system::SlamSystem's loop thread drives it
// offline: Keyframes (tracking node) and MapUpdates (mapping node) keep its copy of the map; for
// every keyframe it runs place recognition and, for an accepted candidate, loop verification, and
// publishes a verified loop as a Sim3Constraint for the mapping node; it answers the tracking
// node's RelocalisationRequests. The subscriber callbacks (main thread) only convert and queue; one
// worker thread owns the LoopCloser and does the heavy work in arrival order, so no message waits
// in roscpp's queues, and a relocalisation request overtakes the keyframes still queued (a lost
// camera should not wait for a backlog). The session rule is the core's, as offline
// (system/loop_closer_endpoint.h): the first keyframe of a new tracker session starts a new
// LoopCloser (with the camera the keyframe carries); a restarted mapping node is followed through
// map version epochs (system/map_versions.h), the map copy is kept.

#include <chrono>
#include <future>
#include <thread>
#include <variant>

#include <ros/ros.h>
#include <opencv2/core.hpp>

#include "scale_drift_slam/GetMapPart.h"
#include "scale_drift_slam/common/message_queue.h"
#include "scale_drift_slam/io/map_file.h"
#include "scale_drift_slam/loop/vocabulary.h"
#include "scale_drift_slam/ros/conversions.h"
#include "scale_drift_slam/ros/node_params.h"
#include "scale_drift_slam/ros/node_shutdown.h"
#include "scale_drift_slam/ros/slam_messages.h"
#include "scale_drift_slam/system/loop_closer_endpoint.h"
#include "scale_drift_slam/system/map_snapshot.h"

namespace {

using namespace scale_drift_slam;

/// What the callbacks hand to the worker: converted, not yet checked against the session.
struct KeyframeInput {
  system::Envelope from;
  map::KeyframeMessage keyframe;
  sensor_msgs::CameraInfo camera;
  std::string image_problem;  ///< Why the image was left out ("" when fine or absent).
  ros::Time stamp;
};
struct UpdateInput {
  system::Addressed<map::MapUpdate> update;
};
struct RequestInput {
  system::Addressed<map::RelocalisationRequest> request;
  ros::Time stamp;
};
/// ~get_map_part: the worker answers after the keyframes queued before it.
struct PartInput {
  std::shared_ptr<std::promise<scale_drift_slam::GetMapPart::Response>> reply;
};
using Input = std::variant<KeyframeInput, UpdateInput, RequestInput, PartInput>;

class LoopClosureNode {
 public:
  LoopClosureNode(ros::NodeHandle& nh, ros::NodeHandle& pnh,
                  ros_conversions::LoopClosureNodeConfig config)
      : config_(std::move(config)) {
    if (!config_.node.map_file.empty()) loadMap(config_.node.map_file);  // throws: main exits
    map_part_srv_ = pnh.advertiseService("get_map_part", &LoopClosureNode::onGetMapPart, this);
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
  /// ~map_file (doc/map_file.md, "In ROS"): the database and the map copy of the saved map, under
  /// the session the tracking node restores it with. Before the worker starts.
  void loadMap(const std::string& path) {
    io::MapFile file = io::loadMapFile(path);
    std::shared_ptr<const loop::Vocabulary> vocabulary;
    if (!file.snapshot.vocabulary.empty()) {
      vocabulary = std::make_shared<const loop::Vocabulary>(
          loop::Vocabulary::fromBytes(file.snapshot.vocabulary, "in the map file " + path));
    }
    const std::size_t keyframes = file.snapshot.map.numKeyframes();
    const std::size_t places = file.snapshot.places.size();
    const std::uint32_t session = io::mapFileSession(file);
    endpoint_.restore(session, geometry::makeCameraModel(file.calibration),
                      std::move(file.snapshot.map), std::move(vocabulary),
                      std::move(file.snapshot.places), std::move(file.snapshot.keyframe_images));
    ROS_INFO("map file %s: %zu keyframes, %zu places (session %u); camera %s", path.c_str(),
             keyframes, places, session, file.calibration.describe().c_str());
  }

  // ---- main thread: convert and queue ----
  bool onGetMapPart(scale_drift_slam::GetMapPart::Request&,
                    scale_drift_slam::GetMapPart::Response& response) {
    auto reply = std::make_shared<std::promise<scale_drift_slam::GetMapPart::Response>>();
    std::future<scale_drift_slam::GetMapPart::Response> answer = reply->get_future();
    queue(PartInput{reply});
    try {
      if (answer.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
        throw std::runtime_error("the worker did not answer within 60 s");
      }
      response = answer.get();
    } catch (const std::exception& e) {  // a broken promise: the worker stopped
      response.success = false;
      response.message = std::string("no part of the map: ") + e.what();
    }
    return true;
  }

  void onKeyframe(const scale_drift_slam::KeyframeConstPtr& msg) {
    std::string image_problem;
    map::KeyframeMessage keyframe;
    try {
      keyframe = ros_conversions::fromKeyframeMsg(*msg, &image_problem);
      ros_conversions::calibrationFromCameraInfo(msg->camera);  // its camera must be valid too
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "ignoring keyframe %u: %s", msg->id, e.what());
      return;
    }
    queue(KeyframeInput{ros_conversions::envelopeOf(*msg), std::move(keyframe), msg->camera,
                        std::move(image_problem), msg->header.stamp});
  }

  void onMapUpdate(const scale_drift_slam::MapUpdateConstPtr& msg) {
    try {
      queue(UpdateInput{
          {ros_conversions::envelopeOf(*msg), ros_conversions::fromMapUpdateMsg(*msg)}});
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
      publishAnswer({system::Envelope{msg->session, 0, 0}, failed}, msg->header.stamp);
      return;
    }
    inbox_.pushUrgent(
        RequestInput{{ros_conversions::envelopeOf(*msg), std::move(request)}, msg->header.stamp});
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
    if (!in.image_problem.empty()) {
      ROS_WARN_THROTTLE(5,
                        "keyframe %u: its image is unusable (%s): stored without it, no loop "
                        "search for it",
                        id, in.image_problem.c_str());
    } else if (in.keyframe.image.empty()) {
      ROS_WARN_THROTTLE(5, "keyframe %u carries no image: stored without it, no loop search for it",
                        id);
    }
    const bool had_session = endpoint_.closer() != nullptr;
    std::string camera;  // described when the keyframe starts a session
    const system::LoopCloserEndpoint::KeyframeOutcome outcome =
        endpoint_.addKeyframe(in.from, std::move(in.keyframe), [&] {
          const geometry::CameraCalibration calibration =
              ros_conversions::calibrationFromCameraInfo(in.camera);
          camera = calibration.describe();
          return geometry::makeCameraModel(calibration);
        });
    if (!outcome.added) {
      ROS_WARN_THROTTLE(5, "%s: ignored", outcome.refusal.c_str());
      return;
    }
    if (outcome.new_session) {
      const std::string text = "new loop closer from keyframe " + std::to_string(id) +
                               " of tracker session " + std::to_string(in.from.session) +
                               "; camera " + camera;
      if (had_session) {
        ROS_WARN("%s (a new tracker session: the tracker was reset or restarted)", text.c_str());
      } else {
        ROS_INFO("%s", text.c_str());
      }
    }
    const loop::LoopDetection& detection = *outcome.detection;
    if (detection.verification || !detection.recognition.candidates.empty()) {
      ROS_INFO("keyframe %u: %s (%.0f + %.0f ms)", id, detection.describe().c_str(),
               detection.recognition_ms, detection.verification_ms);
    }
    if (!outcome.constraint) return;
    scale_drift_slam::Sim3Constraint out =
        ros_conversions::toSim3ConstraintMsg(outcome.constraint->message);
    out.header.stamp = in.stamp;
    ros_conversions::setEnvelope(outcome.constraint->from, &out);
    constraint_pub_.publish(out);
  }

  void handle(UpdateInput& in) {
    const bool loop_correction = in.update.message.isLoopCorrection();
    const system::LoopCloserEndpoint::UpdateOutcome outcome =
        endpoint_.applyMapUpdate(in.update.from, std::move(in.update.message));
    if (!outcome.refusal.empty()) {
      ROS_WARN_THROTTLE(5, "refused: %s (ignored)", outcome.refusal.c_str());
      return;
    }
    if (outcome.new_mapper) {
      ROS_WARN(
          "map updates from a new mapper (restarted or reset): keeping the loop closer's "
          "map; loops to keyframes the new mapper does not hold will be refused by it");
    }
    if (outcome.applied && loop_correction) {
      ROS_INFO("loop correction applied to the loop closer's map (version %lu)",
               static_cast<unsigned long>(endpoint_.closer()->mapVersion()));
    }
  }

  void handle(RequestInput& in) {
    const ros::WallTime start = ros::WallTime::now();
    system::Addressed<map::RelocalisationAnswer> answer;
    try {
      answer = endpoint_.relocalise(in.request.from, in.request.message);
    } catch (const std::exception& e) {
      answer = {system::Envelope{in.request.from.session, 0, 0}, {}};
      answer.message.frame_index = in.request.message.frame_index;
      answer.message.reason = e.what();
    }
    const map::RelocalisationAnswer& a = answer.message;
    const double ms = (ros::WallTime::now() - start).toSec() * 1e3;
    if (a.success) {
      ROS_INFO("relocalised frame %lu against keyframe %u: %d inliers (%.0f ms)",
               static_cast<unsigned long>(a.frame_index), a.keyframe_id, a.inliers, ms);
    } else {  // a lost tracker asks again at each frame once answered: one line a second
      ROS_INFO_THROTTLE(1, "relocalisation of frame %lu failed: %s (%.0f ms)",
                        static_cast<unsigned long>(a.frame_index), a.reason.c_str(), ms);
    }
    publishAnswer(answer, in.stamp);
  }

  void handle(PartInput& in) {
    scale_drift_slam::GetMapPart::Response response;
    response.session = endpoint_.session();
    try {
      if (const loop::LoopCloser* closer = endpoint_.closer()) {
        const system::MapSnapshot part = system::loopCloserPart(*closer);
        const std::string bytes = io::encodeSnapshotPart(part);
        response.part.assign(bytes.begin(), bytes.end());
        response.success = true;
        response.message = std::to_string(part.places.size()) + " places, " +
                           (part.vocabulary.empty() ? "no vocabulary yet" : "the vocabulary");
      } else {
        response.message = "the loop-closure node has no keyframe yet";
      }
    } catch (const std::exception& e) {
      response.success = false;
      response.message = e.what();
    }
    in.reply->set_value(std::move(response));
  }

  /// Any thread: publishers are thread-safe.
  void publishAnswer(const system::Addressed<map::RelocalisationAnswer>& answer,
                     const ros::Time& stamp) {
    scale_drift_slam::RelocalisationAnswer out =
        ros_conversions::toRelocalisationAnswerMsg(answer.message);
    out.header.stamp = stamp;
    ros_conversions::setEnvelope(answer.from, &out);
    answer_pub_.publish(out);
  }

  ros_conversions::LoopClosureNodeConfig config_;
  ros::Subscriber keyframe_sub_, update_sub_, request_sub_;
  ros::Publisher constraint_pub_, answer_pub_;
  ros::ServiceServer map_part_srv_;
  common::MessageQueue<Input> inbox_;
  /// The worker's: the loop closer and its session rule (system/loop_closer_endpoint.h).
  system::LoopCloserEndpoint endpoint_{config_.slam.loop, config_.slam.messages};
  std::thread worker_;  // last: starts after everything it uses
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "loop_closure_node", ros::init_options::NoSigintHandler);
  ros_conversions::catchSigint();
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
  try {
    LoopClosureNode node(nh, pnh, std::move(config));
    ros_conversions::spinUntilSigint();  // the callbacks only queue (~get_map_part waits for
                                         // the worker)
    const std::string stayed = ros_conversions::stayForMapSaveOnShutdown();
    if (!stayed.empty()) ROS_INFO("on shutdown: %s", stayed.c_str());
  } catch (const std::exception& e) {  // an unusable ~map_file
    ROS_FATAL("loop_closure_node: %s", e.what());
    return 1;
  }
  return 0;
}
