#include "scale_drift_slam/ros/bag_image_sequence.h"

#include <stdexcept>

#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <opencv2/imgcodecs.hpp>

#include "scale_drift_slam/ros/conversions.h"

namespace scale_drift_slam::ros_conversions {
namespace {

/// A bag that cannot be read, with the way out: a truncated bag (a recording killed) lost its
/// index, which `rosbag reindex` rebuilds from the messages before the damage.
std::string bagError(const std::string& path, const std::string& what) {
  return "bag '" + path + "': " + what +
         " (the bag may be truncated or unindexed: `rosbag reindex " + path +
         "` recovers the messages before the damage; `rosbag check` tells more)";
}

/// Why a sensor_msgs/Image cannot be converted ("" when it can): its data must hold `height`
/// rows of `step` bytes, each at least `width` pixels of its encoding.
std::string imageMessageProblem(const sensor_msgs::Image& image) {
  std::size_t pixel_bytes = 0;
  try {
    pixel_bytes =
        static_cast<std::size_t>(sensor_msgs::image_encodings::numChannels(image.encoding)) *
        static_cast<std::size_t>(sensor_msgs::image_encodings::bitDepth(image.encoding)) / 8;
  } catch (const std::exception&) {
    return "unknown image encoding '" + image.encoding + "'";
  }
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * pixel_bytes;
  if (image.width == 0 || image.height == 0 || image.step < row_bytes ||
      image.data.size() < static_cast<std::size_t>(image.step) * image.height) {
    return "image message of " + std::to_string(image.width) + "x" + std::to_string(image.height) +
           " " + image.encoding + " pixels, step " + std::to_string(image.step) + ", holds " +
           std::to_string(image.data.size()) + " bytes: too few for its size";
  }
  return "";
}

class BagImageSequence : public io::ImageSequence {
 public:
  BagImageSequence(const std::string& path, const std::string& image_topic,
                   const std::string& camera_info_topic)
      : path_(path) {
    try {
      bag_.open(path, rosbag::bagmode::Read);
      view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(image_topic));
      size_ = view_->size();
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error(bagError(path, e.what()));
    }
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
    try {
      rosbag::View info_view(bag_, rosbag::TopicQuery(camera_info_topic));
      for (const rosbag::MessageInstance& m : info_view) {
        if (const auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
          calibration_ = ros_conversions::calibrationFromCameraInfo(*info);
          break;
        }
      }
      it_ = view_->begin();
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error(bagError(path, e.what()));
    }
  }

  std::optional<io::SequenceFrame> next() override {
    try {
      return readNext();
    } catch (const rosbag::BagException& e) {
      // A bag damaged in the middle: the frames before were read; end here, and say why.
      warnings_.push_back(bagError(path_, std::string("reading stopped: ") + e.what()));
      it_ = view_->end();
      return std::nullopt;
    }
  }

  std::optional<io::SequenceFrame> readNext() {
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
        frame.problem = imageMessageProblem(*image);
        if (!frame.problem.empty()) return frame;  // the SLAM rejects it with the problem
        noteSizeMismatch(static_cast<int>(image->width), static_cast<int>(image->height));
        try {
          frame.image = cv_bridge::toCvCopy(image)->image;  // keeps the encoding
        } catch (const std::exception& e) {
          frame.image = cv::Mat();  // unreadable: the SLAM rejects the empty frame
          frame.problem = std::string("cv_bridge cannot convert it: ") + e.what();
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

  /// Once: the images are not the size of the bag's CameraInfo (each frame is then rejected by
  /// the tracker unless --calib gives a calibration of the images' size).
  void noteSizeMismatch(int width, int height) {
    if (size_warned_ || !calibration_) return;
    if (width == calibration_->width && height == calibration_->height) return;
    size_warned_ = true;
    warnings_.push_back("bag '" + path_ + "': images are " + std::to_string(width) + "x" +
                        std::to_string(height) + " but its CameraInfo is " +
                        std::to_string(calibration_->width) + "x" +
                        std::to_string(calibration_->height));
  }

  std::size_t size() const override { return size_; }
  std::vector<std::string> warnings() const override { return warnings_; }
  std::optional<geometry::CameraCalibration> calibration() const override { return calibration_; }
  std::string describe() const override { return "bag of " + std::to_string(size_) + " images"; }

 private:
  std::string path_;
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  std::size_t size_ = 0;
  std::optional<geometry::CameraCalibration> calibration_;
  std::vector<std::string> warnings_;
  bool size_warned_ = false;
};

}  // namespace

std::unique_ptr<io::ImageSequence> openBagImageSequence(const std::string& path,
                                                        const std::string& image_topic,
                                                        const std::string& camera_info_topic) {
  return std::make_unique<BagImageSequence>(path, image_topic, camera_info_topic);
}

}  // namespace scale_drift_slam::ros_conversions
