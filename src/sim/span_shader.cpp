// Shading row spans (span_shader.h). Per pixel with ray r: t = dn / (n.r), b_i = t (g_i.r) -
// g_i.o, inside test on (b1, b2), z-test on t, texel = origin + axes b, level of detail
// lod_constant + lod_offset - 2 log2|n.r| (Renderer::Prepared in renderer.cpp).

#include "span_shader.h"

#include <cmath>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace scale_drift_slam::sim::detail {

void shadeSpanScalar(const Span& s) {
  const float limit = 1.0f + s.tolerance;
  for (int x = s.x_begin; x < s.x_end; ++x) {
    const float rx = s.rx[x], ry = s.ry ? s.ry[x] : s.ry_value, rz = s.rz ? s.rz[x] : 1.0f;
    const float nr = s.n[0] * rx + s.n[1] * ry + s.n[2] * rz;
    const float t = s.dn / nr;
    if (!(t > 0.0f) || !(t < s.depth[x])) continue;
    const float b1 = t * (s.g1[0] * rx + s.g1[1] * ry + s.g1[2] * rz) - s.g1o;
    const float b2 = t * (s.g2[0] * rx + s.g2[1] * ry + s.g2[2] * rz) - s.g2o;
    if (b1 < -s.tolerance || b2 < -s.tolerance) continue;
    if (s.triangle ? (b1 + b2 > limit) : (b1 > limit || b2 > limit)) continue;
    s.depth[x] = t;
    s.index[x] = s.surface_index;
    const float u = s.texel_origin[0] + s.texel_axes[0] * b1 + s.texel_axes[1] * b2;
    const float v = s.texel_origin[1] + s.texel_axes[2] * b1 + s.texel_axes[3] * b2;
    const float lod = s.lod_constant + s.lod_offset[x] - 2.0f * fastLog2(std::abs(nr));
    const float value = s.texture->sample(u, v, lod) * s.gain + 0.5f;
    s.out[x] = static_cast<std::uint8_t>(value >= 255.0f ? 255.0f : value);
  }
}

#if defined(__x86_64__)

bool vectorShadingAvailable() {
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

namespace {

#define SDS_AVX2 __attribute__((target("avx2,fma")))

/// table[index] for tables of 16 entries (index in [0, 15]).
SDS_AVX2 inline __m256i lookup16(const std::int32_t* table, __m256i index) {
  const __m256i low = _mm256_permutevar8x32_epi32(
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table)), index);
  const __m256i high = _mm256_permutevar8x32_epi32(
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table + 8)), index);
  return _mm256_blendv_epi8(low, high, _mm256_cmpgt_epi32(index, _mm256_set1_epi32(7)));
}

SDS_AVX2 inline __m256 lookup16(const float* table, __m256i index) {
  const __m256 low = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table), index);
  const __m256 high = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 8), index);
  return _mm256_blendv_ps(low, high,
                          _mm256_castsi256_ps(_mm256_cmpgt_epi32(index, _mm256_set1_epi32(7))));
}

/// Texture::bilinear for 8 lanes at levels `level`; inactive lanes read texel (0, 0) of level 0.
SDS_AVX2 inline __m256 bilinear8(const Texture::Layout& t, __m256i level, __m256 u, __m256 v,
                                 __m256i active) {
  const __m256 k256 = _mm256_set1_ps(256.0f), k65536 = _mm256_set1_ps(65536.0f);
  const __m256 half = _mm256_set1_ps(-0.5f);
  const __m256i bias = _mm256_set1_epi32(65536), low8 = _mm256_set1_epi32(255);
  const __m256 xs =
      _mm256_fmadd_ps(_mm256_fmadd_ps(u, lookup16(t.scale_x, level), half), k256, k65536);
  const __m256 ys =
      _mm256_fmadd_ps(_mm256_fmadd_ps(v, lookup16(t.scale_y, level), half), k256, k65536);
  const __m256i xi = _mm256_sub_epi32(_mm256_cvttps_epi32(xs), bias);
  const __m256i yi = _mm256_sub_epi32(_mm256_cvttps_epi32(ys), bias);
  const __m256i fx = _mm256_and_si256(xi, low8), fy = _mm256_and_si256(yi, low8);
  const __m256i stride = lookup16(t.stride, level);
  __m256i address =
      _mm256_add_epi32(_mm256_add_epi32(lookup16(t.offset, level), _mm256_srai_epi32(xi, 8)),
                       _mm256_mullo_epi32(_mm256_srai_epi32(yi, 8), stride));
  address = _mm256_and_si256(address, active);
  const int* base = reinterpret_cast<const int*>(t.pool);
  const __m256i w0 = _mm256_i32gather_epi32(base, address, 1);
  const __m256i w1 =
      _mm256_i32gather_epi32(base, _mm256_add_epi32(address, _mm256_and_si256(stride, active)), 1);
  const __m256i a = _mm256_and_si256(w0, low8),
                b = _mm256_and_si256(_mm256_srli_epi32(w0, 8), low8);
  const __m256i c = _mm256_and_si256(w1, low8),
                d = _mm256_and_si256(_mm256_srli_epi32(w1, 8), low8);
  const __m256i top =
      _mm256_add_epi32(_mm256_slli_epi32(a, 8), _mm256_mullo_epi32(_mm256_sub_epi32(b, a), fx));
  const __m256i bottom =
      _mm256_add_epi32(_mm256_slli_epi32(c, 8), _mm256_mullo_epi32(_mm256_sub_epi32(d, c), fx));
  const __m256i value = _mm256_add_epi32(_mm256_slli_epi32(top, 8),
                                         _mm256_mullo_epi32(_mm256_sub_epi32(bottom, top), fy));
  return _mm256_mul_ps(_mm256_cvtepi32_ps(value), _mm256_set1_ps(1.0f / 65536.0f));
}

