// # implicit: math
//
// Small vectors, frames, bounding boxes and rays: the only copy of these types
// and of the formulas on them. Plain aggregates, free functions, float only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace implicit {

// -----------------------------------------------------------------------------
// CONSTANTS
// -----------------------------------------------------------------------------

inline constexpr float pif     = 3.14159265358979323846f;
inline constexpr float flt_max = std::numeric_limits<float>::max();
// The most negative float (numeric_limits::lowest(), not ::min(), which is
// the smallest positive normal float).
inline constexpr float flt_lowest = std::numeric_limits<float>::lowest();
// The same value under its old, misleading name, until sdf_program.cpp (owned
// elsewhere) moves to flt_lowest. New code uses flt_lowest.
inline constexpr float flt_min = flt_lowest;
inline constexpr float flt_eps = std::numeric_limits<float>::epsilon();
inline constexpr float flt_inf = std::numeric_limits<float>::infinity();

// Handles to scene elements are indices; this one means "none".
inline constexpr int invalidid = -1;

// -----------------------------------------------------------------------------
// VECTORS
// -----------------------------------------------------------------------------

struct vec2f {
  float x = 0, y = 0;
};
struct vec3f {
  float x = 0, y = 0, z = 0;
};
struct vec4f {
  float x = 0, y = 0, z = 0, w = 0;
};
struct vec2i {
  int x = 0, y = 0;
};
struct vec3i {
  int x = 0, y = 0, z = 0;
};

inline float& at(vec3f& a, int i) { return (&a.x)[i]; }
inline float  at(const vec3f& a, int i) { return (&a.x)[i]; }

// vec2f
inline vec2f operator+(vec2f a, vec2f b) { return {a.x + b.x, a.y + b.y}; }
inline vec2f operator-(vec2f a, vec2f b) { return {a.x - b.x, a.y - b.y}; }
inline vec2f operator*(vec2f a, float b) { return {a.x * b, a.y * b}; }
inline vec2f operator*(float a, vec2f b) { return {a * b.x, a * b.y}; }
inline vec2f operator*(vec2f a, vec2f b) { return {a.x * b.x, a.y * b.y}; }
inline vec2f operator/(vec2f a, float b) { return {a.x / b, a.y / b}; }
inline float dot(vec2f a, vec2f b) { return a.x * b.x + a.y * b.y; }
inline float length(vec2f a) { return std::sqrt(dot(a, a)); }
inline vec2f max(vec2f a, float b) {
  return {std::max(a.x, b), std::max(a.y, b)};
}
inline vec2f abs(vec2f a) { return {std::abs(a.x), std::abs(a.y)}; }

