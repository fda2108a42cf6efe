// # implicit: SDF primitives
//
// One evaluation function per primitive, in the primitive's local space, after
// Inigo Quilez's catalogue (iquilezles.org/articles/distfunctions). All are
// exact Euclidean distances (1-Lipschitz) unless noted. The seed's six types
// keep their exact conventions: `box` has its corner at the origin and full
// size, `bbox` is centred with half sizes, `capped_cone` takes a half height.
//
// Each primitive of sdf_primitive_table.h has one block here: its formula,
// its JSON parameters, and its evaluation, bounds, Lipschitz factor and
// parameter checks on an sdf_node.
#pragma once

#include <algorithm>
#include <sstream>

#include "../math/math.h"
#include "sdf_program.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PRIMITIVES (local space)
// -----------------------------------------------------------------------------

// Shortest readable form of a number for messages.
inline std::string format_param_value(float value) {
  auto stream = std::ostringstream{};
  stream << value;
  return stream.str();
}

// Most primitives have no checks across parameters.
inline sdf_param_problem sdf_no_problem(const sdf_node&) { return {}; }

// A box centred at the origin with half sizes `half`.
inline bbox3f centered_bounds(vec3f half) { return {-half, half}; }

// Box centred at the origin with half sizes `half`.
inline float sd_centered_box(vec3f p, vec3f half) {
  auto d = abs(p) - half;
  return std::min(max(d), 0.0f) + length(max(d, 0.0f));
}

// Seed `box`: full size `whd`, corner at the local origin, occupies [0,whd].
inline float sd_box(vec3f p, vec3f whd) {
  return sd_centered_box(p - whd * 0.5f, whd * 0.5f);
}
inline constexpr auto sdf_params_box = std::array<sdf_param, 1>{
    {{"whd", sdf_param_field::size, sdf_param_range::positive}}};