/// Texture::sample for 8 lanes.
SDS_AVX2 inline __m256 sample8(const Texture::Layout& t, __m256 u, __m256 v, __m256 lod,
                               __m256i active) {
  const __m256 clamped =
      _mm256_min_ps(_mm256_max_ps(lod, _mm256_setzero_ps()), _mm256_set1_ps(t.max_lod));
  __m256i level = _mm256_cvttps_epi32(clamped);
  level = _mm256_min_epi32(level, _mm256_set1_epi32(t.levels > 1 ? t.levels - 2 : 0));
  const __m256 f = _mm256_sub_ps(clamped, _mm256_cvtepi32_ps(level));
  const __m256 weight =
      _mm256_min_ps(_mm256_max_ps(_mm256_fmsub_ps(f, _mm256_set1_ps(3.0f), _mm256_set1_ps(1.0f)),
                                  _mm256_setzero_ps()),
                    _mm256_set1_ps(1.0f));
  const __m256i next = _mm256_min_epi32(_mm256_add_epi32(level, _mm256_set1_epi32(1)),
                                        _mm256_set1_epi32(t.levels - 1));
  const __m256 active_ps = _mm256_castsi256_ps(active);
  const int any_a = _mm256_movemask_ps(
      _mm256_and_ps(_mm256_cmp_ps(weight, _mm256_set1_ps(1.0f), _CMP_LT_OQ), active_ps));
  const int any_b = _mm256_movemask_ps(
      _mm256_and_ps(_mm256_cmp_ps(weight, _mm256_setzero_ps(), _CMP_GT_OQ), active_ps));
  if (!any_b) return bilinear8(t, level, u, v, active);
  if (!any_a) return bilinear8(t, next, u, v, active);
  const __m256 a = bilinear8(t, level, u, v, active);
  const __m256 b = bilinear8(t, next, u, v, active);
  return _mm256_fmadd_ps(weight, _mm256_sub_ps(b, a), a);
}

SDS_AVX2 inline __m256 fastLog2x8(__m256 x) {
  const __m256i bits = _mm256_castps_si256(x);
  const __m256 exponent = _mm256_cvtepi32_ps(
      _mm256_sub_epi32(_mm256_and_si256(_mm256_srli_epi32(bits, 23), _mm256_set1_epi32(255)),
                       _mm256_set1_epi32(127)));
  const __m256 m = _mm256_castsi256_ps(_mm256_or_si256(
      _mm256_and_si256(bits, _mm256_set1_epi32(0x007fffff)), _mm256_set1_epi32(0x3f800000)));
  const __m256 poly =
      _mm256_fmadd_ps(_mm256_fmadd_ps(_mm256_set1_ps(-0.34484843f), m, _mm256_set1_ps(2.02466578f)),
                      m, _mm256_set1_ps(-1.67487759f));
  return _mm256_add_ps(exponent, poly);
}

