// The mapper on keyframe messages with a known answer: exact observations of a random scene from
// keyframes whose poses (beyond the two first) arrive perturbed; the window BA puts them back
// and the map update carries the corrected poses of the window's free keyframes; observations of
// unknown points are skipped, earlier observations of new points are added.

#include <random>

#include <gtest/gtest.h>

#include "scale_drift_slam/geometry/so3.h"
#include "scale_drift_slam/mapping/mapper.h"

namespace scale_drift_slam::mapping {
namespace {

TEST(Mapper, WindowBaCorrectsPerturbedKeyframes) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-2.0, 2.0), z(4.0, 8.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 150; ++i)
    points.emplace_back(xy(rng), xy(rng), z(rng));
  auto truth = [](int k) {
    return geometry::SE3(geometry::expSO3(Eigen::Vector3d(0, 0.01 * k, 0)),
                         Eigen::Vector3d(0.2 * k, 0, 0))
        .inverse();
  };
  Mapper mapper(MapperParams{}, 500.0);
  std::normal_distribution<double> perturbation(0.0, 0.01);
  map::MapUpdate update;
  for (int k = 0; k < 6; ++k) {
    map::KeyframeMessage message;
    message.keyframe.id = k;
    message.keyframe.timestamp = k;
    Eigen::Matrix<double, 6, 1> noise;
    for (int i = 0; i < 6; ++i)
      noise[i] = perturbation(rng);
    message.keyframe.T_kf_world = k < 2 ? truth(k) : geometry::SE3::exp(noise) * truth(k);
    for (int i = 0; i < static_cast<int>(points.size()); ++i) {
      if (k == 0) message.new_points.push_back({static_cast<map::PointId>(i), points[i], 0});
      message.keyframe.observations.push_back(
          {static_cast<map::PointId>(i), (truth(k) * points[i]).hnormalized()});
    }
    message.keyframe.observations.push_back({999, Eigen::Vector2d(0, 0)});  // unknown point
    if (k == 3) {  // a point promoted at keyframe 3, also seen by keyframe 2
      const Eigen::Vector3d p(0.3, 0.2, 5.0);
      message.new_points.push_back({500, p, 2});
      message.keyframe.observations.push_back({500, (truth(3) * p).hnormalized()});
      message.earlier_observations.push_back({2, 500, (truth(2) * p).hnormalized()});
    }
    update = mapper.addKeyframe(message);
  }
  const map::Map& map = mapper.map();
  EXPECT_EQ(map.numKeyframes(), 6u);
  EXPECT_EQ(map.numPoints(), 151u);
  EXPECT_EQ(map.point(500).observed_by.size(), 2u);
  EXPECT_EQ(update.map_version, map.version());
  EXPECT_EQ(update.keyframe_poses.size(), 4u);  // the window's free keyframes 2..5
  for (const auto& [id, T_kf_world] : update.keyframe_poses) {
    EXPECT_GE(id, 2u);
    EXPECT_LT((T_kf_world.inverseTranslation() - truth(id).inverseTranslation()).norm(), 1e-4)
        << "keyframe " << id;
  }
}

// A point with (almost) no parallax, as on a car driving with the camera, sits anywhere along
// its ray; one far beyond the scene (over 50 times the keyframe's median depth) is removed from
// the map and listed in the update, a far but plausible one (17 times) is kept. With
// `reference_observes` false the points' reference keyframe holds no observations, as a culled
// keyframe: the depths are then measured from the first keyframe observing them.
void expectRunawayPointRemoved(bool reference_observes) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> xy(-2.0, 2.0), z(4.0, 8.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 150; ++i)
    points.emplace_back(xy(rng), xy(rng), z(rng));
  points.emplace_back(0.5, 0.0, 100.0);  // 150: far, kept
  points.emplace_back(-0.5, 0.0, 1e4);   // 151: run away
  auto truth = [](int k) {
    return geometry::SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.2 * k, 0, 0));
  };
  Mapper mapper(MapperParams{}, 500.0);
  std::vector<map::PointId> removed;
  for (int k = 0; k < 5; ++k) {
    map::KeyframeMessage message;
    message.keyframe.id = k;
    message.keyframe.timestamp = k;
    message.keyframe.T_kf_world = truth(k);
    for (int i = 0; i < static_cast<int>(points.size()); ++i) {
      if (k == 0) message.new_points.push_back({static_cast<map::PointId>(i), points[i], 0});
      if (k > 0 || reference_observes)
        message.keyframe.observations.push_back(
            {static_cast<map::PointId>(i), (truth(k) * points[i]).hnormalized()});
    }
    const map::MapUpdate update = mapper.addKeyframe(message);
    removed.insert(removed.end(), update.removed_points.begin(), update.removed_points.end());
    for (const auto& [id, p] : update.point_positions)
      EXPECT_NE(id, 151u);
  }
  EXPECT_EQ(removed, std::vector<map::PointId>{151});
  EXPECT_FALSE(mapper.map().hasPoint(151));
  EXPECT_TRUE(mapper.map().hasPoint(150));
  EXPECT_EQ(mapper.map().numPoints(), 151u);
}

TEST(Mapper, RunawayPointsAreRemoved) {
  expectRunawayPointRemoved(true);
}

TEST(Mapper, RunawayPointsAreRemovedWhenTheirReferenceKeyframeObservesNothing) {
  expectRunawayPointRemoved(false);
}

}  // namespace
}  // namespace scale_drift_slam::mapping