inline float  eval_box(const sdf_node& n, vec3f p) { return sd_box(p, n.size); }
inline bbox3f bounds_box(const sdf_node& n) { return {{0, 0, 0}, n.size}; }
inline float  lipschitz_box(const sdf_node&) { return 1; }
inline sdf_param_problem check_box(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Seed `bbox`: box frame centred at the origin, half sizes `half`; its bars
// are `thickness` wide and flush with the box's faces.
inline float sd_box_frame(vec3f p, vec3f half, float thickness) {
  auto q = abs(p) - half;
  auto r = abs(q + thickness) - thickness;
  auto t = [](vec3f a) {
    return length(max(a, 0.0f)) + std::min(max(a), 0.0f);
  };
  return std::min(
      std::min(t({q.x, r.y, r.z}), t({r.x, q.y, r.z})), t({r.x, r.y, q.z}));
}
inline constexpr auto sdf_params_bbox = std::array<sdf_param, 2>{
    {{"whd", sdf_param_field::size, sdf_param_range::positive},
        {"thickness", sdf_param_field::thickness, sdf_param_range::positive}}};
inline float eval_bbox(const sdf_node& n, vec3f p) {
  return sd_box_frame(p, n.size, n.thickness);
}
inline bbox3f bounds_bbox(const sdf_node& n) { return centered_bounds(n.size); }
inline float  lipschitz_bbox(const sdf_node&) { return 1; }
inline sdf_param_problem check_bbox(const sdf_node& n) {
  return sdf_no_problem(n);
}

inline float sd_sphere(vec3f p, float radius) { return length(p) - radius; }
inline constexpr auto sdf_params_sphere = std::array<sdf_param, 1>{
    {{"radius", sdf_param_field::radius, sdf_param_range::positive}}};
inline float eval_sphere(const sdf_node& n, vec3f p) {
  return sd_sphere(p, n.radius);
}
inline bbox3f bounds_sphere(const sdf_node& n) {
  return centered_bounds(vec3f{1, 1, 1} * n.radius);
}
inline float             lipschitz_sphere(const sdf_node&) { return 1; }
inline sdf_param_problem check_sphere(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Torus about the local y axis: ring radius `r1`, tube radius `r2`.
inline float sd_torus(vec3f p, float r1, float r2) {
  auto q = vec2f{length(vec2f{p.x, p.z}) - r1, p.y};
  return length(q) - r2;
}
inline constexpr auto sdf_params_torus = std::array<sdf_param, 2>{
    {{"r1", sdf_param_field::radius, sdf_param_range::positive},
        {"r2", sdf_param_field::radius2, sdf_param_range::positive}}};
inline float eval_torus(const sdf_node& n, vec3f p) {
  return sd_torus(p, n.radius, n.radius2);
}
inline bbox3f bounds_torus(const sdf_node& n) {
  auto r = n.radius + n.radius2;
  return centered_bounds({r, n.radius2, r});
}
inline float             lipschitz_torus(const sdf_node&) { return 1; }
inline sdf_param_problem check_torus(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Seed `capped_cone`: axis y, spans y in [-height, height], radius r1 at the
// bottom and r2 at the top.
inline float sd_capped_cone(vec3f p, float height, float r1, float r2) {
  auto q  = vec2f{length(vec2f{p.x, p.z}), p.y};
  auto k1 = vec2f{r2, height};
  auto k2 = vec2f{r2 - r1, 2 * height};
  auto ca =
      vec2f{q.x - std::min(q.x, q.y < 0 ? r1 : r2), std::abs(q.y) - height};
  auto kk = dot(k2, k2);
  auto cb =
      q - k1 + k2 * clamp(kk > 0 ? dot(k1 - q, k2) / kk : 0.0f, 0.0f, 1.0f);
  auto s = (cb.x < 0 && ca.y < 0) ? -1.0f : 1.0f;
  return s * std::sqrt(std::min(dot(ca, ca), dot(cb, cb)));
}
inline constexpr auto sdf_params_capped_cone = std::array<sdf_param, 3>{
    {{"height", sdf_param_field::height, sdf_param_range::positive},
        {"r1", sdf_param_field::radius, sdf_param_range::non_negative},
        {"r2", sdf_param_field::radius2, sdf_param_range::non_negative}}};
inline float eval_capped_cone(const sdf_node& n, vec3f p) {
  return sd_capped_cone(p, n.height, n.radius, n.radius2);
}
inline bbox3f bounds_capped_cone(const sdf_node& n) {
  auto r = std::max(n.radius, n.radius2);
  return centered_bounds({r, n.height, r});
}
inline float lipschitz_capped_cone(const sdf_node&) { return 1; }
// A zero radius is a pointed cone, so only both zero is degenerate.
inline sdf_param_problem check_capped_cone(const sdf_node& n) {
  if (n.radius == 0 && n.radius2 == 0)
    return {"r2", "r1 and r2 cannot both be 0"};
  return {};
}

// Plane y = 0 with normal +y.
inline float          sd_plane(vec3f p) { return p.y; }
inline constexpr auto sdf_params_plane = std::array<sdf_param, 0>{};
inline float  eval_plane(const sdf_node&, vec3f p) { return sd_plane(p); }
inline bbox3f bounds_plane(const sdf_node&) {
  return {{-flt_inf, 0, -flt_inf}, {flt_inf, 0, flt_inf}};
}
inline float             lipschitz_plane(const sdf_node&) { return 1; }
inline sdf_param_problem check_plane(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Capsule along y between (0,-height,0) and (0,height,0).
inline float sd_capsule(vec3f p, float height, float radius) {
  auto y = clamp(p.y, -height, height);
  return length(vec3f{p.x, p.y - y, p.z}) - radius;
}
inline constexpr auto sdf_params_capsule = std::array<sdf_param, 2>{
    {{"height", sdf_param_field::height, sdf_param_range::positive},
        {"radius", sdf_param_field::radius, sdf_param_range::positive}}};
inline float eval_capsule(const sdf_node& n, vec3f p) {
  return sd_capsule(p, n.height, n.radius);
}
inline bbox3f bounds_capsule(const sdf_node& n) {
  return centered_bounds({n.radius, n.height + n.radius, n.radius});
}
inline float             lipschitz_capsule(const sdf_node&) { return 1; }
inline sdf_param_problem check_capsule(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Capped cylinder along y, half height `height`.
inline float sd_cylinder(vec3f p, float height, float radius) {
  auto d = vec2f{length(vec2f{p.x, p.z}) - radius, std::abs(p.y) - height};
  return std::min(std::max(d.x, d.y), 0.0f) + length(max(d, 0.0f));
}
inline constexpr auto sdf_params_cylinder = std::array<sdf_param, 2>{
    {{"height", sdf_param_field::height, sdf_param_range::positive},
        {"radius", sdf_param_field::radius, sdf_param_range::positive}}};
inline float eval_cylinder(const sdf_node& n, vec3f p) {
  return sd_cylinder(p, n.height, n.radius);
}
inline bbox3f bounds_cylinder(const sdf_node& n) {
  return centered_bounds({n.radius, n.height, n.radius});
}
inline float             lipschitz_cylinder(const sdf_node&) { return 1; }
inline sdf_param_problem check_cylinder(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Box with half sizes `half` whose edges are rounded by `radius` (the radius
// is inside the half sizes).
inline float sd_rounded_box(vec3f p, vec3f half, float radius) {
  return sd_centered_box(p, half - radius) - radius;
}
inline constexpr auto sdf_params_rounded_box = std::array<sdf_param, 2>{
    {{"whd", sdf_param_field::size, sdf_param_range::positive},
        {"radius", sdf_param_field::radius, sdf_param_range::positive}}};
inline float eval_rounded_box(const sdf_node& n, vec3f p) {
  return sd_rounded_box(p, n.size, n.radius);
}
inline bbox3f bounds_rounded_box(const sdf_node& n) {
  return centered_bounds(n.size);
}
inline float lipschitz_rounded_box(const sdf_node&) { return 1; }
// The rounding is carved out of the half sizes.
inline sdf_param_problem check_rounded_box(const sdf_node& n) {
  if (n.radius > min(n.size))
    return {"radius", "must be <= the smallest half size " +
                          format_param_value(min(n.size)) + ", found " +
                          format_param_value(n.radius)};
  return {};
}

// Ellipsoid with semi-axes `radii`. Not exact: IQ's bound k0*(k0-1)/k1, which
// is close to the distance near the surface; its Lipschitz factor is
// lipschitz_ellipsoid().
inline float sd_ellipsoid(vec3f p, vec3f radii) {
  auto k0 = length(p / radii);
  auto k1 = length(p / (radii * radii));
  if (k1 == 0) return -min(radii);
  return k0 * (k0 - 1) / k1;
}
inline constexpr auto sdf_params_ellipsoid = std::array<sdf_param, 1>{
    {{"radii", sdf_param_field::size, sdf_param_range::positive}}};
inline float eval_ellipsoid(const sdf_node& n, vec3f p) {
  return sd_ellipsoid(p, n.size);
}
inline bbox3f bounds_ellipsoid(const sdf_node& n) {
  return centered_bounds(n.size);
}
// IQ's bound k0(k0-1)/k1 is steeper than 1 away from the surface by at most
// the axis ratio.
inline float lipschitz_ellipsoid(const sdf_node& n) {
  auto lo = min(n.size), hi = max(n.size);
  return lo > 0 ? hi / lo : 1;
}
inline sdf_param_problem check_ellipsoid(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Regular octahedron |x|+|y|+|z| = size (exact version).
inline float sd_octahedron(vec3f p, float size) {
  p      = abs(p);
  auto m = p.x + p.y + p.z - size;
  auto q = vec3f{};
  if (3 * p.x < m)
    q = p;
  else if (3 * p.y < m)
    q = {p.y, p.z, p.x};
  else if (3 * p.z < m)
    q = {p.z, p.x, p.y};
  else
    return m * 0.57735027f;
  auto k = clamp(0.5f * (q.z - q.y + size), 0.0f, size);
  return length(vec3f{q.x, q.y - size + k, q.z - k});
}
inline constexpr auto sdf_params_octahedron = std::array<sdf_param, 1>{
    {{"radius", sdf_param_field::radius, sdf_param_range::positive}}};
inline float eval_octahedron(const sdf_node& n, vec3f p) {
  return sd_octahedron(p, n.radius);
}
inline bbox3f bounds_octahedron(const sdf_node& n) {
  return centered_bounds(vec3f{1, 1, 1} * n.radius);
}
inline float             lipschitz_octahedron(const sdf_node&) { return 1; }
inline sdf_param_problem check_octahedron(const sdf_node& n) {
  return sdf_no_problem(n);
}

// Distance of one primitive node at a local point (inline: the tapes'
// loops call it for every primitive clause).
inline float eval_primitive(const sdf_node& node, vec3f p) {
#define IMPLICIT_SDF_EVAL(id, name) \
  case sdf_type::id: return eval_##id(node, p);
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_EVAL)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_EVAL
  return flt_max;  // an operator: no primitive
}

// -----------------------------------------------------------------------------
// OPERATORS (on distances)
// -----------------------------------------------------------------------------

// Polynomial smooth minimum; never below min(a,b) - blend/4.
inline float smooth_min(float a, float b, float blend) {
  if (blend <= 0) return std::min(a, b);
  auto h = std::max(blend - std::abs(a - b), 0.0f) / blend;
  return std::min(a, b) - h * h * blend * 0.25f;
}
// The smooth minimum of a smooth union group (sdf_program.h): `values`
// sorted in increasing order, folded from the smallest.
inline float smooth_min_sorted(const float* values, int count, float blend) {
  auto m = values[0];
  for (auto i = 1; i < count; i++) m = smooth_min(m, values[i], blend);
  return m;
}
inline float smooth_max(float a, float b, float blend) {
  return -smooth_min(-a, -b, blend);
}

// -----------------------------------------------------------------------------
// SHARED HELPERS (the one copy of each)
// -----------------------------------------------------------------------------

// Gradient of a distance `f` by tetrahedral central differences with step
// `step` (IQ, "normals for an SDF"): four evaluations instead of six. Not
// normalized.
template <typename Distance>
inline vec3f tetrahedral_gradient(const Distance& f, vec3f p, float step) {
  auto k0 = vec3f{1, -1, -1}, k1 = vec3f{-1, -1, 1}, k2 = vec3f{-1, 1, -1},
       k3 = vec3f{1, 1, 1};
  return k0 * f(p + k0 * step) + k1 * f(p + k1 * step) + k2 * f(p + k2 * step) +
         k3 * f(p + k3 * step);
}

// Both parameters t0 <= t1 where a ray (any direction length) crosses the
// sphere of radius `radius` about the origin; false if it misses. Stable
// form (Hearn & Baker, as in pbrt and Ray Tracing Gems ch. 7): the
// discriminant from the closest approach, the roots from c/q and q/a.
inline bool intersect_sphere(
    const ray3f& ray, float radius, float& t0, float& t1) {
  auto a    = dot(ray.d, ray.d);
  auto b    = dot(ray.o, ray.d);
  auto c    = dot(ray.o, ray.o) - radius * radius;
  auto l    = ray.o - ray.d * (b / a);
  auto disc = radius * radius - dot(l, l);
  if (disc < 0) return false;
  auto q = -b - std::copysign(std::sqrt(a * disc), b);
  if (q == 0) {
    t0 = t1 = -b / a;
    return true;
  }
  t0 = c / q;
  t1 = q / a;
  if (t0 > t1) std::swap(t0, t1);
  return true;
}

// Crossings of a ray with the surface of the seed's capped cone (axis y,
// y in [-height, height], radius r1 at the bottom and r2 at the top), in
// increasing t over the whole line: `count` of them (0, or 2 for a convex
// solid, more only where the rim is met twice by rounding). The side is
// x^2 + z^2 = (a + b y)^2 with b = (r2 - r1) / (2 height), a = r(0); a
// small tolerance at the rim keeps rays from slipping between side and cap.
inline int intersect_capped_cone(
    const ray3f& ray, float height, float r1, float r2, float crossings[4]) {
  auto& o = ray.o;
  auto& d = ray.d;
  auto  b = (r2 - r1) / (2 * height), a = 0.5f * (r1 + r2);
  auto  rim   = 1e-5f * std::max(height, std::max(r1, r2));
  auto  count = 0;
  auto  add   = [&](float t) {
    if (std::isfinite(t)) crossings[count++] = t;
  };
  // Side: A t^2 + 2 B t + C = 0, roots kept where y is within the caps.
  auto ra      = a + b * o.y;
  auto qa      = d.x * d.x + d.z * d.z - b * b * d.y * d.y;
  auto qb      = o.x * d.x + o.z * d.z - b * d.y * ra;
  auto qc      = o.x * o.x + o.z * o.z - ra * ra;
  auto on_side = [&](float t) {
    return std::abs(o.y + t * d.y) <= height + rim;
  };
  if (qa != 0) {
    auto disc = qb * qb - qa * qc;
    if (disc >= 0) {
      // Stable roots: q = -(B + sign(B) sqrt(disc)), t = q / A and C / q.
      auto q = -(qb + std::copysign(std::sqrt(disc), qb));
      if (on_side(q / qa)) add(q / qa);
      if (q != 0 && on_side(qc / q)) add(qc / q);
    }
  } else if (qb != 0 && on_side(-qc / (2 * qb))) {
    add(-qc / (2 * qb));
  }
  // Caps: y = -height (radius r1) and y = +height (radius r2).
  if (d.y != 0) {
    for (auto side : {-1.0f, 1.0f}) {
      auto t = (side * height - o.y) / d.y;
      auto x = o.x + t * d.x, z = o.z + t * d.z;
      auto r = (side < 0 ? r1 : r2) + rim;
      if (x * x + z * z <= r * r) add(t);
    }
  }
  std::sort(crossings, crossings + count);
  return count;
}

}  // namespace implicit
