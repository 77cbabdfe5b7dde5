#pragma once
// Image sequences in rosbags: writing rendered sequences with their ground truth, and reading
// images (+ CameraInfo) back by topic, for the offline runner and the tests.
//
// Written layout (all messages of a frame carry the same stamp, also as the bag time):
//   /camera/image_raw      sensor_msgs/Image (mono8 or bgr8), frame_id "camera"
//   /camera/camera_info    sensor_msgs/CameraInfo (plumb_bob or equidistant), frame_id "camera"
//   /ground_truth/pose     geometry_msgs/PoseStamped, the camera pose in "world" (T_world_cam)
//   /tf                    tf2_msgs/TFMessage: "world" -> "camera_ground_truth" (= T_world_cam)

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "scale_drift_slam/geometry/camera_calibration.h"
#include "scale_drift_slam/geometry/se3.h"
#include "scale_drift_slam/io/trajectory_io.h"

namespace rosbag {
class Bag;
}

namespace scale_drift_slam::ros_bag {

struct SequenceTopics {
  std::string image = "/camera/image_raw";
  std::string camera_info = "/camera/camera_info";
  std::string ground_truth = "/ground_truth/pose";
  std::string world_frame = "world";
  std::string camera_frame = "camera";
  std::string ground_truth_frame = "camera_ground_truth";
};

/// Writes a sequence frame by frame. Owns the open bag (closed by the destructor).
class SequenceBagWriter {
 public:
  /// Opens (truncates) the bag. Throws std::runtime_error when it cannot be written.
  SequenceBagWriter(const std::string& path, const geometry::CameraCalibration& calibration,
                    SequenceTopics topics = {});
  ~SequenceBagWriter();
  /// Writes one frame's image (CV_8UC1 -> mono8, CV_8UC3 -> bgr8), CameraInfo, pose and tf.
  void write(std::int64_t stamp_ns, const cv::Mat& image, const geometry::SE3& T_world_cam);

 private:
  std::unique_ptr<rosbag::Bag> bag_;
  geometry::CameraCalibration calibration_;
  SequenceTopics topics_;
  std::uint32_t sequence_ = 0;
};

/// One image read from a bag, with the CameraInfo of the same stamp when there is one.
struct BagImage {
  std::int64_t stamp_ns = 0;  ///< Header stamp.
  double timestamp = 0.0;     ///< The same in seconds.
  cv::Mat image;              ///< CV_8UC1 (mono8) or CV_8UC3 (bgr8; rgb8 is converted).
  std::optional<geometry::CameraCalibration> calibration;
};

/// Reads all images of `image_topic` in stamp order, attaching the CameraInfo of
/// `camera_info_topic` with the same stamp (or the latest before it). Throws std::runtime_error
/// for a missing or unreadable bag, a topic with no images, or an unsupported encoding.
std::vector<BagImage> readBagImages(const std::string& path,
                                    const std::string& image_topic = "/camera/image_raw",
                                    const std::string& camera_info_topic = "/camera/camera_info");
/// Reads geometry_msgs/PoseStamped messages as a trajectory (T_world_cam per stamp).
std::vector<io::StampedPose> readBagPoses(const std::string& path,
                                          const std::string& topic = "/ground_truth/pose");

}  // namespace scale_drift_slam::ros_bag
