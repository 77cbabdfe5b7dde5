#pragma once
// Procedural textures that look like the real world to a feature detector: corners at many scales
// (bricks, window frames, text, posters, paving), some repetitive structure (window rows,
// keyboards, tiles) and some weakly textured areas (plaster, sky, lakes). Every function is
// deterministic for its seed (cv::RNG), so a scene is the same on every run and machine.
// Images are 8-bit grey; sizes are in texels.

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace scale_drift_slam::sim::textures {

/// Sum of `octaves` value-noise layers (bicubic upsampled random grids), the largest with period
/// `largest_period` texels, each next one half the period and `persistence` times the amplitude.
/// Result CV_32F, roughly in [-1, 1].
cv::Mat fractalNoise(cv::Size size, double largest_period, int octaves, double persistence,
                     cv::RNG& rng);
/// Adds amplitude * fractal noise (grey levels) to an 8-bit image.
void addNoise(cv::Mat& image, double amplitude, double largest_period, int octaves, cv::RNG& rng);

/// A pronounceable random word ("Velorantic"), for signs, posters and door plates.
std::string randomWord(cv::RNG& rng, int min_syllables = 2, int max_syllables = 4);
/// Draws `text` fitted into `box` (centred, largest Hershey font scale that fits).
void drawTextInBox(cv::Mat& image, const std::string& text, const cv::Rect& box, double grey,
                   int font, int thickness);

/// A poster or sign: a background gradient, random shapes, a headline and lines of small text.
cv::Mat poster(cv::Size size, cv::RNG& rng);
/// A chessboard of `cols` x `rows` squares of `square` texels, black and white, with a white
/// border of one square (the corner positions are known exactly: multiples of `square`).
cv::Mat checkerboard(int cols, int rows, int square);

/// A building facade of width_m x height_m metres at `texels_per_metre`: a wall material (brick,
/// stone or plaster), storeys of windows with per-window variation, a ground floor with doors,
/// posters and a named sign, pipes, plants and weathering. Distinct for every seed.
cv::Mat facade(double width_m, double height_m, double texels_per_metre, std::uint32_t seed);
/// Outdoor ground: paving slabs, gravel and lawn patches, markings.
cv::Mat pavedGround(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed);
/// A street of length_m x width_m (texture x along the street): worn asphalt with repairs and
/// cracks, a dashed centre line, parking strips 2 m wide at both edges with bay ticks, lane arrows,
/// and a zebra crossing with a stop line at the chosen ends.
cv::Mat road(double length_m, double width_m, double texels_per_metre, std::uint32_t seed,
             bool crossing_at_start, bool crossing_at_end);
/// Unmarked asphalt (the middle of a crossing).
cv::Mat asphalt(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed);
/// The face of a kerb: 1 m stones with joints.
cv::Mat kerbStones(double length_m, double height_m, double texels_per_metre, std::uint32_t seed);
/// The side of a parked car: paint, windows with reflections, door seams, wheels.
cv::Mat carBody(double length_m, double height_m, double texels_per_metre, std::uint32_t seed);
/// Street furniture: "foliage" (tree crowns), "bark" (trunks), "metal" (painted poles).
cv::Mat streetMaterial(const std::string& kind, double width_m, double height_m,
                       double texels_per_metre, std::uint32_t seed);
/// An interior wall (width_m x height_m): paint, posters, a whiteboard, framed pictures, a door,
/// a radiator and a bookshelf, chosen and placed by the seed.
cv::Mat interiorWall(double width_m, double height_m, double texels_per_metre, std::uint32_t seed,
                     bool with_door);
/// Floors and ceilings: "carpet", "wood", "tiles", "ceiling".
cv::Mat floorMaterial(const std::string& kind, double width_m, double depth_m,
                      double texels_per_metre, std::uint32_t seed);
/// Furniture surfaces: "desk" (wood with papers and a keyboard), "cabinet" (doors and handles),
/// "books" (shelves of book spines), "screen" (a monitor showing windows of text).
cv::Mat furniture(const std::string& kind, double width_m, double height_m, double texels_per_metre,
                  std::uint32_t seed);
/// A desk top (width_m x depth_m) seen from above: wood veneer with papers, notebooks and sticky
/// notes lying askew, a keyboard, a mouse pad, pens, a cable and a coffee ring.
cv::Mat deskTop(double width_m, double depth_m, double texels_per_metre, std::uint32_t seed);
/// An equirectangular terrain map (width = 2 height) for a sphere: fields with crop rows,
/// roads, villages, forests and lakes. Periodic in longitude.
cv::Mat terrain(int height, std::uint32_t seed);

}  // namespace scale_drift_slam::sim::textures
