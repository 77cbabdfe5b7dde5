#include "scale_drift_slam/ros/bag_image_sequence.h"

#include <stdexcept>

#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

class BagImageSequence : public io::ImageSequence {
 public:
  BagImageSequence(const std::string& path, const std::string& image_topic,
                   const std::string& camera_info_topic)
      : path_(path) {
    try {
      bag_.open(path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error("bag '" + path + "': " + e.what());
    }
    view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(image_topic));
    size_ = view_->size();
    if (size_ == 0) {
      std::string topics;
      rosbag::View all(bag_);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) {
        if (c->datatype == "sensor_msgs/Image" || c->datatype == "sensor_msgs/CompressedImage") {
          topics += (topics.empty() ? "" : ", ") + c->topic;
        }
      }
      throw std::runtime_error("bag '" + path + "' has no message on '" + image_topic +
                               "' (image topics: " + (topics.empty() ? "none" : topics) + ")");
    }
    rosbag::View info_view(bag_, rosbag::TopicQuery(camera_info_topic));
    for (const rosbag::MessageInstance& m : info_view) {
      if (const auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
        calibration_ = ros_conversions::calibrationFromCameraInfo(*info);
        break;
      }
    }
    it_ = view_->begin();
  }

  std::optional<io::SequenceFrame> next() override {
    while (it_ != view_->end()) {
      // Read the message before advancing: the iterator owns the instance it points to.
      const rosbag::MessageInstance& m = *it_;
      const auto image = m.instantiate<sensor_msgs::Image>();
      const auto compressed = image ? nullptr : m.instantiate<sensor_msgs::CompressedImage>();
      io::SequenceFrame frame;
      frame.source = path_ + ":" + m.getTopic();
      ++it_;
      if (image) {
        frame.timestamp = image->header.stamp.toSec();
        frame.encoding = image->encoding;
        try {
          frame.image = cv_bridge::toCvCopy(image)->image;  // keeps the encoding
        } catch (const std::exception&) {
          frame.image = cv::Mat();  // unreadable: the SLAM rejects the empty frame
        }
        return frame;
      }
      if (compressed) {
        frame.timestamp = compressed->header.stamp.toSec();
        frame.image = cv::imdecode(compressed->data, cv::IMREAD_UNCHANGED);
        return frame;
      }
    }
    return std::nullopt;
  }

  std::size_t size() const override { return size_; }
  std::optional<geometry::CameraCalibration> calibration() const override { return calibration_; }
  std::string describe() const override { return "bag of " + std::to_string(size_) + " images"; }

 private:
  std::string path_;
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  std::size_t size_ = 0;
  std::optional<geometry::CameraCalibration> calibration_;
};

}  // namespace

std::unique_ptr<io::ImageSequence> openBagImageSequence(const std::string& path,
                                                        const std::string& image_topic,
                                                        const std::string& camera_info_topic) {
  return std::make_unique<BagImageSequence>(path, image_topic, camera_info_topic);
}

}  // namespace scale_drift_slam::ros_conversions
