#pragma once
// The parameters of the whole SLAM: one struct per module (tracker, mapper, loop closer) and how
// the pipeline runs them. Loaded from YAML by io/slam_params_io.h, overridden by ROS parameters in
// ros/node_params.h; both include this header only, not the pipeline and its threads.

#include "scale_drift_slam/loop/loop_closer.h"
#include "scale_drift_slam/mapping/mapper.h"
#include "scale_drift_slam/system/message_validation.h"
#include "scale_drift_slam/tracking/tracker.h"

namespace scale_drift_slam::system {

struct SlamParams {
  tracking::TrackerParams tracker;
  mapping::MapperParams mapper;
  loop::LoopCloserParams loop;
  MessageLimits messages;      ///< What a message between the parts must pass to be taken.
  bool mapping_thread = true;  ///< Mapper and loop closer on their own threads.
  void validate() const;
};

}  // namespace scale_drift_slam::system
