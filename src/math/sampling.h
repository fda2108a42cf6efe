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

// -----------------------------------------------------------------------------
// SPHERICAL RECTANGLES (Urena, Fajardo and King 2013, "An Area-Preserving
// Parametrization for Spherical Rectangles")
// -----------------------------------------------------------------------------

// The rectangle [x0, x1] x [y0, y1] of the plane z = z0 != 0, seen from the
// origin, prepared for points uniform in its solid angle. The four interior
// angles of the spherical rectangle are kept as their excess over pi/2, each
// an atan2 of the corner's products (no acos, no difference of sums near
// 2 pi, so nearly edge-on rectangles keep their precision), by atan2_fast:
// the solid angle is within 2e-6 sr, so callers use it where a rectangle
// looks large (box lights: above 0.3 sr) and sample small ones by area.
struct spherical_rectangle {
  float x0 = 0, x1 = 0, y0 = 0, y1 = 0, z0 = 0;
  float b0 = 0, b1 = 0;   // z of the edge planes' normals at y0 and y1
  float start       = 0;  // the angle where the parametrization begins
  float solid_angle = 0;
};

inline spherical_rectangle make_spherical_rectangle(
    float x0, float x1, float y0, float y1, float z0) {
  auto rect = spherical_rectangle{x0, x1, y0, y1, z0};
  auto h = std::abs(z0), z2 = z0 * z0;
  auto corner = [&](float x, float y, float product) {
    return atan2_fast(product, h * std::sqrt(x * x + y * y + z2));
  };
  auto excess10 = corner(x1, y0, -y0 * x1), excess11 = corner(x1, y1, x1 * y1);
  auto excess01 = corner(x0, y1, -x0 * y1), excess00 = corner(x0, y0, x0 * y0);
  rect.b0          = -y0 / std::sqrt(y0 * y0 + z2);
  rect.b1          = y1 / std::sqrt(y1 * y1 + z2);
  rect.start       = -(excess01 + excess00);
  rect.solid_angle = excess10 + excess11 + excess01 + excess00;
  return rect;
}

// Point of the rectangle (z = z0) whose direction is uniform in the solid
// angle: pdf 1 / solid_angle.
inline vec3f sample_spherical_rectangle(
    const spherical_rectangle& rect, vec2f ruv) {
  // The angle that cuts off a fraction ruv.x of the solid angle, as the
  // paper's a_u = pi + phi, gives the column x.
  auto phi = rect.start + ruv.x * rect.solid_angle;
  auto fu  = (std::cos(phi) * rect.b0 + rect.b1) / std::sin(phi);
  auto cu =
      clamp(std::copysign(1.0f, fu) / std::sqrt(fu * fu + rect.b0 * rect.b0),
          -1.0f, 1.0f);
  auto x = cu * std::abs(rect.z0) / std::sqrt(std::max(1 - cu * cu, 1e-12f));
  x      = std::isnan(x) ? rect.x0 : clamp(x, rect.x0, rect.x1);
  // Along the column, y is uniform in the sine of its elevation.
  auto d  = std::sqrt(x * x + rect.z0 * rect.z0);
  auto h0 = rect.y0 / std::sqrt(d * d + rect.y0 * rect.y0);
  auto h1 = rect.y1 / std::sqrt(d * d + rect.y1 * rect.y1);
  auto hv = h0 + ruv.y * (h1 - h0);
  auto y  = hv * hv < 1 - 1e-6f ? hv * d / std::sqrt(1 - hv * hv) : rect.y1;
  return {x, clamp(y, rect.y0, rect.y1), rect.z0};
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
