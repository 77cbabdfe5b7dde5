// facade_grid: repetitive texture. A camera walks along a street past a long building made of
// identical bays (the same texture on every bay: windows, a door, a sign, all alike) above a
// pavement of identical tiles; the only things that tell one place from another are the street
// furniture between the camera and the building (lamp posts, bins, benches, kiosks with posters,
// a parked van), at irregular spacing and each with its own texture.
//
// Street along x: the facade in the plane y = 0 (seen from y < 0), 24 bays of 2.5 m from
// x = -8 m, 12 m high; pavement from the facade to y = -9 m. Path: x from 0 to 28 m at 1.4 m/s at
// y = -7 m, height 1.6 m with a walking bob, looking at the facade (+y) and 10 degrees along the
// walk, with hand-held wobble. 20 s, 600 frames at 30 Hz.

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "scale_drift_slam/sim/texture_generator.h"
#include "scenario_builders.h"

namespace scale_drift_slam::sim::detail {
namespace {

constexpr double kBay = 2.5;        ///< Width of one identical facade bay (metres).
constexpr int kBays = 24;           ///< The building: x in [-8, 52].
constexpr double kStart = -8.0;     ///< x of the building's first bay.
constexpr double kHeight = 12.0;    ///< Building height.
constexpr double kPavement = 9.0;   ///< Pavement depth in front of the building.
constexpr double kDuration = 20.0;  ///< Seconds.
constexpr double kSpeed = 1.4;      ///< m/s along x.

/// Street furniture at irregular places, each with its own texture: what tells places apart.
void addStreetFurniture(Scene& scene, std::uint32_t seed) {
  cv::RNG rng(seed * 31 + 5);
  double x = kStart + 3.0;
  for (int k = 0; x < kStart + kBays * kBay - 2.0; ++k) {
    const double y = -rng.uniform(1.0, 3.0);
    const double yaw = rng.uniform(-0.3, 0.3);
    const std::uint32_t s = seed * 64 + static_cast<std::uint32_t>(k);
    switch (k % 5) {
      case 0:  // lamp post with a poster band
        addBox(scene, {x, y, 0}, {0.18, 0.18, 3.5}, yaw, textures::poster(cv::Size(40, 700), rng),
               textures::poster(cv::Size(32, 32), rng), 0.9f);
        break;
      case 1:  // bin
        addBox(scene, {x, y, 0}, {0.5, 0.5, 0.9}, yaw,
               textures::furniture("cabinet", 0.5, 0.9, 200, s),
               textures::poster(cv::Size(100, 100), rng));
        break;
      case 2:  // kiosk with posters
        addBox(scene, {x, y, 0}, {1.4, 1.2, 2.4}, yaw, textures::poster(cv::Size(280, 480), rng),
               textures::poster(cv::Size(280, 240), rng));
        break;
      case 3:  // bench
        addBox(scene, {x, y, 0}, {1.8, 0.5, 0.45}, yaw,
               textures::furniture("books", 1.8, 0.45, 200, s),
               textures::furniture("desk", 1.8, 0.5, 200, s + 1));
        break;
      default:  // parked van along the street
        addBox(scene, {x, -3.2, 0}, {4.5, 1.9, 2.0}, 0.0, textures::poster(cv::Size(900, 400), rng),
               textures::poster(cv::Size(450, 190), rng), 0.85f);
        x += 3.0;
        break;
    }
    x += rng.uniform(3.0, 7.0);
  }
}

/// Paving of identical square tiles (0.5 m, the same speckle on every tile, dark joints).
cv::Mat identicalTiles(double width_m, double depth_m, double texels_per_metre,
                       std::uint32_t seed) {
  const int side = static_cast<int>(std::lround(0.5 * texels_per_metre));
  cv::Mat tile(side, side, CV_8U, cv::Scalar(150));
  cv::RNG rng(seed);
  textures::addNoise(tile, 14.0, side / 2.0, 3, rng);
  cv::rectangle(tile, cv::Rect(0, 0, side, side), cv::Scalar(70), 2);
  return cv::repeat(tile, static_cast<int>(std::lround(depth_m / 0.5)),
                    static_cast<int>(std::lround(width_m / 0.5)));
}

/// One bay of the building (width_m wide, height_m high): plaster with a pilaster at each side, a
/// string course and a window with frame, bars and sill on every storey, a shop window and a
/// door on the ground floor. Every bay shows this same texture.
cv::Mat bayTexture(double width_m, double height_m, double tpm, std::uint32_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(static_cast<int>(height_m * tpm), static_cast<int>(width_m * tpm), CV_8U,
                cv::Scalar(180));
  textures::addNoise(image, 10.0, 1.0 * tpm, 4, rng);
  auto px = [&](double metres) { return static_cast<int>(std::lround(metres * tpm)); };
  auto row = [&](double z) { return px(height_m - z); };  // texture rows run downwards
  auto box = [&](double x0, double z0, double x1, double z1, double level) {
    cv::rectangle(image, cv::Rect(cv::Point(px(x0), row(z1)), cv::Point(px(x1), row(z0))),
                  cv::Scalar(level), cv::FILLED);
  };
  box(0, 0, 0.15, height_m, 140);  // pilasters
  box(width_m - 0.15, 0, width_m, height_m, 140);
  const double w = 1.2, h = 1.6, x0 = 0.5 * (width_m - w);
  for (double floor_z = 3.0; floor_z + 2.4 < height_m; floor_z += 3.0) {
    box(0, floor_z - 0.1, width_m, floor_z + 0.1, 210);  // string course
    box(x0, floor_z + 0.8, x0 + w, floor_z + 0.8 + h, 225);
    box(x0 + 0.08, floor_z + 0.88, x0 + w - 0.08, floor_z + 0.72 + h, 55);  // glass
    box(x0 + 0.5 * w - 0.03, floor_z + 0.88, x0 + 0.5 * w + 0.03, floor_z + 0.72 + h, 225);
    box(x0 + 0.08, floor_z + 1.75, x0 + w - 0.08, floor_z + 1.8, 225);  // transom
    box(x0 - 0.1, floor_z + 0.7, x0 + w + 0.1, floor_z + 0.8, 235);     // sill
  }
  box(0.3, 0.4, 1.5, 2.3, 45);  // shop window with a bar
  box(0.3, 1.6, 1.5, 1.66, 200);
  box(1.7, 0.0, 2.25, 2.2, 90);  // door with a handle
  box(2.15, 1.0, 2.2, 1.12, 220);
  return image;
}

}  // namespace

Scenario makeFacadeGrid(std::uint32_t seed) {
  Scenario scenario;
  scenario.name = "facade_grid";
  scenario.description =
      "camera walking 28 m past a building of identical bays over identical paving tiles, "
      "with irregular street furniture";
  scenario.duration = kDuration;
  scenario.rate = 30.0;
  scenario.horizontal_fov_deg = 80.0;
  Scene& scene = scenario.scene;
  // One bay texture and one paving texture, used on every bay: the repetition is exact.
  const int bay = scene.addTexture(bayTexture(kBay, kHeight, 120.0, seed * 16 + 3));
  const int tiles = scene.addTexture(identicalTiles(kBay, kPavement, 60.0, seed * 16 + 4));
  for (int k = 0; k < kBays; ++k) {
    const double x = kStart + k * kBay;
    // Facade seen from y < 0: its left end is at x (texture rows along +x, columns downwards).
    const int facade = scene.addQuad({x, 0, kHeight}, {kBay, 0, 0}, {0, 0, -kHeight}, bay, 0.95f);
    scene.surface(facade).tint = Eigen::Vector3f(0.7f, 1.0f, 1.25f);
    scene.addQuad({x, 0, 0}, {kBay, 0, 0}, {0, -kPavement, 0}, tiles, 0.9f);
  }
  addStreetFurniture(scene, seed);

  cv::RNG rng(seed);
  const double step_hz = 1.8;
  const Wobble yaw(rng, 0.03, 0.25), pitch(rng, 0.025, 0.3), roll(rng, 0.02, 0.35);
  const Wobble sway(rng, 0.03, 0.4);
  scenario.T_world_cam = [=](double t) {
    const double x =
        kSpeed * t - kSpeed * 0.08 / (2 * M_PI * step_hz) * std::sin(2 * M_PI * step_hz * t);
    const Eigen::Vector3d position(x, -7.0 + sway(t),
                                   1.6 + 0.025 * std::sin(2 * M_PI * step_hz * t));
    const double a = 10.0 * M_PI / 180.0 + yaw(t);  // a little along the walk
    const Eigen::Vector3d look(std::sin(a), std::cos(a), std::tan(0.08 + pitch(t)));
    return geometry::SE3(lookRotation(look, Eigen::Vector3d::UnitZ(), roll(t)), position);
  };
  return scenario;
}

}  // namespace scale_drift_slam::sim::detail
