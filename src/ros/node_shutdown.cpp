#include "scale_drift_slam/ros/node_shutdown.h"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <stdexcept>

#include <ros/callback_queue.h>
#include <ros/master.h>
#include <ros/names.h>
#include <ros/param.h>
#include <ros/ros.h>
#include <ros/service.h>

#include "scale_drift_slam/ros/node_params.h"

namespace scale_drift_slam::ros_conversions {
namespace {

std::atomic<bool> g_sigint{false};

void onSigint(int) {
  g_sigint = true;
}

const char* const kMapper = "mapping_node";

std::string seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f s", s);
  return text;
}

}  // namespace

void catchSigint() {
  std::signal(SIGINT, onSigint);
}

bool sigintReceived() {
  return g_sigint;
}

void spinUntilSigint() {
  while (ros::ok() && !g_sigint)
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.1));
}

std::string stayForMapSaveOnShutdown(double timeout_s) {
  // The master is up (roslaunch stops it last), but a node stopped after it would wait forever.
  ros::master::setRetryTimeout(ros::WallDuration(1.0));
  const std::string mapper = ros::names::resolve(kMapper);
  XmlRpc::XmlRpcValue value;
  std::string save;
  try {
    if (ros::param::get(mapper + "/save_map_on_shutdown", value)) save = pathOrBool(value);
  } catch (const std::exception&) {
    return "";  // the mapping node refuses such a value and does not run
  }
  if (save.empty()) return "";
  const std::string service = mapper + "/save_map";
  const ros::WallTime start = ros::WallTime::now();
  ros::WallTime last_check;
  while (ros::ok()) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
    const ros::WallTime now = ros::WallTime::now();
    if ((now - start).toSec() > timeout_s) {
      return "waited " + seconds(timeout_s) + " for " + mapper +
             " to save the map on shutdown; stopping without it";
    }
    if ((now - last_check).toSec() < 0.2) continue;
    last_check = now;
    if (!ros::service::exists(service, false)) {
      return "stayed " + seconds((now - start).toSec()) + " until " + mapper +
             " (saving the map on shutdown) had gone";
    }
  }
  return "";
}

}  // namespace scale_drift_slam::ros_conversions
