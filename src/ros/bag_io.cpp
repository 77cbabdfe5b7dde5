#include "scale_drift_slam/ros/bag_io.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <stdexcept>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

ros::Time toRosTime(std::int64_t stamp_ns) {
  ros::Time time;
  time.fromNSec(static_cast<std::uint64_t>(stamp_ns));
  return time;
}

cv::Mat imageFromMessage(const sensor_msgs::Image& msg) {
  int type = 0;
  if (msg.encoding == "mono8" || msg.encoding == "8UC1") {
    type = CV_8UC1;
  } else if (msg.encoding == "bgr8" || msg.encoding == "rgb8" || msg.encoding == "8UC3") {
    type = CV_8UC3;
  } else {
    throw std::runtime_error("unsupported image encoding '" + msg.encoding +
                             "' (mono8, bgr8 and rgb8 are read)");
  }
  const size_t row_bytes = static_cast<size_t>(msg.width) * static_cast<size_t>(CV_ELEM_SIZE(type));
  if (msg.step < row_bytes || msg.data.size() < static_cast<size_t>(msg.step) * msg.height) {
    throw std::runtime_error("image message smaller than its width, height and step");
  }
  cv::Mat image(static_cast<int>(msg.height), static_cast<int>(msg.width), type);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(image.ptr(y), &msg.data[static_cast<size_t>(y) * msg.step], row_bytes);
  }
  if (msg.encoding == "rgb8") cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  return image;
}

}  // namespace

SequenceBagWriter::SequenceBagWriter(const std::string& path,
                                     const geometry::CameraCalibration& calibration,
                                     SequenceTopics topics)
    : bag_(std::make_unique<rosbag::Bag>()), calibration_(calibration), topics_(std::move(topics)) {
  try {
    bag_->open(path, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write bag '" + path + "': " + e.what());
  }
}

SequenceBagWriter::~SequenceBagWriter() {
  try {
    bag_->close();
  } catch (...) {  // nothing sensible to do in a destructor
  }
}

void SequenceBagWriter::write(std::int64_t stamp_ns, const cv::Mat& image,
                              const geometry::SE3& T_world_cam) {
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3) {
    throw std::invalid_argument("bag images must be CV_8UC1 or CV_8UC3");
  }
  const ros::Time stamp = toRosTime(stamp_ns);
  std_msgs::Header header;
  header.stamp = stamp;
  header.seq = sequence_++;
  header.frame_id = topics_.camera_frame;

  sensor_msgs::Image msg;
  msg.header = header;
  msg.height = static_cast<std::uint32_t>(image.rows);
  msg.width = static_cast<std::uint32_t>(image.cols);
  msg.encoding = image.channels() == 1 ? "mono8" : "bgr8";
  msg.is_bigendian = 0;
  msg.step = static_cast<std::uint32_t>(image.cols * image.channels());
  msg.data.resize(static_cast<size_t>(msg.step) * msg.height);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(&msg.data[static_cast<size_t>(y) * msg.step], image.ptr(y), msg.step);
  }
  sensor_msgs::CameraInfo info = ros_conversions::cameraInfoFromCalibration(calibration_);
  info.header = header;

  geometry_msgs::PoseStamped pose;
  pose.header = header;
  pose.header.frame_id = topics_.world_frame;
  pose.pose = ros_conversions::toPoseMsg(T_world_cam);

  geometry_msgs::TransformStamped transform;
  transform.header = pose.header;
  transform.child_frame_id = topics_.ground_truth_frame;
  transform.transform = ros_conversions::toTransformMsg(T_world_cam);
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(transform);

  bag_->write(topics_.image, stamp, msg);
  bag_->write(topics_.camera_info, stamp, info);
  bag_->write(topics_.ground_truth, stamp, pose);
  bag_->write("/tf", stamp, tf);
}

struct BagImageReader::State {
  rosbag::Bag bag;
  std::string image_topic;
  std::map<std::int64_t, geometry::CameraCalibration> calibrations;
  std::unique_ptr<rosbag::View> view;
  rosbag::View::iterator it;
};

BagImageReader::BagImageReader(const std::string& path, const std::string& image_topic,
                               const std::string& camera_info_topic)
    : state_(std::make_unique<State>()) {
  try {
    state_->bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read bag '" + path + "': " + e.what());
  }
  state_->image_topic = image_topic;
  for (const rosbag::MessageInstance& m :
       rosbag::View(state_->bag, rosbag::TopicQuery(camera_info_topic))) {
    if (const auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
      state_->calibrations[static_cast<std::int64_t>(info->header.stamp.toNSec())] =
          ros_conversions::calibrationFromCameraInfo(*info);
    }
  }
  state_->view = std::make_unique<rosbag::View>(state_->bag, rosbag::TopicQuery(image_topic));
  size_ = state_->view->size();
  if (size_ == 0) throw std::runtime_error("bag '" + path + "' has no images on " + image_topic);
  state_->it = state_->view->begin();
}

BagImageReader::~BagImageReader() = default;

bool BagImageReader::next(BagImage& image) {
  if (state_->it == state_->view->end()) return false;
  const sensor_msgs::Image::ConstPtr msg = state_->it->instantiate<sensor_msgs::Image>();
  if (!msg) {
    throw std::runtime_error("topic " + state_->image_topic + " does not hold sensor_msgs/Image");
  }
  ++state_->it;
  image.stamp_ns = static_cast<std::int64_t>(msg->header.stamp.toNSec());
  image.timestamp = msg->header.stamp.toSec();
  image.image = imageFromMessage(*msg);
  image.calibration.reset();
  const auto found = state_->calibrations.upper_bound(image.stamp_ns);
  if (found != state_->calibrations.begin()) image.calibration = std::prev(found)->second;
  return true;
}

std::vector<BagImage> readBagImages(const std::string& path, const std::string& image_topic,
                                    const std::string& camera_info_topic) {
  BagImageReader reader(path, image_topic, camera_info_topic);
  std::vector<BagImage> images;
  BagImage image;
  while (reader.next(image))
    images.push_back(image);
  std::stable_sort(images.begin(), images.end(),
                   [](const BagImage& a, const BagImage& b) { return a.stamp_ns < b.stamp_ns; });
  return images;
}

std::vector<io::StampedPose> readBagPoses(const std::string& path, const std::string& topic) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read bag '" + path + "': " + e.what());
  }
  std::vector<io::StampedPose> poses;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topic))) {
    const auto msg = m.instantiate<geometry_msgs::PoseStamped>();
    if (!msg)
      throw std::runtime_error("topic " + topic + " does not hold geometry_msgs/PoseStamped");
    poses.push_back({msg->header.stamp.toSec(), ros_conversions::fromPoseMsg(msg->pose)});
  }
  return poses;
}

}  // namespace scale_drift_slam::ros_conversions
