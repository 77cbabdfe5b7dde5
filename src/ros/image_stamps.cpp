#include "scale_drift_slam/ros/image_stamps.h"

namespace scale_drift_slam::ros_conversions {

ImageStampCheck checkImageStamp(const ros::Time& last_stamp, const ros::Time& stamp,
                                double restart_after_s) {
  ImageStampCheck check;
  if (last_stamp.isZero() || stamp > last_stamp) return check;
  if (stamp == last_stamp) {
    check.duplicate = true;
  } else if ((last_stamp - stamp).toSec() <= restart_after_s) {
    check.drop_reason = "an image stamped " + std::to_string((last_stamp - stamp).toSec()) +
                        " s before the previous one (a driver glitch?) is dropped; a jump back " +
                        "of more than " + std::to_string(restart_after_s) + " s restarts tracking";
  } else {
    check.restart_reason = "image time jumped backwards from " +
                           std::to_string(last_stamp.toSec()) + " to " +
                           std::to_string(stamp.toSec()) + " s (bag restarted?)";
  }
  return check;
}

}  // namespace scale_drift_slam::ros_conversions
