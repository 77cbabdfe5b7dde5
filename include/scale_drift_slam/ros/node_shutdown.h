#pragma once
// How the three nodes stop on SIGINT, so that the mapping node's ~save_map_on_shutdown can still
// collect the tracking and loop-closure nodes' parts when a whole launch is stopped (Ctrl-C on
// roslaunch signals every node at once and stops the master last; doc/map_file.md "In ROS").
//
// Each node replaces roscpp's SIGINT handler (ros::init with ros::init_options::NoSigintHandler,
// then catchSigint()) and serves its callbacks until SIGINT. Then the mapping node saves the map
// while the other two stay: each asks the master whether `mapping_node` saves on shutdown and, if
// so, keeps serving its ~get_map_part until the mapping node has gone (bounded by a timeout below
// roslaunch's 15 s before it escalates to SIGTERM).

#include <string>

namespace scale_drift_slam::ros_conversions {

/// Makes SIGINT set a flag instead of shutting roscpp down (after ros::init with
/// NoSigintHandler).
void catchSigint();

/// Whether SIGINT has arrived since catchSigint().
bool sigintReceived();

/// Serves the global callback queue until SIGINT or ros::shutdown().
void spinUntilSigint();

/// After SIGINT, in the tracking and loop-closure nodes: when the mapping node (`mapping_node`
/// in this node's namespace) saves the map on shutdown, keeps serving the global callback queue
/// (its ~get_map_part) until the mapping node has gone or `timeout_s` has passed. Returns what
/// happened, for the log (empty when there was nothing to stay for). The default timeout is below
/// roslaunch's 15 s between SIGINT and SIGTERM.
std::string stayForMapSaveOnShutdown(double timeout_s = 12.0);

}  // namespace scale_drift_slam::ros_conversions
