#pragma once
// The tracking node's check of image stamps (doc/ros.md): a frame with the previous frame's
// stamp is a duplicate and dropped; a stamp before it means the source restarted (a bag played
// again), and the tracker starts afresh rather than track across the jump.

#include <string>

#include <ros/time.h>

namespace scale_drift_slam::ros_conversions {

/// What to do with an image, given the stamp of the last image tracked (zero: none yet).
struct ImageStampCheck {
  bool duplicate = false;      ///< The previous image's stamp: drop the image.
  std::string restart_reason;  ///< Non-empty: time jumped backwards, reset the tracker first.
};

ImageStampCheck checkImageStamp(const ros::Time& last_stamp, const ros::Time& stamp);

}  // namespace scale_drift_slam::ros_conversions
