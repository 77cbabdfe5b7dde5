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

namespace scale_drift_slam::ros_conversions {

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

/// Streams the images of one topic in bag-time order (one image in memory at a time), each with
/// the CameraInfo of `camera_info_topic` with the same stamp (or the latest stamp before it; the
/// CameraInfo messages, which are small, are read in a first pass). Owns the open bag.
class BagImageReader {
 public:
  /// Throws std::runtime_error for a missing or unreadable bag or a topic with no images.
  BagImageReader(const std::string& path, const std::string& image_topic = "/camera/image_raw",
                 const std::string& camera_info_topic = "/camera/camera_info");
  ~BagImageReader();
  /// The number of images on the topic.
  size_t size() const { return size_; }
  /// The next image; false after the last. Throws std::runtime_error for a message that is not
  /// a sensor_msgs/Image or has an unsupported encoding.
  bool next(BagImage& image);

 private:
  struct State;
  std::unique_ptr<State> state_;
  size_t size_ = 0;
};

/// All images of `image_topic` in stamp order (BagImageReader, collected). Throws as it does.
std::vector<BagImage> readBagImages(const std::string& path,
                                    const std::string& image_topic = "/camera/image_raw",
                                    const std::string& camera_info_topic = "/camera/camera_info");
/// Reads geometry_msgs/PoseStamped messages as a trajectory (T_world_cam per stamp).
std::vector<io::StampedPose> readBagPoses(const std::string& path,
                                          const std::string& topic = "/ground_truth/pose");

}  // namespace scale_drift_slam::ros_conversions
