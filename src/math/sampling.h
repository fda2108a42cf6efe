// # implicit: sampling warps and their pdfs
//
// Each warp maps uniform numbers in [0,1)^n to a distribution; its `_pdf`
// twin returns the density of the same distribution (solid angle for
// directions).
#pragma once

#include <vector>

#include "math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// LAT-LONG MAPPING (environments)
// -----------------------------------------------------------------------------

// Direction in an environment's frame for lat-long texture coordinates uv:
// u turns phi from +x toward +z, v = theta / pi from +y (up) to -y.
inline vec3f latlong_direction(vec2f uv) {
  auto phi = 2 * pif * uv.x, theta = pif * uv.y;
  return {std::cos(phi) * std::sin(theta), std::cos(theta),
      std::sin(phi) * std::sin(theta)};
}

// atan2(y, x) within 4e-7 rad for finite arguments, with std::atan2's signs
// and zeros: (+-0, +0) gives +-0, (+-0, -0) gives +-pi, and a NaN argument
// NaN. The environment looks up two per bounce, where glibc's atanf took 5%
// of the seed's renders. The octant is reduced to a = min / max in [0, 1],
// and atan(a) = a P(a^2) with P the degree-7 polynomial of least maximum
// absolute error a |atan(a) / a - P(a^2)| (Remez exchange: 3.7e-8 before
// float rounding; degree 6 gave 2.5e-7 and 5.3e-7 after it, most of the
// rest is the rounding of results near pi).
inline float atan2_fast(float y, float x) {
  auto ax = std::abs(x), ay = std::abs(y);
  auto steep = ay > ax;
  auto hi = steep ? ay : ax, lo = steep ? ax : ay;
  auto a = lo == 0 && hi == 0 ? 0.0f : lo / hi;  // (0, 0): not 0 / 0
  auto t = a * a;
  auto p = -0.00405456197f;
  p      = p * t + 0.0218629368f;
  p      = p * t - 0.0559122924f;
  p      = p * t + 0.0964219443f;
  p      = p * t - 0.139086282f;
  p      = p * t + 0.199465653f;
  p      = p * t - 0.333298607f;
  p      = p * t + 0.999999336f;
  auto r = a * p;
  if (steep) r = pif / 2 - r;
  if (std::signbit(x)) r = pif - r;
  return std::copysign(r, y);
}

// Its inverse for a unit direction. atan2 keeps small polar angles accurate
// where acos(y) rounds to 0.
inline vec2f latlong_uv(vec3f direction) {
  auto u = atan2_fast(direction.z, direction.x) / (2 * pif);
  if (u < 0) u += 1;
  auto sin_theta =
      std::sqrt(direction.x * direction.x + direction.z * direction.z);
  return {u, atan2_fast(sin_theta, direction.y) / pif};
}

// Uniform direction on the unit sphere.
inline vec3f sample_sphere(vec2f ruv) {
  auto z   = 2 * ruv.y - 1;
  auto r   = std::sqrt(clamp(1 - z * z, 0.0f, 1.0f));
  auto phi = 2 * pif * ruv.x;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Cosine-weighted direction in the hemisphere around `normal`.
inline vec3f sample_hemisphere_cos(vec3f normal, vec2f ruv) {
  auto z     = std::sqrt(ruv.y);
  auto r     = std::sqrt(1 - z * z);
  auto phi   = 2 * pif * ruv.x;
  auto local = vec3f{r * std::cos(phi), r * std::sin(phi), z};
  return transform_direction(basis_fromz(normal), local);
}
inline float sample_hemisphere_cos_pdf(vec3f normal, vec3f direction) {
  auto cosw = dot(normal, direction);
  return cosw <= 0 ? 0 : cosw / pif;
}

// Uniform point on the unit disk (concentric mapping keeps strata).
inline vec2f sample_disk(vec2f ruv) {
  auto a = 2 * ruv.x - 1, b = 2 * ruv.y - 1;
  if (a == 0 && b == 0) return {0, 0};
  auto r = 0.0f, phi = 0.0f;
  if (a * a > b * b) {
    r   = a;
    phi = (pif / 4) * (b / a);
  } else {
    r   = b;
    phi = (pif / 2) - (pif / 4) * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

// Uniform direction inside a cone around the unit `axis`, its size given as
// 1 - cos(half angle): small cones (far lights) keep their precision, where
// 1 - cos_max rounded in float would lose it (a cone of 1e-4 rad has
// 1 - cos = 5e-9, below float's resolution near 1).
inline vec3f sample_cone(vec3f axis, float one_minus_cos, vec2f ruv) {
  auto v     = ruv.y * one_minus_cos;  // 1 - cos(theta)
  auto sin_t = std::sqrt(clamp(v * (2 - v), 0.0f, 1.0f));
  auto phi   = 2 * pif * ruv.x;
  auto local = vec3f{sin_t * std::cos(phi), sin_t * std::sin(phi), 1 - v};
  return transform_direction(basis_fromz(axis), local);
}
inline float sample_cone_pdf(float one_minus_cos) {
  return 1 / (2 * pif * one_minus_cos);
}

// 1 - cos of the half angle of the cone of a sphere of squared radius r2
// seen from squared distance d2 > r2: sin^2 / (1 + cos), without
// cancellation.
inline float sphere_cone_size(float r2, float d2) {
  auto sin2 = r2 / d2;
  return sin2 / (1 + std::sqrt(std::max(0.0f, 1 - sin2)));
}

// Index from a cumulative distribution (cdf.back() is the total weight).
inline int sample_discrete(const std::vector<float>& cdf, float r) {
  r        = clamp(r * cdf.back(), 0.0f, cdf.back() - 1e-6f * cdf.back());
  auto idx = (int)(std::upper_bound(cdf.data(), cdf.data() + cdf.size(), r) -
                   cdf.data());
  return clamp(idx, 0, (int)cdf.size() - 1);
}

// Uniform integer in [0, size).
inline int sample_uniform(int size, float r) {
  return clamp((int)(r * size), 0, size - 1);
}
inline float sample_uniform_pdf(int size) { return 1.0f / size; }

}  // namespace implicit
