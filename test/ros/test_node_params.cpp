// The nodes' parameters: defaults, ~config plus ~<section>/<key> overrides parsed by the core,
// and every kind of bad value refused with the parameter's name.

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "scale_drift_slam/io/slam_params_io.h"
#include "scale_drift_slam/ros/node_params.h"

namespace scale_drift_slam::ros_conversions {
namespace {

using XmlRpc::XmlRpcValue;

XmlRpcValue emptyStruct() {
  XmlRpcValue v;
  v.begin();
  return v;
}

std::string writeFile(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

/// The message of the std::runtime_error `f` throws ("" when it does not throw).
template <typename F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(NodeParams, DefaultsWithoutParameters) {
  const TrackingNodeConfig tracking = trackingNodeConfig(emptyStruct());
  EXPECT_EQ(tracking.node.frames.map, "map");
  EXPECT_EQ(tracking.node.frames.optical, "camera_optical_frame");
  EXPECT_TRUE(tracking.node.map_z_up);
  EXPECT_FALSE(tracking.calibration.has_value());
  EXPECT_TRUE(tracking.unknown.empty());
  const system::SlamParams defaults;
  EXPECT_EQ(io::formatSlamParams(tracking.slam), io::formatSlamParams(defaults));
  const MappingNodeConfig mapping = mappingNodeConfig(emptyStruct());
  EXPECT_EQ(mapping.node.map_frame, "map");
  EXPECT_NE(describe(mapping).find("window_ba"), std::string::npos);
  EXPECT_NE(describe(tracking).find("camera_optical_frame"), std::string::npos);
}

// Issue 17: a misspelt node parameter is named with the one it is close to (the shared helper).
TEST(NodeParams, UnknownParametersGetADidYouMean) {
  XmlRpcValue p = emptyStruct();
  p["image_queue_sise"] = 3;
  const TrackingNodeConfig c = trackingNodeConfig(p);
  ASSERT_EQ(c.unknown.size(), 1u);
  EXPECT_EQ(c.unknown[0], "~image_queue_sise (did you mean '~image_queue_size'?)");
}

TEST(NodeParams, ConfigFileThenOverrides) {
  XmlRpcValue p = emptyStruct();
  p["config"] =
      writeFile("sds_params.yaml", "tracker:\n  good_inliers: 60\nsearch:\n  min_ncc: 0.7\n");
  p["tracker"]["min_inliers"] = 20;
  p["search"]["max_radius_px"] = 35;  // an int for a double
  p["flow"]["method"] = std::string("dis");
  p["window_ba"]["window_size"] = 8;
  p["mapper"]["run_window_ba"] = false;
  p["map_frame"] = std::string("world");
  p["image_queue_size"] = 3;
  p["keyframe_publish_queue_size"] = 50;
  p["something_else"] = 1;
  const TrackingNodeConfig c = trackingNodeConfig(p);
  EXPECT_EQ(c.slam.tracker.good_inliers, 60);  // from the file
  EXPECT_DOUBLE_EQ(c.slam.tracker.search.min_ncc, 0.7);
  EXPECT_EQ(c.slam.tracker.min_inliers, 20);  // overrides
  EXPECT_DOUBLE_EQ(c.slam.tracker.search.max_radius_px, 35.0);
  EXPECT_EQ(c.slam.tracker.motion_prior.flow.method, tracking::FlowMethod::kDis);
  EXPECT_EQ(c.slam.mapper.window.window_size, 8);
  EXPECT_FALSE(c.slam.mapper.run_window_ba);
  EXPECT_EQ(c.node.frames.map, "world");
  EXPECT_EQ(c.node.image_queue_size, 3);
  EXPECT_EQ(c.node.keyframe_publish_queue_size, 50);
  ASSERT_EQ(c.unknown.size(), 1u);
  EXPECT_EQ(c.unknown[0], "~something_else");
  // A double written with all its digits comes back exactly.
  XmlRpcValue q = emptyStruct();
  q["motion_prior"]["min_rotation_sigma"] = 0.1 + 0.2;
  EXPECT_EQ(slamParams(q).tracker.motion_prior.min_rotation_sigma, 0.1 + 0.2);
}

TEST(NodeParams, LoopClosureNodeReadsTheLoopSections) {
  const LoopClosureNodeConfig defaults = loopClosureNodeConfig(emptyStruct());
  EXPECT_EQ(defaults.node.keyframe_queue_size, 100);
  EXPECT_TRUE(defaults.unknown.empty());
  EXPECT_NE(describe(defaults).find("loop_verification"), std::string::npos) << describe(defaults);
  EXPECT_NE(describe(defaults).find("place_recognition: ORB 800 features"), std::string::npos)
      << describe(defaults);

  XmlRpcValue p = emptyStruct();
  p["config"] = writeFile("sds_loop.yaml",
                          "loop_closure:\n  enabled: false\nplace_recognition:\n"
                          "  min_consistent_queries: 2\n  appearance:\n    grid_cols: 6\n");
  p["loop_closure"]["relocalisation_candidates"] = 5;
  p["loop_verification"]["min_final_inliers"] = 30;
  p["place_recognition"]["recent_keyframes_excluded"] = 20;
  p["place_recognition"]["appearance"]["max_features"] = 800;
  p["place_recognition"]["geometry"]["min_inliers"] = 50;
  p["keyframe_queue_size"] = 10;
  const LoopClosureNodeConfig c = loopClosureNodeConfig(p);
  EXPECT_FALSE(c.slam.loop.enabled);  // from the file
  EXPECT_EQ(c.slam.loop.recognition.min_consistent_queries, 2);
  EXPECT_EQ(c.slam.loop.recognition.appearance.grid_cols, 6);
  EXPECT_EQ(c.slam.loop.relocalisation_candidates, 5);  // overrides
  EXPECT_EQ(c.slam.loop.verification.min_final_inliers, 30);
  EXPECT_EQ(c.slam.loop.recognition.recent_keyframes_excluded, 20);
  EXPECT_EQ(c.slam.loop.recognition.appearance.max_features, 800);
  EXPECT_EQ(c.slam.loop.recognition.geometry.min_inliers, 50);
  EXPECT_EQ(c.node.keyframe_queue_size, 10);
  EXPECT_TRUE(c.unknown.empty());

  const auto loop_error = [](XmlRpcValue q) { return errorOf([&] { loopClosureNodeConfig(q); }); };
  p = emptyStruct();
  p["place_recognition"]["appearance"]["no_such_key"] = 1;
  EXPECT_NE(loop_error(p).find("appearance.no_such_key"), std::string::npos) << loop_error(p);
  p = emptyStruct();
  p["loop_verification"]["max_scale"] = -2.0;
  EXPECT_NE(loop_error(p).find("scale"), std::string::npos) << loop_error(p);
  p = emptyStruct();
  p["keyframe_queue_size"] = 0;
  EXPECT_NE(loop_error(p).find("~keyframe_queue_size"), std::string::npos) << loop_error(p);
  p = emptyStruct();
  p["loop_closure"]["enabled"] = std::string("maybe");
  EXPECT_NE(loop_error(p).find("loop_closure.enabled"), std::string::npos) << loop_error(p);
}

TEST(NodeParams, MapFileParameters) {
  XmlRpcValue p = emptyStruct();
  EXPECT_TRUE(trackingNodeConfig(p).node.map_file.empty());
  EXPECT_FALSE(trackingNodeConfig(p).node.localization_only);
  EXPECT_TRUE(mappingNodeConfig(p).node.save_map_on_shutdown.empty());
  p["map_file"] = std::string("/maps/a.map");
  p["localization_only"] = true;
  const TrackingNodeConfig tracking = trackingNodeConfig(p);
  EXPECT_EQ(tracking.node.map_file, "/maps/a.map");
  EXPECT_TRUE(tracking.node.localization_only);
  EXPECT_TRUE(tracking.unknown.empty());
  EXPECT_NE(describe(tracking).find("localization_only: 1"), std::string::npos);
  EXPECT_EQ(loopClosureNodeConfig(p).node.map_file, "/maps/a.map");
  // Localisation needs a map.
  p = emptyStruct();
  p["localization_only"] = true;
  EXPECT_NE(errorOf([&] { trackingNodeConfig(p); }).find("~localization_only: needs ~map_file"),
            std::string::npos);
  // ~save_map_on_shutdown: a path, true (~save_map_file), false.
  p = emptyStruct();
  p["save_map_on_shutdown"] = std::string("/maps/out.map");
  EXPECT_EQ(mappingNodeConfig(p).node.save_map_on_shutdown, "/maps/out.map");
  p["save_map_on_shutdown"] = false;
  EXPECT_TRUE(mappingNodeConfig(p).node.save_map_on_shutdown.empty());
  p["save_map_on_shutdown"] = true;
  EXPECT_NE(errorOf([&] { mappingNodeConfig(p); }).find("~save_map_file is not set"),
            std::string::npos);
  p["save_map_file"] = std::string("/maps/b.map");
  EXPECT_EQ(mappingNodeConfig(p).node.save_map_on_shutdown, "true");
  p["save_map_on_shutdown"] = 3;
  EXPECT_NE(errorOf([&] { mappingNodeConfig(p); }).find("must be a path or a bool"),
            std::string::npos);
}

TEST(NodeParams, BadValuesNameTheParameter) {
  const auto tracking_error = [](XmlRpcValue p) { return errorOf([&] { trackingNodeConfig(p); }); };
  const auto mapping_error = [](XmlRpcValue p) { return errorOf([&] { mappingNodeConfig(p); }); };
  XmlRpcValue p = emptyStruct();
  p["tracker"]["good_inliers"] = -3;
  EXPECT_NE(tracking_error(p).find("good_inliers"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["search"]["no_such_key"] = 1;
  EXPECT_NE(tracking_error(p).find("no_such_key"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["search"] = 3;
  EXPECT_NE(tracking_error(p).find("~search"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["image_queue_size"] = std::string("many");
  EXPECT_NE(tracking_error(p).find("~image_queue_size: must be an int"), std::string::npos)
      << tracking_error(p);
  p = emptyStruct();
  p["image_queue_size"] = 0;
  EXPECT_NE(tracking_error(p).find("~image_queue_size"), std::string::npos);
  p = emptyStruct();
  p["keyframe_publish_queue_size"] = 0;
  EXPECT_NE(tracking_error(p).find("~keyframe_publish_queue_size: must be >= 1"), std::string::npos)
      << tracking_error(p);
  p = emptyStruct();
  p["odom_frame"] = std::string("map");
  EXPECT_NE(tracking_error(p).find("used for two frames"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["map_z_up"] = 1;
  EXPECT_NE(tracking_error(p).find("~map_z_up: must be a bool"), std::string::npos);
  p = emptyStruct();
  p["config"] = std::string("/nonexistent/params.yaml");
  EXPECT_NE(tracking_error(p).find("~config: cannot read '/nonexistent/params.yaml'"),
            std::string::npos)
      << tracking_error(p);
  p = emptyStruct();
  p["config"] = writeFile("sds_bad.yaml", "tracker: [1, 2\n");
  EXPECT_NE(tracking_error(p).find("~config"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["calibration_file"] = writeFile(
      "sds_nan_calibration.yaml",
      "width: 640\nheight: 480\nfx: .nan\nfy: 500\ncx: 320\ncy: 240\ndistortion_model: plumb_bob\n"
      "distortion: [0, 0, 0, 0, 0]\n");
  EXPECT_NE(tracking_error(p).find("~calibration_file"), std::string::npos) << tracking_error(p);
  p = emptyStruct();
  p["window_ba"]["window_size"] = 0;
  EXPECT_NE(mapping_error(p).find("window_size"), std::string::npos) << mapping_error(p);
  p = emptyStruct();
  p["marker_scale"] = -1.0;
  EXPECT_NE(mapping_error(p).find("~marker_scale"), std::string::npos) << mapping_error(p);
}

// CameraInfo has no field for a rolling shutter's readout: the parameter sets it, also over a
// calibration file's; an impossible one is refused naming it.
TEST(NodeParams, RollingShutterReadout) {
  EXPECT_EQ(trackingNodeConfig(emptyStruct()).node.rolling_shutter_readout_s, 0.0);
  XmlRpcValue p = emptyStruct();
  p["rolling_shutter_readout_s"] = 0.025;
  EXPECT_EQ(trackingNodeConfig(p).node.rolling_shutter_readout_s, 0.025);
  p["calibration_file"] = writeFile("sds_rolling_shutter.yaml",
                                    "width: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\n"
                                    "cy: 240\nrolling_shutter_readout_s: 0.01\n");
  EXPECT_EQ(trackingNodeConfig(p).calibration->rolling_shutter_readout_s, 0.025);
  p["rolling_shutter_readout_s"] = 0.0;  // the file's own
  EXPECT_EQ(trackingNodeConfig(p).calibration->rolling_shutter_readout_s, 0.01);
  p["rolling_shutter_readout_s"] = -0.02;
  EXPECT_NE(errorOf([&] { trackingNodeConfig(p); }).find("~rolling_shutter_readout_s"),
            std::string::npos);
}

TEST(NodeParams, RobotFrames) {
  const TrackingNodeParams defaults = trackingNodeConfig(emptyStruct()).node;
  EXPECT_EQ(defaults.frames.base, "base_link");
  EXPECT_TRUE(defaults.publish_tf);
  EXPECT_TRUE(defaults.publish_odom_tf);
  EXPECT_EQ(defaults.camera_mount, std::vector<double>(6, 0.0));
  XmlRpcValue p = emptyStruct();
  p["base_frame"] = std::string("");
  p["publish_odom_tf"] = false;
  p["camera_mount"][0] = 0.2;
  p["camera_mount"][1] = 0;
  p["camera_mount"][2] = 0.5;
  p["camera_mount"][3] = 0;
  p["camera_mount"][4] = 0.3;
  p["camera_mount"][5] = -1;
  const TrackingNodeConfig config = trackingNodeConfig(p);
  EXPECT_EQ(config.node.frames.base, "");
  EXPECT_FALSE(config.node.publish_odom_tf);
  EXPECT_EQ(config.node.camera_mount, (std::vector<double>{0.2, 0, 0.5, 0, 0.3, -1}));
  EXPECT_TRUE(config.unknown.empty());

  const auto error = [](XmlRpcValue q) { return errorOf([&] { trackingNodeConfig(q); }); };
  XmlRpcValue short_mount = emptyStruct();
  short_mount["camera_mount"][0] = 1.0;
  EXPECT_NE(error(short_mount).find("~camera_mount: must have 6 numbers, got 1"), std::string::npos)
      << error(short_mount);
  XmlRpcValue text_mount = p;
  text_mount["camera_mount"][2] = std::string("up");
  EXPECT_NE(error(text_mount).find("~camera_mount: must be a list of numbers"), std::string::npos)
      << error(text_mount);
  XmlRpcValue same = emptyStruct();
  same["base_frame"] = std::string("camera_link");
  EXPECT_NE(error(same).find("used for two frames"), std::string::npos) << error(same);
  XmlRpcValue sigma = emptyStruct();
  sigma["pose_pixel_sigma_px"] = 0.0;
  EXPECT_NE(error(sigma).find("~pose_pixel_sigma_px: must be > 0"), std::string::npos);
  XmlRpcValue wait = emptyStruct();
  wait["odom_tf_timeout_s"] = -1.0;
  EXPECT_NE(error(wait).find("~odom_tf_timeout_s"), std::string::npos);
}

}  // namespace
}  // namespace scale_drift_slam::ros_conversions
