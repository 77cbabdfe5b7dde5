#pragma once
// A rosbag's image topic as an io::ImageSequence, read one message at a time (memory stays flat
// however long the bag), with the calibration from the first CameraInfo on the camera-info topic.
// sensor_msgs/Image (any encoding the core accepts) and sensor_msgs/CompressedImage are read.
// Used by run_sequence; ROS layer only.

#include <memory>
#include <string>

#include "scale_drift_slam/io/image_sequence.h"

namespace scale_drift_slam::ros_conversions {

/// Opens the bag. Throws std::runtime_error naming the bag and the reason when it cannot be
/// opened or holds no message on `image_topic` (the message lists the image topics it has).
std::unique_ptr<io::ImageSequence> openBagImageSequence(const std::string& path,
                                                        const std::string& image_topic,
                                                        const std::string& camera_info_topic);

}  // namespace scale_drift_slam::ros_conversions
