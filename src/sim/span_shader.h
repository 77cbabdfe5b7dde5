#pragma once
// Private to src/sim: shading one row span of one surface (sim/renderer.h), in plain C++ and
// with AVX2 + FMA (chosen at run time, so the binary runs on any x86-64).

#include <cstdint>

#include "scale_drift_slam/sim/texture.h"

namespace scale_drift_slam::sim::detail {

/// Everything a span needs. Rays: per pixel x of the row, r = (rx[x], ry ? ry[x] : ry_value,
/// rz ? rz[x] : 1). Arrays indexed by x hold at least x_end + 8 values (the vector code reads
/// whole groups of 8; it writes only pixels in [x_begin, x_end)).
struct Span {
  const float* rx = nullptr;
  const float* ry = nullptr;
  const float* rz = nullptr;
  float ry_value = 0.0f;
  const float* lod_offset = nullptr;
  float* depth = nullptr;
  int* index = nullptr;
  std::uint8_t* out = nullptr;
  int x_begin = 0, x_end = 0;
  // The surface (see Renderer::Prepared in renderer.cpp).
  float n[3], g1[3], g2[3];
  float dn, g1o, g2o, lod_constant, gain;
  float texel_origin[2], texel_axes[4];  ///< Axes row-major: u = o0 + a0 b1 + a1 b2, ...
  bool triangle = false;
  int surface_index = 0;
  float tolerance = 0.0f;
  const Texture* texture = nullptr;
};

/// log2(x) for x > 0, to about 0.005 (enough to pick a mip level): exponent plus a quadratic in
/// the mantissa m in [1, 2).
inline float fastLog2(float x) {
  std::uint32_t bits;
  __builtin_memcpy(&bits, &x, sizeof(bits));
  const float exponent = static_cast<float>(static_cast<int>((bits >> 23) & 255u) - 127);
  bits = (bits & 0x007fffffu) | 0x3f800000u;
  float m;
  __builtin_memcpy(&m, &bits, sizeof(m));
  return exponent + (-0.34484843f * m + 2.02466578f) * m - 1.67487759f;
}

void shadeSpanScalar(const Span& span);
/// True when the processor has AVX2 and FMA.
bool vectorShadingAvailable();
/// The same as shadeSpanScalar with 8 pixels at a time; only call when available.
void shadeSpanVector(const Span& span);

}  // namespace scale_drift_slam::sim::detail
