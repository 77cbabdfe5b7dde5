// The SLAM parameter file: config/default.yaml holds exactly the defaults of the structs, keys
// override them, the printed form loads back to the same values, and typos or bad values are
// refused with the file and the key.

#include <gtest/gtest.h>

#include "scale_drift_slam/io/slam_params_io.h"

namespace scale_drift_slam::io {
namespace {

void expectFailure(const std::string& text, const std::string& reason) {
  try {
    parseSlamParams(text, "test.yaml");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("test.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
  }
}

TEST(SlamParamsIo, DefaultFileEqualsTheStructDefaults) {
  const system::SlamParams from_file =
      loadSlamParams(std::string(SDS_TEST_DATA_DIR) + "/../../config/default.yaml");
  const system::SlamParams defaults;
  EXPECT_EQ(formatSlamParams(from_file), formatSlamParams(defaults));
}

TEST(SlamParamsIo, KeysOverrideDefaults) {
  const auto p = parseSlamParams(
      "tracker:\n  good_inliers: 70\nflow:\n  method: dis\nwindow_ba:\n  window_size: 7\n"
      "motion_ba:\n  solver: ceres\nsystem:\n  mapping_thread: false\n");
  EXPECT_EQ(p.tracker.good_inliers, 70);
  EXPECT_EQ(parseSlamParams("flow:\n  min_step_px: 0.03\n").tracker.motion_prior.flow.min_step_px,
            0.03);
  EXPECT_EQ(p.tracker.motion_prior.flow.method, tracking::FlowMethod::kDis);
  EXPECT_EQ(p.mapper.window.window_size, 7);
  EXPECT_EQ(p.tracker.motion_ba.solver, features::MotionOnlySolver::kCeres);
  EXPECT_FALSE(p.mapping_thread);
  const system::SlamParams defaults;
  EXPECT_EQ(p.tracker.min_inliers, defaults.tracker.min_inliers);
  // The printed form reads back to the same values.
  EXPECT_EQ(formatSlamParams(parseSlamParams(formatSlamParams(p))), formatSlamParams(p));
  EXPECT_EQ(formatSlamParams(parseSlamParams("")), formatSlamParams(defaults));
}

TEST(SlamParamsIo, LoopClosureSectionsAndPlaceRecognition) {
  const auto p = parseSlamParams(
      "loop_correction:\n  mode: se3\n  covisibility_min_shared_points: 50\n"
      "loop_closure:\n  enabled: false\n  relocalisation_min_coverage: 0.4\n"
      "loop_verification:\n  min_final_inliers: 60\n"
      "place_recognition:\n  min_consistent_queries: 2\n  geometry:\n    min_inliers: 45\n");
  EXPECT_EQ(p.mapper.loop_correction.graph.mode, loop::PoseGraphMode::kSE3);
  EXPECT_EQ(p.mapper.loop_correction.covisibility_min_shared_points, 50);
  EXPECT_FALSE(p.loop.enabled);
  EXPECT_DOUBLE_EQ(p.loop.relocalisation_geometry.min_coverage, 0.4);
  EXPECT_EQ(p.loop.verification.min_final_inliers, 60);
  EXPECT_EQ(p.loop.recognition.min_consistent_queries, 2);
  EXPECT_EQ(p.loop.recognition.geometry.min_inliers, 45);
  EXPECT_THROW(parseSlamParams("place_recognition:\n  min_inliers: 45\n"), std::runtime_error);
  EXPECT_THROW(parseSlamParams("loop_correction:\n  mode: se2\n"), std::runtime_error);
  EXPECT_THROW(parseSlamParams("loop_verification:\n  min_scale: 2.0\n"), std::runtime_error);
}

TEST(SlamParamsIo, RefusesTyposAndBadValues) {
  expectFailure("trackr:\n  good_inliers: 3\n", "unknown section 'trackr'");
  expectFailure("tracker:\n  good_inlier: 3\n", "unknown key 'tracker.good_inlier'");
  // Issue 17: a did-you-mean for typos, and the section that has a key put in the wrong one.
  expectFailure("tracker:\n  good_inlier: 3\n",
                "unknown key 'tracker.good_inlier' (did you mean 'tracker.good_inliers'?)");
  expectFailure("trackr:\n  good_inliers: 3\n", "(did you mean 'tracker'?)");
  expectFailure("tracker:\n  window_size: 3\n",
                "unknown key 'tracker.window_size' (did you mean 'window_ba.window_size'?)");
  expectFailure("place_recognition:\n  min_consistent_querys: 2\n",
                "unknown key 'min_consistent_querys' (did you mean 'min_consistent_queries'?)");
  expectFailure("place_recognition:\n  geometry:\n    min_inlier: 2\n",
                "(did you mean 'geometry.min_inliers'?)");
  expectFailure("? [a, b]\n: 3\n", "a section name is not text");
  // Found by the fuzz test: a non-finite value passed range checks written as `x < bound`.
  expectFailure("loop_verification:\n  ransac_threshold_px: .inf\n",
                "'loop_verification.ransac_threshold_px' must be a finite number");
  expectFailure("search:\n  min_ncc: .nan\n", "'search.min_ncc' must be a finite number");
  expectFailure("place_recognition:\n  geometry:\n    ratio: .nan\n",
                "key 'geometry.ratio' is not a finite number");
  expectFailure("tracker:\n  good_inliers: many\n", "tracker.good_inliers");
  expectFailure("tracker:\n  good_inliers: 5\n", "good_inliers");
  expectFailure("flow:\n  method: horn_schunck\n", "flow.method");
  expectFailure("flow:\n  min_step_px: 0\n", "flow.min_step_px");
  expectFailure("flow:\n  min_step_px: 1.5\n", "flow.min_step_px");
  expectFailure("search:\n  min_ncc: 2\n", "min_ncc");
  expectFailure("motion_prior:\n  candidate_flow_window: 8\n", "candidate_flow_window");
  expectFailure("motion_prior:\n  candidate_flow_window: 3\n", "candidate_flow_window");
  expectFailure("[1, 2]", "mapping of sections");
  expectFailure("tracker: [", "not valid YAML");
  EXPECT_THROW(loadSlamParams("/nonexistent/params.yaml"), std::runtime_error);
}

}  // namespace
}  // namespace scale_drift_slam::io
