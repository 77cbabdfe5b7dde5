// render_sequence: renders a named synthetic scene with exact ground truth as a TUM-format folder
// and, with --bag, a rosbag (doc/sequences.md).

#include <cstdio>
#include <iostream>
#include <memory>

#include "scale_drift_slam/common/stopwatch.h"
#include "scale_drift_slam/io/command_line.h"
#include "scale_drift_slam/ros/bag_io.h"
#include "scale_drift_slam/sim/sequence.h"
#include "scale_drift_slam/sim/sequence_writer.h"

namespace sds = scale_drift_slam;

namespace {

const char* kUsage =
    "usage: render_sequence --scene NAME --out DIR [--bag FILE] [--seed N] [options]\n"
    "Renders a synthetic image sequence with exact ground truth (doc/sequences.md).\n"
    "Scenes: courtyard_loop, office_orbit, corridor_straight, sphere_flyover, desk, office_pan,\n"
    "city_block, city_loop, city_tour, facade_grid, slider.\n"
    "Writes DIR/rgb.txt, DIR/rgb/<stamp>.png, DIR/groundtruth.txt (camera pose in the world, "
    "TUM),\n"
    "DIR/camera.yaml; with --bag FILE also a rosbag (/camera/image_raw, /camera/camera_info,\n"
    "/ground_truth/pose, /tf world -> camera_ground_truth), all stamped alike.\n"
    "Options:\n"
    "  --seed N                 textures and wobble (default 1); same seed, same images\n"
    "  --scene-seed N           the scene's textures from N, the wobble and noise from --seed\n"
    "                           (another pass through the same place; default: --seed)\n"
    "  --start-fraction F       start F (in [0, 1)) along the trajectory (default 0)\n"
    "  --laps N                 drive the route N times (city_loop only; default 1)\n"
    "  --frames N               render only the first N frames (default: the whole trajectory)\n"
    "  --fps HZ                 frame rate (default: the scene's, 30; city_*: 10)\n"
    "  --width W --height H     image size (default: the scene's, 640 x 480; city_*: 1241 x 376)\n"
    "  --fov DEG                horizontal field of view (default: the scene's; fisheye 120)\n"
    "  --distortion MODEL       none | radtan | tum_fr1 | fisheye (rendered through the lens\n"
    "                           model; default: the scene's, tum_fr1 for desk, else none)\n"
    "  --color                  bgr8 images instead of mono8\n"
    "  --noise SIGMA            Gaussian pixel noise in grey levels (default 0)\n"
    "  --exposure AMPLITUDE     brightness gain 1 + A sin(2 pi t / period) (default 0)\n"
    "  --exposure-period S      period of the brightness change (default 6 s)\n"
    "  --motion-blur S          shutter time in seconds (default 0: none)\n"
    "  --blur-samples N         renders averaged over the shutter (default 6)\n"
    "  --optics-blur SIGMA      lens softness, Gaussian sigma in pixels (default 0.5)\n"
    "  --blackout START:LENGTH  black frames from START for LENGTH seconds\n"
    "  --start-time S           stamp of the first frame (default 1000 s)\n"
    "  --traffic                city_* scenes: moving cars in the streets (oncoming, crossing,\n"
    "                           turning in ahead), from --seed; the tracker must reject them\n"
    "  --turn-rate DEG_S        city_* scenes: the car's yaw rate in the turns (default ~29;\n"
    "                           50: fast corners, ~65 px of image motion per frame at 10 Hz)\n"
    "  --quiet                  no progress output\n"
    "Camera effects (doc/sequences.md):\n"
    "  --rolling-shutter S      readout time top to bottom row (default 0: global shutter);\n"
    "                           each row at its own pose, the ground truth at the middle row's\n"
    "  --rolling-shutter-bands N  N bands of rows, one pose each (default 0: every row)\n"
    "  --vignetting K           brightness 1 - K r^2, r over the half diagonal (default 0)\n"
    "  --sunlight GAIN          world-fixed sunlit patches and sky GAIN times brighter\n"
    "                           (default 1: none; 3 with --auto-exposure)\n"
    "  --auto-exposure          a lagging gain keeps the mean grey level at 110; highlights clip\n"
    "  --defocus RADIUS         lens out of focus: disc blur of RADIUS pixels (default 0)\n"
    "  --jpeg QUALITY           JPEG round trip as compressed image_transport (default 0: off)\n";

sds::sim::SequenceParams parseParams(const sds::io::CommandLine& cl) {
  sds::sim::SequenceParams p;
  p.scene = cl.required("scene");
  const long seed = cl.integer("seed", 1);
  if (seed < 0 || seed > 0xffffffffL) throw std::invalid_argument("--seed must be in [0, 2^32)");
  p.seed = static_cast<std::uint32_t>(seed);
  if (cl.has("scene-seed")) {
    const long scene_seed = cl.integer("scene-seed", 1);
    if (scene_seed < 0 || scene_seed > 0xffffffffL) {
      throw std::invalid_argument("--scene-seed must be in [0, 2^32)");
    }
    p.scene_seed = static_cast<std::uint32_t>(scene_seed);
  }
  p.start_fraction = cl.number("start-fraction", 0.0);
  const long laps = cl.integer("laps", 1);
  if (laps < 1 || laps > 100) throw std::invalid_argument("--laps must be in [1, 100]");
  p.laps = static_cast<int>(laps);
  const long frames = cl.integer("frames", 0);
  if (frames < 0 || frames > 10000000) throw std::invalid_argument("--frames must be >= 0");
  p.max_frames = static_cast<int>(frames);
  const double fps = cl.number("fps", 0.0);
  if (cl.has("fps") && !(fps > 0)) throw std::invalid_argument("--fps must be > 0");
  p.rate = fps;
  const Eigen::Vector2i size = sds::sim::defaultImageSize(p.scene);
  p.width = static_cast<int>(cl.integer("width", size.x()));
  p.height = static_cast<int>(cl.integer("height", size.y()));
  p.horizontal_fov_deg = cl.number("fov", 0.0);
  if (cl.has("fov") && p.horizontal_fov_deg == 0) throw std::invalid_argument("--fov must be > 0");
  p.distortion = cl.text("distortion", "");
  p.color = cl.has("color");
  p.traffic = cl.has("traffic");
  if (cl.has("turn-rate")) p.turn_rate_deg_s = cl.number("turn-rate", 0.0);
  p.start_time = cl.number("start-time", 1000.0);
  p.realism.noise_sigma = cl.number("noise", 0.0);
  p.realism.exposure_amplitude = cl.number("exposure", 0.0);
  p.realism.exposure_period = cl.number("exposure-period", 6.0);
  p.realism.motion_blur = cl.number("motion-blur", 0.0);
  p.realism.motion_blur_samples = static_cast<int>(cl.integer("blur-samples", 6));
  p.realism.optics_blur = cl.number("optics-blur", 0.5);
  sds::sim::RealismParams& r = p.realism;
  r.rolling_shutter = cl.number("rolling-shutter", 0.0);
  r.rolling_shutter_bands = static_cast<int>(cl.integer("rolling-shutter-bands", 0));
  r.vignetting = cl.number("vignetting", 0.0);
  r.auto_exposure = cl.has("auto-exposure");
  r.sunlight = cl.number("sunlight", r.auto_exposure ? 3.0 : 1.0);
  r.defocus = cl.number("defocus", 0.0);
  r.jpeg_quality = static_cast<int>(cl.integer("jpeg", 0));
  if (cl.has("jpeg") && r.jpeg_quality == 0)
    throw std::invalid_argument("--jpeg must be in [1, 100]");
  if (const auto blackout = cl.value("blackout")) {
    double start = 0, length = 0;
    char rest = 0;
    if (std::sscanf(blackout->c_str(), "%lf:%lf%c", &start, &length, &rest) != 2) {
      throw std::invalid_argument("--blackout expects START:LENGTH in seconds, got '" + *blackout +
                                  "'");
    }
    p.realism.blackout_start = start;
    p.realism.blackout_duration = length;
  }
  p.validate();
  return p;
}

int run(const sds::io::CommandLine& cl) {
  cl.rejectUnknownFlags({"scene",
                         "out",
                         "bag",
                         "seed",
                         "scene-seed",
                         "start-fraction",
                         "laps",
                         "frames",
                         "fps",
                         "width",
                         "height",
                         "fov",
                         "distortion",
                         "color",
                         "noise",
                         "exposure",
                         "exposure-period",
                         "motion-blur",
                         "blur-samples",
                         "optics-blur",
                         "blackout",
                         "start-time",
                         "quiet",
                         "traffic",
                         "turn-rate",
                         "rolling-shutter",
                         "rolling-shutter-bands",
                         "vignetting",
                         "sunlight",
                         "auto-exposure",
                         "defocus",
                         "jpeg"});
  if (!cl.positional().empty()) {
    throw std::invalid_argument("unexpected argument '" + cl.positional().front() + "'");
  }
  const sds::sim::SequenceParams params = parseParams(cl);
  const std::string out = cl.required("out");
  const bool quiet = cl.has("quiet");
  const sds::common::Stopwatch timer;
  sds::sim::SequenceRenderer renderer(params);
  const double build_s = timer.seconds();
  sds::sim::TumSequenceWriter folder(out, renderer.calibration(), renderer.scenario().description);
  std::unique_ptr<sds::ros_conversions::SequenceBagWriter> bag;
  if (const auto bag_path = cl.value("bag")) {
    bag = std::make_unique<sds::ros_conversions::SequenceBagWriter>(*bag_path,
                                                                    renderer.calibration());
  }
  const int n = renderer.frameCount();
  for (int i = 0; i < n; ++i) {
    const sds::sim::RenderedFrame frame = renderer.render(i);
    folder.add(frame);
    if (bag) bag->write(frame.stamp_ns, frame.image, frame.T_world_cam);
    if (!quiet && (i % 100 == 0 || i == n - 1)) {
      std::fprintf(stderr, "\rrender_sequence: frame %d / %d", i + 1, n);
    }
  }
  folder.finish();
  bag.reset();
  const double total_s = timer.seconds();
  if (!quiet) std::fprintf(stderr, "\n");
  std::printf("%s: %d frames %dx%d at %.4g Hz (%s, seed %u) -> %s%s%s\n", params.scene.c_str(), n,
              params.width, params.height, renderer.rate(),
              renderer.calibration().describe().c_str(), params.seed, out.c_str(),
              cl.has("bag") ? " and " : "", cl.text("bag", "").c_str());
  std::printf("scene built in %.2f s, total %.2f s\n", build_s, total_s);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sds::io::runTool(argc, argv, kUsage, {"color", "quiet", "auto-exposure", "traffic"}, run);
}
