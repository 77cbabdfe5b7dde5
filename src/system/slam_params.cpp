#include "scale_drift_slam/system/slam_params.h"

namespace scale_drift_slam::system {

void SlamParams::validate() const {
  tracker.validate();
  mapper.validate();
  loop.validate();
  messages.validate();
}

}  // namespace scale_drift_slam::system