// vec3f
inline vec3f operator-(vec3f a) { return {-a.x, -a.y, -a.z}; }
inline vec3f operator+(vec3f a, vec3f b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline vec3f operator-(vec3f a, vec3f b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline vec3f operator*(vec3f a, vec3f b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}
inline vec3f operator/(vec3f a, vec3f b) {
  return {a.x / b.x, a.y / b.y, a.z / b.z};
}
inline vec3f operator+(vec3f a, float b) { return {a.x + b, a.y + b, a.z + b}; }
inline vec3f operator-(vec3f a, float b) { return {a.x - b, a.y - b, a.z - b}; }
inline vec3f operator*(vec3f a, float b) { return {a.x * b, a.y * b, a.z * b}; }
inline vec3f operator*(float a, vec3f b) { return {a * b.x, a * b.y, a * b.z}; }
inline vec3f operator/(vec3f a, float b) { return {a.x / b, a.y / b, a.z / b}; }
inline vec3f operator/(float a, vec3f b) { return {a / b.x, a / b.y, a / b.z}; }
inline vec3f& operator+=(vec3f& a, vec3f b) { return a = a + b; }
inline vec3f& operator-=(vec3f& a, vec3f b) { return a = a - b; }
inline vec3f& operator*=(vec3f& a, vec3f b) { return a = a * b; }
inline vec3f& operator*=(vec3f& a, float b) { return a = a * b; }
inline vec3f& operator/=(vec3f& a, float b) { return a = a / b; }
inline bool   operator==(vec3f a, vec3f b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
}
inline bool operator!=(vec3f a, vec3f b) { return !(a == b); }

inline float dot(vec3f a, vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline vec3f cross(vec3f a, vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(vec3f a) { return std::sqrt(dot(a, a)); }
inline float length_squared(vec3f a) { return dot(a, a); }
inline float distance(vec3f a, vec3f b) { return length(a - b); }
inline float distance_squared(vec3f a, vec3f b) { return dot(a - b, a - b); }
inline vec3f normalize(vec3f a) {
  auto l = length(a);
  return l != 0 ? a / l : a;
}
inline vec3f abs(vec3f a) {
  return {std::abs(a.x), std::abs(a.y), std::abs(a.z)};
}
inline vec3f min(vec3f a, vec3f b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline vec3f max(vec3f a, vec3f b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline vec3f max(vec3f a, float b) {
  return {std::max(a.x, b), std::max(a.y, b), std::max(a.z, b)};
}
inline vec3f min(vec3f a, float b) {
  return {std::min(a.x, b), std::min(a.y, b), std::min(a.z, b)};
}
inline vec3f clamp(vec3f a, float lo, float hi) { return min(max(a, lo), hi); }
inline float max(vec3f a) { return std::max(a.x, std::max(a.y, a.z)); }
inline float min(vec3f a) { return std::min(a.x, std::min(a.y, a.z)); }
inline float sum(vec3f a) { return a.x + a.y + a.z; }
inline float mean(vec3f a) { return sum(a) / 3; }
inline vec3f lerp(vec3f a, vec3f b, float u) { return a * (1 - u) + b * u; }
inline vec3f exp(vec3f a) {
  return {std::exp(a.x), std::exp(a.y), std::exp(a.z)};
}
inline vec3f log(vec3f a) {
  return {std::log(a.x), std::log(a.y), std::log(a.z)};
}
inline vec3f sqrt(vec3f a) {
  return {std::sqrt(a.x), std::sqrt(a.y), std::sqrt(a.z)};
}
inline bool isfinite(vec3f a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

// Reflect and refract, with directions pointing away from the surface.
inline vec3f reflect(vec3f w, vec3f n) { return -w + 2 * dot(n, w) * n; }
inline vec3f refract(vec3f w, vec3f n, float inv_eta) {
  auto cosine = dot(n, w);
  auto k      = 1 + inv_eta * inv_eta * (cosine * cosine - 1);
  if (k < 0) return {0, 0, 0};  // total internal reflection
  return -w * inv_eta + (inv_eta * cosine - std::sqrt(k)) * n;
}

// vec4f
inline vec4f operator+(vec4f a, vec4f b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w};
}
inline vec4f operator*(vec4f a, float b) {
  return {a.x * b, a.y * b, a.z * b, a.w * b};
}
inline vec4f operator*(vec4f a, vec4f b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z, a.w * b.w};
}
inline vec4f& operator+=(vec4f& a, vec4f b) { return a = a + b; }
inline vec3f  xyz(vec4f a) { return {a.x, a.y, a.z}; }

// vec3i
inline bool operator==(vec3i a, vec3i b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

// Scalars
inline float clamp(float a, float lo, float hi) {
  return std::min(std::max(a, lo), hi);
}
inline int clamp(int a, int lo, int hi) {
  return std::min(std::max(a, lo), hi);
}
inline float lerp(float a, float b, float u) { return a * (1 - u) + b * u; }
inline float radians(float a) { return a * pif / 180; }
inline float sign(float a) { return a < 0 ? -1.0f : 1.0f; }

// -----------------------------------------------------------------------------
// FRAMES (affine maps: columns x, y, z and origin o)
// -----------------------------------------------------------------------------

struct mat3f {
  vec3f x = {1, 0, 0}, y = {0, 1, 0}, z = {0, 0, 1};
};

// An affine map p -> x*p.x + y*p.y + z*p.z + o. Frames are named by what they
// map (world_from_local, local_from_world); the columns need not be
// orthonormal.
struct frame3f {
  vec3f x = {1, 0, 0}, y = {0, 1, 0}, z = {0, 0, 1}, o = {0, 0, 0};
};

inline constexpr frame3f identity_frame = {};

inline vec3f operator*(const mat3f& m, vec3f v) {
  return m.x * v.x + m.y * v.y + m.z * v.z;
}
inline mat3f transpose(const mat3f& m) {
  return {{m.x.x, m.y.x, m.z.x}, {m.x.y, m.y.y, m.z.y}, {m.x.z, m.y.z, m.z.z}};
}
inline float determinant(const mat3f& m) { return dot(m.x, cross(m.y, m.z)); }
inline mat3f inverse(const mat3f& m) {
  auto a = cross(m.y, m.z), b = cross(m.z, m.x), c = cross(m.x, m.y);
  auto d = dot(m.x, a);
  return transpose(mat3f{a / d, b / d, c / d});
}
inline mat3f rotation(const frame3f& f) { return {f.x, f.y, f.z}; }

inline vec3f transform_point(const frame3f& f, vec3f p) {
  return f.x * p.x + f.y * p.y + f.z * p.z + f.o;
}
inline vec3f transform_vector(const frame3f& f, vec3f v) {
  return f.x * v.x + f.y * v.y + f.z * v.z;
}
inline vec3f transform_direction(const frame3f& f, vec3f v) {
  return normalize(transform_vector(f, v));
}
inline frame3f operator*(const frame3f& a, const frame3f& b) {
  return {transform_vector(a, b.x), transform_vector(a, b.y),
      transform_vector(a, b.z), transform_point(a, b.o)};
}
// General affine inverse (frames from files may scale or shear).
inline frame3f inverse(const frame3f& f) {
  auto m  = inverse(rotation(f));
  auto io = -(m * f.o);
  return {m.x, m.y, m.z, io};
}
inline bool is_invertible(const frame3f& f) {
  auto d = determinant(rotation(f));
  return std::isfinite(d) && std::abs(d) > 1e-12f;
}
// Largest stretch of the linear part (spectral norm bound via Frobenius is
// too loose; power iteration on M^T M converges in a few steps for 3x3).
inline float max_stretch(const frame3f& f) {
  auto m   = rotation(f);
  auto mtm = transpose(m);
  auto v   = normalize(vec3f{1, 0.7f, 0.3f});
  auto s   = 0.0f;
  for (auto i = 0; i < 32; i++) {
    auto w = mtm * (m * v);
    s      = length(w);
    if (s == 0) return 0;
    v = w / s;
  }
  return std::sqrt(s);
}

// Frame looking from `from` toward `to`; z points backwards as in cameras.
inline frame3f lookat_frame(vec3f from, vec3f to, vec3f up) {
  auto w = normalize(from - to);
  auto u = normalize(cross(up, w));
  auto v = normalize(cross(w, u));
  return {u, v, w, from};
}

// Orthonormal basis around a unit vector (Duff et al. 2017).
inline frame3f basis_fromz(vec3f v) {
  auto z   = normalize(v);
  auto sgn = std::copysign(1.0f, z.z);
  auto a   = -1.0f / (sgn + z.z);
  auto b   = z.x * z.y * a;
  auto x   = vec3f{1.0f + sgn * z.x * z.x * a, sgn * b, -sgn * z.x};
  auto y   = vec3f{b, sgn + z.y * z.y * a, -z.y};
  return {x, y, z, {0, 0, 0}};
}

// -----------------------------------------------------------------------------
// BOUNDING BOXES
// -----------------------------------------------------------------------------

struct bbox3f {
  vec3f min = {flt_max, flt_max, flt_max};
  vec3f max = {flt_lowest, flt_lowest, flt_lowest};
};

inline constexpr bbox3f invalid_bbox = {};

inline bool  is_empty(const bbox3f& b) { return b.min.x > b.max.x; }
inline vec3f center(const bbox3f& b) { return (b.min + b.max) * 0.5f; }
inline vec3f size(const bbox3f& b) { return b.max - b.min; }
inline bool  is_finite(const bbox3f& b) {
   return isfinite(b.min) && isfinite(b.max);
}
inline bbox3f merge(const bbox3f& a, vec3f p) {
  return {min(a.min, p), max(a.max, p)};
}
inline bbox3f merge(const bbox3f& a, const bbox3f& b) {
  return {min(a.min, b.min), max(a.max, b.max)};
}
inline bbox3f intersect(const bbox3f& a, const bbox3f& b) {
  return {max(a.min, b.min), min(a.max, b.max)};
}
inline bbox3f expand(const bbox3f& b, float r) {
  return {b.min - r, b.max + r};
}
inline bool inside(const bbox3f& b, vec3f p) {
  return p.x >= b.min.x && p.x <= b.max.x && p.y >= b.min.y && p.y <= b.max.y &&
         p.z >= b.min.z && p.z <= b.max.z;
}

// Image of a box under an affine map (boxes with infinite extent stay infinite
// along the axes they touch).
inline bbox3f transform_bbox(const frame3f& f, const bbox3f& b) {
  if (is_empty(b)) return b;
  auto r = bbox3f{};
  for (auto c = 0; c < 8; c++) {
    auto p = vec3f{(c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y,
        (c & 4) ? b.max.z : b.min.z};
    auto q = f.o;
    for (auto a = 0; a < 3; a++) {
      auto axis = a == 0 ? f.x : a == 1 ? f.y : f.z;
      auto v    = at(p, a);
      for (auto k = 0; k < 3; k++) {
        auto m = at(axis, k);
        if (m != 0) at(q, k) += m * v;  // skip 0*inf
      }
    }
    r = merge(r, q);
  }
  return r;
}

// -----------------------------------------------------------------------------
// RAYS
// -----------------------------------------------------------------------------

struct ray3f {
  vec3f o    = {0, 0, 0};
  vec3f d    = {0, 0, 1};
  float tmin = 0;
  float tmax = flt_max;
};

inline vec3f ray_point(const ray3f& r, float t) { return r.o + r.d * t; }

// Transform a ray without renormalizing, so that t keeps its meaning.
inline ray3f transform_ray(const frame3f& f, const ray3f& r) {
  return {transform_point(f, r.o), transform_vector(f, r.d), r.tmin, r.tmax};
}

// Slab test; returns the parametric interval [t0, t1] of the ray inside the
// box, clipped to [ray.tmin, ray.tmax]. Robust to zero direction components.
inline bool intersect_bbox(
    const ray3f& ray, const bbox3f& b, float& t0, float& t1) {
  t0 = ray.tmin;
  t1 = ray.tmax;
  for (auto a = 0; a < 3; a++) {
    auto o = at(ray.o, a), d = at(ray.d, a);
    auto lo = at(b.min, a), hi = at(b.max, a);
    if (d == 0) {
      if (o < lo || o > hi) return false;
      continue;
    }
    auto inv = 1 / d;
    auto ta = (lo - o) * inv, tb = (hi - o) * inv;
    if (ta > tb) std::swap(ta, tb);
    // NaN-safe: min/max keep the current interval when a bound is NaN.
    t0 = ta > t0 ? ta : t0;
    t1 = tb < t1 ? tb : t1;
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace implicit