SDS_AVX2 inline __m256 dot8(const float* w, __m256 rx, __m256 ry, __m256 rz) {
  return _mm256_fmadd_ps(
      _mm256_set1_ps(w[0]), rx,
      _mm256_fmadd_ps(_mm256_set1_ps(w[1]), ry, _mm256_mul_ps(_mm256_set1_ps(w[2]), rz)));
}

}  // namespace

SDS_AVX2 void shadeSpanVector(const Span& s) {
  const Texture::Layout& layout = s.texture->layout();
  const __m256 limit = _mm256_set1_ps(1.0f + s.tolerance), low = _mm256_set1_ps(-s.tolerance);
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (int x = s.x_begin; x < s.x_end; x += 8) {
    const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(s.x_end),
                                             _mm256_add_epi32(_mm256_set1_epi32(x), lanes));
    const __m256 rx = _mm256_loadu_ps(s.rx + x);
    const __m256 ry = s.ry ? _mm256_loadu_ps(s.ry + x) : _mm256_set1_ps(s.ry_value);
    const __m256 rz = s.rz ? _mm256_loadu_ps(s.rz + x) : _mm256_set1_ps(1.0f);
    const __m256 nr = dot8(s.n, rx, ry, rz);
    const __m256 t = _mm256_div_ps(_mm256_set1_ps(s.dn), nr);
    const __m256 depth = _mm256_maskload_ps(s.depth + x, valid);
    __m256 mask = _mm256_and_ps(_mm256_castsi256_ps(valid),
                                _mm256_and_ps(_mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GT_OQ),
                                              _mm256_cmp_ps(t, depth, _CMP_LT_OQ)));
    if (!_mm256_movemask_ps(mask)) continue;
    const __m256 b1 = _mm256_fmsub_ps(t, dot8(s.g1, rx, ry, rz), _mm256_set1_ps(s.g1o));
    const __m256 b2 = _mm256_fmsub_ps(t, dot8(s.g2, rx, ry, rz), _mm256_set1_ps(s.g2o));
    mask = _mm256_and_ps(mask, _mm256_and_ps(_mm256_cmp_ps(b1, low, _CMP_GE_OQ),
                                             _mm256_cmp_ps(b2, low, _CMP_GE_OQ)));
    if (s.triangle) {
      mask = _mm256_and_ps(mask, _mm256_cmp_ps(_mm256_add_ps(b1, b2), limit, _CMP_LE_OQ));
    } else {
      mask = _mm256_and_ps(mask, _mm256_and_ps(_mm256_cmp_ps(b1, limit, _CMP_LE_OQ),
                                               _mm256_cmp_ps(b2, limit, _CMP_LE_OQ)));
    }
    const int bits = _mm256_movemask_ps(mask);
    if (!bits) continue;
    const __m256i active = _mm256_castps_si256(mask);
    _mm256_maskstore_ps(s.depth + x, active, t);
    _mm256_maskstore_epi32(s.index + x, active, _mm256_set1_epi32(s.surface_index));
    const __m256 u = _mm256_fmadd_ps(
        _mm256_set1_ps(s.texel_axes[0]), b1,
        _mm256_fmadd_ps(_mm256_set1_ps(s.texel_axes[1]), b2, _mm256_set1_ps(s.texel_origin[0])));
    const __m256 v = _mm256_fmadd_ps(
        _mm256_set1_ps(s.texel_axes[2]), b1,
        _mm256_fmadd_ps(_mm256_set1_ps(s.texel_axes[3]), b2, _mm256_set1_ps(s.texel_origin[1])));
    const __m256 abs_nr = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), nr);
    const __m256 lod = _mm256_fmadd_ps(
        _mm256_set1_ps(-2.0f), fastLog2x8(abs_nr),
        _mm256_add_ps(_mm256_set1_ps(s.lod_constant), _mm256_loadu_ps(s.lod_offset + x)));
    const __m256 value =
        _mm256_min_ps(_mm256_fmadd_ps(sample8(layout, u, v, lod, active), _mm256_set1_ps(s.gain),
                                      _mm256_set1_ps(0.5f)),
                      _mm256_set1_ps(255.0f));
    alignas(32) std::int32_t grey[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(grey), _mm256_cvttps_epi32(value));
    for (int k = 0; k < 8; ++k) {
      if (bits & (1 << k)) s.out[x + k] = static_cast<std::uint8_t>(grey[k]);
    }
  }
}

#else

bool vectorShadingAvailable() {
  return false;
}
void shadeSpanVector(const Span& span) {
  shadeSpanScalar(span);
}

#endif

}  // namespace scale_drift_slam::sim::detail
