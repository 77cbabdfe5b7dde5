// Traffic in the driving world (render_sequence --traffic): the cars follow from the seed, drive
// on the asphalt, never touch each other or the camera's car, come and go only out of sight of
// the camera, and are drawn where they are.

#include <cmath>

#include <gtest/gtest.h>

#include "scale_drift_slam/sim/renderer.h"
#include "scale_drift_slam/sim/scenario.h"
#include "scale_drift_slam/sim/sequence.h"

namespace scale_drift_slam::sim {
namespace {

Scenario cityWithTraffic(std::uint32_t seed, const std::string& name = "city_block") {
  ScenarioOptions options;
  options.traffic = true;
  return makeScenario(name, seed, options);
}

Eigen::Vector2d left(const Eigen::Vector2d& d) {
  return {-d.y(), d.x()};
}

/// The camera's car as documented (doc/sequences.md): 4.5 m x 1.8 m, centred 1.2 m behind the
/// camera, along the optical axis.
MovingObject cameraCar(const Scenario& scenario, double t) {
  const geometry::SE3 pose = scenario.T_world_cam(t);
  MovingObject car;
  car.present = true;
  const Eigen::Vector3d z = pose.rotationMatrix().col(2);
  car.heading = Eigen::Vector2d(z.x(), z.y()).normalized();
  car.position = pose.translation().head<2>() - 1.2 * car.heading;
  car.size = Eigen::Vector3d(4.5, 1.8, 1.5);
  return car;
}

std::vector<Eigen::Vector2d> corners(const MovingObject& o) {
  std::vector<Eigen::Vector2d> result;
  for (const double a : {-0.5, 0.5}) {
    for (const double b : {-0.5, 0.5})
      result.push_back(o.position + a * o.size.x() * o.heading + b * o.size.y() * left(o.heading));
  }
  return result;
}

/// Separating axes: true when the two rectangles intersect.
bool intersect(const MovingObject& a, const MovingObject& b) {
  for (const Eigen::Vector2d& u : {a.heading, left(a.heading), b.heading, left(b.heading)}) {
    double a0 = 1e30, a1 = -1e30, b0 = 1e30, b1 = -1e30;
    for (const Eigen::Vector2d& c : corners(a)) {
      a0 = std::min(a0, c.dot(u));
      a1 = std::max(a1, c.dot(u));
    }
    for (const Eigen::Vector2d& c : corners(b)) {
      b0 = std::min(b0, c.dot(u));
      b1 = std::max(b1, c.dot(u));
    }
    if (a1 < b0 || b1 < a0) return false;
  }
  return true;
}

TEST(Traffic, SameSeedSameCarsOtherSeedOtherCars) {
  const Scenario a = cityWithTraffic(1), b = cityWithTraffic(1), c = cityWithTraffic(2);
  ASSERT_TRUE(a.moving_objects);
  bool differs = false;
  for (double t = 0.0; t < a.duration; t += 1.0) {
    const std::vector<MovingObject> oa = a.moving_objects(t), ob = b.moving_objects(t);
    ASSERT_EQ(oa.size(), ob.size());
    for (size_t i = 0; i < oa.size(); ++i) {
      EXPECT_EQ(oa[i].present, ob[i].present);
      EXPECT_EQ(oa[i].position, ob[i].position);
    }
    const std::vector<MovingObject> oc = c.moving_objects(t);
    if (oc.size() != oa.size()) {
      differs = true;
    } else {
      for (size_t i = 0; i < oa.size(); ++i)
        differs = differs || (oa[i].position - oc[i].position).norm() > 1.0;
    }
  }
  EXPECT_TRUE(differs);
  // Without traffic: no moving objects.
  EXPECT_FALSE(makeScenario("city_block", 1).moving_objects);
  EXPECT_THROW(cityWithTraffic(1, "desk"), std::invalid_argument);
}

TEST(Traffic, CarsOnTheAsphaltClearOfEachOtherAndOfTheCamerasCar) {
  for (const std::uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const Scenario scenario = cityWithTraffic(seed);
    int oncoming = 0, crossing = 0, same_way = 0;
    for (double t = 0.0; t <= scenario.duration; t += 0.05) {
      const std::vector<MovingObject> cars = scenario.moving_objects(t);
      const MovingObject camera = cameraCar(scenario, t);
      for (size_t i = 0; i < cars.size(); ++i) {
        if (!cars[i].present) continue;
        // city_block's streets: centre lines x = 110 i and y = 75 j, asphalt 5.5 m either side.
        for (const Eigen::Vector2d& c : corners(cars[i])) {
          const double to_x = std::abs(c.x() - 110.0 * std::round(c.x() / 110.0));
          const double to_y = std::abs(c.y() - 75.0 * std::round(c.y() / 75.0));
          ASSERT_LE(std::min(to_x, to_y), 5.5) << "car " << i << " off the road at t = " << t;
        }
        ASSERT_FALSE(intersect(cars[i], camera))
            << "car " << i << " hits the camera's car at " << t;
        for (size_t j = i + 1; j < cars.size(); ++j)
          ASSERT_FALSE(cars[j].present && intersect(cars[i], cars[j]))
              << i << ", " << j << " at " << t;
        // Near the camera (within 30 m ahead): which way it goes relative to the camera.
        const Eigen::Vector2d to_car = cars[i].position - camera.position;
        if (to_car.norm() < 30.0 && to_car.dot(camera.heading) > 0) {
          const double cosine = cars[i].heading.dot(camera.heading);
          if (cosine < -0.9)
            ++oncoming;
          else if (std::abs(cosine) < 0.3)
            ++crossing;
          else if (cosine > 0.9)
            ++same_way;
        }
      }
    }
    // Samples (0.05 s) of each kind of encounter: oncoming, crossing, driving ahead.
    EXPECT_GT(oncoming, 40);
    EXPECT_GT(crossing, 10);
    EXPECT_GT(same_way, 20);
  }
}

TEST(Traffic, CarsAreDrawnWhereTheyAre) {
  Scenario traffic = cityWithTraffic(1);
  const Scenario still = makeScenario("city_block", 1);
  SequenceParams params;
  params.width = 320;
  params.height = 97;
  const auto camera =
      geometry::makeCameraModel(sequenceCalibration(params, still.horizontal_fov_deg));
  Renderer renderer(*camera);
  // A time with a car 8-25 m ahead of the camera, nearly in its line of sight.
  int checked = 0;
  for (double t = 0.0; t < traffic.duration && checked < 3; t += 0.5) {
    const geometry::SE3 T_cam_world = traffic.T_world_cam(t).inverse();
    for (const MovingObject& car : traffic.moving_objects(t)) {
      const Eigen::Vector3d p =
          T_cam_world * Eigen::Vector3d(car.position.x(), car.position.y(), 0.8);
      if (!car.present || p.z() < 8.0 || p.z() > 25.0 || std::abs(p.x()) > 0.3 * p.z()) continue;
      traffic.animate(t, traffic.scene);
      cv::Mat with, without;
      renderer.render(traffic.scene, T_cam_world, with);
      const cv::Mat depth_with = renderer.range();
      renderer.render(still.scene, T_cam_world, without);
      const cv::Mat depth_without = renderer.range();
      // The car's centre pixel: nearer than the still world there, at the car's range.
      const Eigen::Vector2d pixel(
          camera->calibration().fx * p.x() / p.z() + camera->calibration().cx,
          camera->calibration().fy * p.y() / p.z() + camera->calibration().cy);
      const int x = static_cast<int>(std::lround(pixel.x())),
                y = static_cast<int>(std::lround(pixel.y()));
      EXPECT_NEAR(depth_with.at<float>(y, x), p.norm(), 2.5) << "t = " << t;
      EXPECT_LT(depth_with.at<float>(y, x), depth_without.at<float>(y, x) - 0.5) << "t = " << t;
      EXPECT_GT(cv::norm(with, without, cv::NORM_L1), 0.0);
      ++checked;
      break;
    }
  }
  EXPECT_EQ(checked, 3);
}

TEST(Traffic, CarsComeAndGoOutOfSight) {
  for (const std::uint32_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    Scenario traffic = cityWithTraffic(seed);
    SequenceParams params;
    params.width = 620;
    params.height = 188;
    const auto camera =
        geometry::makeCameraModel(sequenceCalibration(params, traffic.horizontal_fov_deg));
    Renderer renderer(*camera);
    cv::Mat image;
    int transitions = 0;
    std::vector<MovingObject> before = traffic.moving_objects(0.0);
    for (double t = 0.1; t <= traffic.duration; t += 0.1) {
      const std::vector<MovingObject> now = traffic.moving_objects(t);
      for (size_t i = 0; i < now.size(); ++i) {
        if (now[i].present == before[i].present) continue;
        // Rendered at the moment it is in the world (just after coming, just before going):
        // none of its surfaces is seen.
        const double at = now[i].present ? t : t - 0.1;
        traffic.animate(at, traffic.scene);
        renderer.render(traffic.scene, traffic.T_world_cam(at).inverse(), image);
        const cv::Mat& index = renderer.surfaceIndex();
        int seen = 0;
        for (int k = 0; k < 5; ++k)
          seen += cv::countNonZero(index == now[i].first_surface + k);
        EXPECT_EQ(seen, 0) << "car " << i << (now[i].present ? " comes" : " goes") << " in view at "
                           << at;
        ++transitions;
      }
      before = now;
    }
    EXPECT_GT(transitions, 10);
  }
}

}  // namespace
}  // namespace scale_drift_slam::sim
