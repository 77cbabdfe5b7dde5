// keyframe_relay: on the base station of a two-machine setup (launch/base_station.launch,
// doc/ros.md "Running on two machines"), takes the robot's keyframes once over the link and hands
// them to the mapping and loop-closure nodes on this machine. ROS 1 gives every subscriber its own
// TCP connection to the publisher: without the relay each keyframe (its image: ~0.3 MB at
// 640x480) crosses the link once per node. Unlike topic_tools relay it knows the type and
// advertises at start, so the nodes are connected before the first keyframe (the pair that
// starts the map) arrives. Keeps ~queue_size keyframes for each local subscriber.

#include <ros/ros.h>

#include "scale_drift_slam/Keyframe.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "keyframe_relay");
  ros::NodeHandle nh, pnh("~");
  int queue_size = 200;
  pnh.param("queue_size", queue_size, queue_size);
  if (queue_size < 1) {
    ROS_FATAL("keyframe_relay: ~queue_size must be >= 1 (is %d)", queue_size);
    return 1;
  }
  ros::Publisher out = nh.advertise<scale_drift_slam::Keyframe>("keyframes_out", queue_size);
  ros::Subscriber in = nh.subscribe<scale_drift_slam::Keyframe>(
      "keyframes_in", queue_size,
      [&out](const scale_drift_slam::KeyframeConstPtr& msg) { out.publish(msg); });
  ROS_INFO("relaying keyframes from %s to %s", in.getTopic().c_str(), out.getTopic().c_str());
  ros::spin();
  return 0;
}
