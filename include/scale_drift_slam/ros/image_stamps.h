#pragma once
// The tracking node's check of image stamps (doc/ros.md): a frame with the previous frame's
// stamp is a duplicate and dropped; a stamp slightly before it (a driver glitch) is dropped too;
// only a jump back by more than a threshold (a bag played again) means the source restarted, and
// the tracker starts afresh rather than track across the jump.

#include <string>

#include <ros/time.h>

namespace scale_drift_slam::ros_conversions {

/// What to do with an image, given the stamp of the last image tracked (zero: none yet).
struct ImageStampCheck {
  bool duplicate = false;      ///< The previous image's stamp: drop the image.
  std::string drop_reason;     ///< Non-empty: slightly older than the previous image: drop it.
  std::string restart_reason;  ///< Non-empty: time jumped backwards, reset the tracker first.
};

/// `restart_after_s`: a stamp more than this before the last one restarts, a smaller step back
/// drops the image.
ImageStampCheck checkImageStamp(const ros::Time& last_stamp, const ros::Time& stamp,
                                double restart_after_s = 1.0);

}  // namespace scale_drift_slam::ros_conversions
