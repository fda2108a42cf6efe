// # implicit: the tape loop (internal to src/sdf)
//
// One loop runs every tape, templated on the value type T: float (a point),
// sdf_lanes (a batch of points, one clause at a time over all of them, as
// fidget's bulk evaluators), interval (a box) and the dual numbers of dual.h
// (value and gradient; interval gradients). The loop is a `switch` per
// clause; what a clause means for a value type is an overload of the
// functions below (math_* from interval.h and dual.h, csg_*, map_point,
// warp_point, eval_shape, point_coord), so there is one loop and one formula
// per clause and value type, and no virtual or std::function call.
#pragma once

#include <algorithm>
#include <cmath>

#include "../math/dual.h"
#include "../math/interval.h"
#include "sdf_primitives.h"
#include "sdf_tape.h"

namespace implicit {

// -----------------------------------------------------------------------------
// DISTANCE OPERATORS ON FLOATS (the stack tape's formulas, in its order)
// -----------------------------------------------------------------------------

inline float csg_union(float a, float b) { return std::min(a, b); }
inline float csg_intersection(float a, float b) { return std::max(a, b); }
inline float csg_subtraction(float a, float b) { return std::max(a, -b); }
inline float csg_smooth_union(float a, float b, float k) {
  return smooth_min(a, b, k);
}
inline float csg_smooth_intersection(float a, float b, float k) {
  return smooth_max(a, b, k);
}
inline float csg_smooth_subtraction(float a, float b, float k) {
  return smooth_max(a, -b, k);
}
inline float csg_round(float a, float radius) { return a - radius; }
inline float csg_onion(float a, float thickness) {
  return std::abs(a) - thickness;
}
inline float csg_scale(float a, float scale) { return a * scale; }

// -----------------------------------------------------------------------------
// DOMAIN OPERATORS (sdf_program.h gives each map), over any coordinate type
// -----------------------------------------------------------------------------

template <class C>
struct sdf_vec3 {
  C x = {}, y = {}, z = {};
};

// A float as a constant of any value type.
template <class C>
struct sdf_lift {
  static C make(float value) { return C(value); }
};
template <class T, int N>
struct sdf_lift<dual<T, N>> {
  static dual<T, N> make(float value) {
    return make_dual_constant<N>(T(value));
  }
};
template <class C>
inline C lift(float value) {
  return sdf_lift<C>::make(value);
}

// Rotation about y by k * p.y (twist) or about z by k * p.x (bend).
template <class C>
inline sdf_vec3<C> warp_twist(const sdf_vec3<C>& p, float k) {
  auto angle = math_mul(lift<C>(k), p.y);
  auto c = math_cos(angle), s = math_sin(angle);
  return {math_sub(math_mul(c, p.x), math_mul(s, p.z)), p.y,
      math_add(math_mul(s, p.x), math_mul(c, p.z))};
}
template <class C>
inline sdf_vec3<C> warp_bend(const sdf_vec3<C>& p, float k) {
  auto angle = math_mul(lift<C>(k), p.x);
  auto c = math_cos(angle), s = math_sin(angle);
  return {math_sub(math_mul(c, p.x), math_mul(s, p.y)),
      math_add(math_mul(s, p.x), math_mul(c, p.y)), p.z};
}
// The copy of a repeat that p falls in: n = round(p / size), clamped to
// [-count, count] when count >= 0 (size > 0).
template <class C>
inline C repeat_copy(const C& p, float size, int count) {
  auto n = math_round(math_div(p, lift<C>(size)));
  if (count >= 0)
    n = math_clamp(n, lift<C>((float)-count), lift<C>((float)count));
  return n;
}
// One axis of repeat: p - size * n, n its copy; no repetition when
// size <= 0.
template <class C>
inline C repeat_axis(const C& p, float size, int count) {
  if (!(size > 0)) return p;
  return math_sub(p, math_mul(lift<C>(size), repeat_copy(p, size, count)));
}
template <class C>
inline sdf_vec3<C> warp_repeat(const sdf_vec3<C>& p, const sdf_node& node) {
  return {repeat_axis(p.x, node.size.x, node.count.x),
      repeat_axis(p.y, node.size.y, node.count.y),
      repeat_axis(p.z, node.size.z, node.count.z)};
}
// p - clamp(p, -h, h) per axis.
template <class C>
inline C elongate_axis(const C& p, float h) {
  return math_sub(p, math_clamp(p, lift<C>(-h), lift<C>(h)));
}
template <class C>
inline sdf_vec3<C> warp_elongate(const sdf_vec3<C>& p, vec3f h) {
  return {elongate_axis(p.x, h.x), elongate_axis(p.y, h.y),
      elongate_axis(p.z, h.z)};
}
template <class C>
inline sdf_vec3<C> warp_mirror(const sdf_vec3<C>& p, int axes) {
  return {(axes & 1) ? math_abs(p.x) : p.x, (axes & 2) ? math_abs(p.y) : p.y,
      (axes & 4) ? math_abs(p.z) : p.z};
}
// The domain operator of a node (twist .. mirror) with its parameters.
template <class C>
inline sdf_vec3<C> warp_vec3(const sdf_node& node, const sdf_vec3<C>& p) {
  switch (node.type) {
    case sdf_type::op_twist: return warp_twist(p, node.value);
    case sdf_type::op_bend: return warp_bend(p, node.value);
    case sdf_type::op_repeat: return warp_repeat(p, node);
    case sdf_type::op_elongate: return warp_elongate(p, node.size);
    case sdf_type::op_mirror:
      return warp_mirror(p, node.axes);
      IMPLICIT_SDF_PRIMITIVE_CASES
      IMPLICIT_SDF_CSG_CASES
      IMPLICIT_SDF_MATH_CASES break;
  }
  return p;
}

// -----------------------------------------------------------------------------
// POINTS: float
// -----------------------------------------------------------------------------

inline vec3f map_point(const sdf_tape& pool, int frame, vec3f p) {
  return transform_point(pool.frames[frame], p);
}
inline vec3f warp_point(const sdf_node& node, vec3f p) {
  auto q = warp_vec3(node, sdf_vec3<float>{p.x, p.y, p.z});
  return {q.x, q.y, q.z};
}
inline float point_coord(vec3f p, int axis) { return at(p, axis); }
inline float eval_shape(const sdf_node& node, vec3f q, float) {
  return eval_primitive(node, q);
}
inline float sdf_constant(float value, const float*) { return value; }

// -----------------------------------------------------------------------------
// LANES: a batch of points
// -----------------------------------------------------------------------------

// Points per pass of the batched evaluator: the register files then take
// 256 x 32 x 4 + 64 x 32 x 12 bytes (56 KiB) of stack. A march's batch of
// points ahead along one ray (segment_trace.h) is shorter: its own width.
inline constexpr int sdf_lane_count       = 32;
inline constexpr int sdf_march_lane_count = 8;

template <int N>
struct sdf_lanes_of {
  float v[N];
};
template <int N>
struct sdf_lane_points_of {
  float x[N], y[N], z[N];
};
using sdf_lanes       = sdf_lanes_of<sdf_lane_count>;
using sdf_lane_points = sdf_lane_points_of<sdf_lane_count>;

template <int N, class F>
inline sdf_lanes_of<N> lanes_map(const sdf_lanes_of<N>& a, const F& f) {
  auto r = sdf_lanes_of<N>{};
  for (auto i = 0; i < N; i++) r.v[i] = f(a.v[i]);
  return r;
}
template <int N, class F>
inline sdf_lanes_of<N> lanes_map(
    const sdf_lanes_of<N>& a, const sdf_lanes_of<N>& b, const F& f) {
  auto r = sdf_lanes_of<N>{};
  for (auto i = 0; i < N; i++) r.v[i] = f(a.v[i], b.v[i]);
  return r;
}

// Every math clause of one or two operands, lane by lane.
#define IMPLICIT_SDF_LANES_MATH_0(id)
#define IMPLICIT_SDF_LANES_MATH_1(id)                   \
  template <int N>                                      \
  inline sdf_lanes_of<N> id(const sdf_lanes_of<N>& a) { \
    return lanes_map(a, [](float x) { return id(x); }); \
  }
#define IMPLICIT_SDF_LANES_MATH_2(id)                                  \
  template <int N>                                                     \
  inline sdf_lanes_of<N> id(                                           \
      const sdf_lanes_of<N>& a, const sdf_lanes_of<N>& b) {            \
    return lanes_map(a, b, [](float x, float y) { return id(x, y); }); \
  }
#define IMPLICIT_SDF_LANES_MATH(id, name, operands) \
  IMPLICIT_SDF_LANES_MATH_##operands(id)
IMPLICIT_SDF_MATH(IMPLICIT_SDF_LANES_MATH)
#undef IMPLICIT_SDF_LANES_MATH
#undef IMPLICIT_SDF_LANES_MATH_2
#undef IMPLICIT_SDF_LANES_MATH_1
#undef IMPLICIT_SDF_LANES_MATH_0

#define IMPLICIT_SDF_LANES_CSG_2(id)                                   \
  template <int N>                                                     \
  inline sdf_lanes_of<N> id(                                           \
      const sdf_lanes_of<N>& a, const sdf_lanes_of<N>& b) {            \
    return lanes_map(a, b, [](float x, float y) { return id(x, y); }); \
  }
#define IMPLICIT_SDF_LANES_CSG_K(id)                                       \
  template <int N>                                                         \
  inline sdf_lanes_of<N> id(                                               \
      const sdf_lanes_of<N>& a, const sdf_lanes_of<N>& b, float k) {       \
    return lanes_map(a, b, [k](float x, float y) { return id(x, y, k); }); \
  }
#define IMPLICIT_SDF_LANES_CSG_1(id)                             \
  template <int N>                                               \
  inline sdf_lanes_of<N> id(const sdf_lanes_of<N>& a, float k) { \
    return lanes_map(a, [k](float x) { return id(x, k); });      \
  }
IMPLICIT_SDF_LANES_CSG_2(csg_union)
IMPLICIT_SDF_LANES_CSG_2(csg_intersection)
IMPLICIT_SDF_LANES_CSG_2(csg_subtraction)
IMPLICIT_SDF_LANES_CSG_K(csg_smooth_union)
IMPLICIT_SDF_LANES_CSG_K(csg_smooth_intersection)
IMPLICIT_SDF_LANES_CSG_K(csg_smooth_subtraction)
IMPLICIT_SDF_LANES_CSG_1(csg_round)
IMPLICIT_SDF_LANES_CSG_1(csg_onion)
IMPLICIT_SDF_LANES_CSG_1(csg_scale)
#undef IMPLICIT_SDF_LANES_CSG_1
#undef IMPLICIT_SDF_LANES_CSG_K
#undef IMPLICIT_SDF_LANES_CSG_2

template <int N>
inline sdf_lane_points_of<N> map_point(
    const sdf_tape& pool, int frame, const sdf_lane_points_of<N>& p) {
  auto& f = pool.frames[frame];
  auto  q = sdf_lane_points_of<N>{};
  for (auto i = 0; i < N; i++) {
    auto r = transform_point(f, {p.x[i], p.y[i], p.z[i]});
    q.x[i] = r.x;
    q.y[i] = r.y;
    q.z[i] = r.z;
  }
  return q;
}
template <int N>
inline sdf_lane_points_of<N> warp_point(
    const sdf_node& node, const sdf_lane_points_of<N>& p) {
  auto q = sdf_lane_points_of<N>{};
  for (auto i = 0; i < N; i++) {
    auto r = warp_point(node, vec3f{p.x[i], p.y[i], p.z[i]});
    q.x[i] = r.x;
    q.y[i] = r.y;
    q.z[i] = r.z;
  }
  return q;
}
template <int N>
inline sdf_lanes_of<N> point_coord(const sdf_lane_points_of<N>& p, int axis) {
  auto r   = sdf_lanes_of<N>{};
  auto src = axis == 0 ? p.x : axis == 1 ? p.y : p.z;
  for (auto i = 0; i < N; i++) r.v[i] = src[i];
  return r;
}
// One loop per primitive type, its switch outside the lanes.
template <int N>
inline sdf_lanes_of<N> eval_shape(
    const sdf_node& node, const sdf_lane_points_of<N>& q, float) {
  auto r = sdf_lanes_of<N>{};
#define IMPLICIT_SDF_LANES_SHAPE(id, name)                \
  case sdf_type::id:                                      \
    for (auto i = 0; i < N; i++)                          \
      r.v[i] = eval_##id(node, {q.x[i], q.y[i], q.z[i]}); \
    break;
  switch (node.type) {
    IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_LANES_SHAPE)
    IMPLICIT_SDF_OPERATOR_CASES break;
  }
#undef IMPLICIT_SDF_LANES_SHAPE
  return r;
}
template <int N>
inline sdf_lanes_of<N> sdf_constant(float value, const sdf_lanes_of<N>*) {
  auto r = sdf_lanes_of<N>{};
  for (auto i = 0; i < N; i++) r.v[i] = value;
  return r;
}

// -----------------------------------------------------------------------------
// INTERVALS: a box
// -----------------------------------------------------------------------------

// A box of points (sdf_box_point) is also held as a ball for the primitives:
// their interval is the value at the centre plus or minus their Lipschitz
// factor times the radius, as sdf_prune bounded them, widened by
// `sdf_shape_margin` relative against the rounding of the centre value and
// of the radius; primitives that grow with each |coordinate| take the
// exact range over the box instead (eval_shape_box). Affine maps move the
// ball's centre and scale its radius by the map's stretch; 1-Lipschitz
// domain maps (elongate, mirror) keep its radius; the others rebuild it
// around the box.
inline constexpr float sdf_shape_margin = 1e-4f;

// A box as a box point.
inline sdf_box_point make_box_point(const bbox3f& box) {
  auto p   = sdf_box_point{};
  p.x      = {box.min.x, box.max.x};
  p.y      = {box.min.y, box.max.y};
  p.z      = {box.min.z, box.max.z};
  p.centre = center(box);
  p.radius = length(size(box)) * 0.5f;
  return p;
}

// An interval from endpoints computed in floats: entire if one is NaN.
inline interval make_interval(float lo, float hi) {
  return lo <= hi ? interval{lo, hi} : entire_interval;
}

// The distance operators over intervals (sdf_prune's rules, proven there):
// the smooth minimum and maximum are monotone in each operand, so their
// values lie between those at the ends. An operand that may be NaN makes
// the result entire.
inline interval csg_union(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  return make_interval(std::min(a.lo, b.lo), std::min(a.hi, b.hi));
}
inline interval csg_intersection(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  return make_interval(std::max(a.lo, b.lo), std::max(a.hi, b.hi));
}
inline interval csg_subtraction(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  return make_interval(std::max(a.lo, -b.hi), std::max(a.hi, -b.lo));
}
inline interval csg_smooth_union(interval a, interval b, float blend) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  auto k = std::max(blend, 0.0f);
  return make_interval(smooth_min(a.lo, b.lo, k), smooth_min(a.hi, b.hi, k));
}
inline interval csg_smooth_intersection(interval a, interval b, float blend) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  auto k = std::max(blend, 0.0f);
  return make_interval(smooth_max(a.lo, b.lo, k), smooth_max(a.hi, b.hi, k));
}
inline interval csg_smooth_subtraction(interval a, interval b, float blend) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  auto k = std::max(blend, 0.0f);
  return make_interval(smooth_max(a.lo, -b.hi, k), smooth_max(a.hi, -b.lo, k));
}
inline interval csg_round(interval a, float radius) {
  if (is_entire(a)) return a;
  return make_interval(a.lo - radius, a.hi - radius);
}
inline interval csg_onion(interval a, float t) {
  if (is_entire(a)) return a;
  if (a.lo >= 0) return make_interval(a.lo - t, a.hi - t);
  if (a.hi <= 0) return make_interval(-a.hi - t, -a.lo - t);
  return make_interval(-t, std::max(-a.lo, a.hi) - t);
}
inline interval csg_scale(interval a, float scale) {
  if (is_entire(a)) return a;
  return make_interval(a.lo * scale, a.hi * scale);
}

inline sdf_box_point map_point(
    const sdf_tape& pool, int frame, const sdf_box_point& p) {
  auto& f      = pool.frames[frame];
  auto  q      = sdf_box_point{};
  auto  affine = [&](float mx, float my, float mz, float o) {
    return math_add(
         math_add(math_mul(interval{mx}, p.x), math_mul(interval{my}, p.y)),
         math_add(math_mul(interval{mz}, p.z), interval{o}));
  };
  q.x      = affine(f.x.x, f.y.x, f.z.x, f.o.x);
  q.y      = affine(f.x.y, f.y.y, f.z.y, f.o.y);
  q.z      = affine(f.x.z, f.y.z, f.z.z, f.o.z);
  q.centre = transform_point(f, p.centre);
  q.radius = p.radius * pool.stretches[frame];
  return q;
}
// The point of a primitive: its ball, and its box where the map is a move
// (a rotated box's hull is no tighter than the ball, and costs more).
inline sdf_box_point map_shape_point(
    const sdf_tape& pool, int frame, const sdf_box_point& p) {
  auto& f  = pool.frames[frame];
  auto  q  = sdf_box_point{};
  q.centre = transform_point(f, p.centre);
  q.radius = p.radius * pool.stretches[frame];
  // Plain float sums: their rounding lies within the primitives' margin
  // (eval_shape_box), which outward rounding here cost 8% of a 10,000-sphere
  // preview.
  if (f.x == vec3f{1, 0, 0} && f.y == vec3f{0, 1, 0} && f.z == vec3f{0, 0, 1}) {
    q.x = {p.x.lo + f.o.x, p.x.hi + f.o.x};
    q.y = {p.y.lo + f.o.y, p.y.hi + f.o.y};
    q.z = {p.z.lo + f.o.z, p.z.hi + f.o.z};
  } else {
    q.x = q.y = q.z = entire_interval;
  }
  return q;
}
// Repeat over an interval: one copy when round(p / size) is one number,
// otherwise the cell [-size/2, size/2] and the clamped ends beyond it.
inline interval repeat_interval(interval p, float size, int count) {
  if (!(size > 0) || is_entire(p)) return p;
  auto n = repeat_copy(p, size, count);
  if (is_single(n)) return math_sub(p, math_mul(interval{size}, n));
  auto half  = float_up(size * 0.5f, 1);
  auto reach = float_up(size * (float)std::max(count, 0), 1);
  auto lo = -half, hi = half;
  if (count >= 0) {
    lo = std::min(lo, float_down(p.lo + reach, 1));
    hi = std::max(hi, float_up(p.hi - reach, 1));
  }
  return make_interval(lo, hi);
}
// Elongate is nondecreasing in p: its values at the ends bound it.
inline interval elongate_interval(interval p, float h) {
  if (is_entire(p)) return p;
  return make_interval(elongate_axis(p.lo, h), elongate_axis(p.hi, h));
}
inline sdf_box_point warp_point(const sdf_node& node, const sdf_box_point& p) {
  auto q   = sdf_box_point{};
  auto box = sdf_vec3<interval>{p.x, p.y, p.z};
  if (node.type == sdf_type::op_repeat) {
    box = {repeat_interval(p.x, node.size.x, node.count.x),
        repeat_interval(p.y, node.size.y, node.count.y),
        repeat_interval(p.z, node.size.z, node.count.z)};
  } else if (node.type == sdf_type::op_elongate) {
    box = {elongate_interval(p.x, node.size.x),
        elongate_interval(p.y, node.size.y),
        elongate_interval(p.z, node.size.z)};
  } else {
    box = warp_vec3(node, box);
  }
  q.x = box.x;
  q.y = box.y;
  q.z = box.z;
  if (node.type == sdf_type::op_elongate || node.type == sdf_type::op_mirror) {
    q.centre = warp_point(node, p.centre);
    q.radius = p.radius;
  } else {
    q.centre = {(q.x.lo + q.x.hi) * 0.5f, (q.y.lo + q.y.hi) * 0.5f,
        (q.z.lo + q.z.hi) * 0.5f};
    q.radius =
        float_up(length(vec3f{width(q.x), width(q.y), width(q.z)}) * 0.5f, 2);
    if (!std::isfinite(q.radius)) q.radius = flt_inf;
  }
  return q;
}
inline interval point_coord(const sdf_box_point& p, int axis) {
  return axis == 0 ? p.x : axis == 1 ? p.y : p.z;
}
// The least and largest |p| of an interval of coordinates p.
inline float least_abs(interval p) {
  return p.lo > 0 ? p.lo : p.hi < 0 ? -p.hi : 0.0f;
}
inline float largest_abs(interval p) {
  return std::max(std::abs(p.lo), std::abs(p.hi));
}
// The values at the nearest and farthest points of a box, widened by
// sdf_shape_margin of the coordinates' size against rounding (of the
// coordinates' shifts too: a primitive moves by at most the distance its
// point moves, a few ulps of the coordinates); false where not finite.
inline bool monotone_bound(float lo, float hi, vec3f far, interval& bound) {
  auto m =
      sdf_shape_margin * (far.x + far.y + far.z + std::abs(lo) + std::abs(hi));
  if (!std::isfinite(m)) return false;
  bound = {lo - m, hi + m};
  return true;
}
// Over a box (q's coordinates), primitives that grow with each |coordinate|
// (a sphere, a cylinder, a centred box) or with y (a plane) range from
// their value at its nearest point to that at its farthest: the exact
// range, where the ball's bound (its radius is the half diagonal) is wider:
// a thin cylinder's over a cube of side s by up to 0.37 s on each side.
// False for other primitives and for a box that is unknown (entire).
inline bool eval_shape_box(
    const sdf_node& node, const sdf_box_point& q, interval& bound) {
  auto type = node.type;
  if (type != sdf_type::sphere && type != sdf_type::cylinder &&
      type != sdf_type::box && type != sdf_type::rounded_box &&
      type != sdf_type::plane)
    return false;
  auto x = q.x, y = q.y, z = q.z;
  if (type == sdf_type::box) {  // the seed's box: corner at the origin
    auto h = node.size * 0.5f;
    x      = {x.lo - h.x, x.hi - h.x};
    y      = {y.lo - h.y, y.hi - h.y};
    z      = {z.lo - h.z, z.hi - h.z};
  }
  auto near = vec3f{least_abs(x), least_abs(y), least_abs(z)};
  auto far  = vec3f{largest_abs(x), largest_abs(y), largest_abs(z)};
  switch (type) {
    case sdf_type::sphere:
      return monotone_bound(sd_sphere(near, node.radius),
          sd_sphere(far, node.radius), far, bound);
    case sdf_type::cylinder:
      return monotone_bound(sd_cylinder(near, node.height, node.radius),
          sd_cylinder(far, node.height, node.radius), far, bound);
    case sdf_type::box:
      return monotone_bound(sd_centered_box(near, node.size * 0.5f),
          sd_centered_box(far, node.size * 0.5f), far, bound);
    case sdf_type::rounded_box:
      return monotone_bound(sd_rounded_box(near, node.size, node.radius),
          sd_rounded_box(far, node.size, node.radius), far, bound);
    default: return monotone_bound(y.lo, y.hi, far, bound);  // the plane
  }
}
// The box's bound where eval_shape_box gives one and the box lies within
// the ball (a box and its ball; a moved box), else the ball's (the value at
// its centre, plus or minus the Lipschitz factor times its radius), within
// the box's if any (the hull of a rotated box is wider than its ball).
inline interval eval_shape(
    const sdf_node& node, const sdf_box_point& q, float) {
  auto box      = interval{};
  auto has_box  = eval_shape_box(node, q, box);
  auto w        = vec3f{width(q.x), width(q.y), width(q.z)} * 0.5f;
  auto box_fits = dot(w, w) <= q.radius * q.radius * 1.001f;
  if (has_box && box_fits) return box;
  auto v = eval_primitive(node, q.centre);
  auto d = q.radius * primitive_lipschitz(node);
  auto m = sdf_shape_margin * (d + std::abs(v));
  auto r = make_interval(v - d - m, v + d + m);
  if (!has_box || is_entire(r)) return r;
  return make_interval(std::max(r.lo, box.lo), std::min(r.hi, box.hi));
}
inline interval sdf_constant(float value, const interval*) {
  return interval{value};
}

// -----------------------------------------------------------------------------
// DUAL NUMBERS: values with derivatives (dual<float, N> at a point,
// dual<interval, N> over a box; N = 3 partials, or 1 along a ray)
// -----------------------------------------------------------------------------

// Finite-difference step of primitives without an analytic gradient,
// relative to the size of the point in the primitive's space.
inline constexpr float sdf_shape_step = 1e-4f;

// The distance operators: the value of the operator on the values, and the
// derivative of the operand that gives it; where interval arithmetic cannot
// tell which, the hull of both (a box). The smooth minimum's partials are
// 1 - h/2 on the smaller operand and h/2 on the other, so its gradient is a
// convex combination of theirs: within their hull.
template <class T, int N>
inline dual<T, N> with_slopes(const T& value, const dual<T, N>& a) {
  auto r = a;
  r.v    = value;
  return r;
}
template <class T, int N>
inline dual<T, N> join_duals(
    const T& value, const dual<T, N>& a, const dual<T, N>& b) {
  auto r = dual<T, N>{value};
  for (auto i = 0; i < N; i++) r.d[i] = join_slopes(a.d[i], b.d[i]);
  return r;
}
template <class T, int N>
inline dual<T, N> csg_union(const dual<T, N>& a, const dual<T, N>& b) {
  auto value = csg_union(a.v, b.v);
  if (may_be_nan(a.v) || may_be_nan(b.v)) return with_unknown_slope<N>(value);
  if (always_less(b.v, a.v)) return with_slopes(value, b);
  if (always_less_equal(a.v, b.v)) return with_slopes(value, a);
  return join_duals(value, a, b);
}
template <class T, int N>
inline dual<T, N> csg_intersection(const dual<T, N>& a, const dual<T, N>& b) {
  auto value = csg_intersection(a.v, b.v);
  if (may_be_nan(a.v) || may_be_nan(b.v)) return with_unknown_slope<N>(value);
  if (always_less(a.v, b.v)) return with_slopes(value, b);
  if (always_less_equal(b.v, a.v)) return with_slopes(value, a);
  return join_duals(value, a, b);
}
template <class T, int N>
inline dual<T, N> csg_subtraction(const dual<T, N>& a, const dual<T, N>& b) {
  return csg_intersection(a, math_neg(b));
}
// Smooth blend of slopes: exact weights at a point, the hull over a box.
template <int N>
inline dual<float, N> blend_duals(
    float value, const dual<float, N>& a, const dual<float, N>& b, float k) {
  auto h     = std::max(k - std::abs(a.v - b.v), 0.0f) / k;
  auto small = b.v < a.v ? b : a;
  auto large = b.v < a.v ? a : b;
  auto r     = dual<float, N>{value};
  for (auto i = 0; i < N; i++)
    r.d[i] = (1 - h * 0.5f) * small.d[i] + h * 0.5f * large.d[i];
  return r;
}
template <int N>
inline dual<interval, N> blend_duals(interval value, const dual<interval, N>& a,
    const dual<interval, N>& b, float) {
  return join_duals(value, a, b);
}
template <class T, int N>
inline dual<T, N> csg_smooth_union(
    const dual<T, N>& a, const dual<T, N>& b, float k) {
  auto value = csg_smooth_union(a.v, b.v, k);
  if (may_be_nan(a.v) || may_be_nan(b.v)) return with_unknown_slope<N>(value);
  auto kk = lift<T>(std::max(k, 0.0f));
  if (always_less_equal(math_add(b.v, kk), a.v)) return with_slopes(value, b);
  if (always_less_equal(math_add(a.v, kk), b.v)) return with_slopes(value, a);
  return blend_duals(value, a, b, k);
}
template <class T, int N>
inline dual<T, N> csg_smooth_intersection(
    const dual<T, N>& a, const dual<T, N>& b, float k) {
  return math_neg(csg_smooth_union(math_neg(a), math_neg(b), k));
}
template <class T, int N>
inline dual<T, N> csg_smooth_subtraction(
    const dual<T, N>& a, const dual<T, N>& b, float k) {
  return csg_smooth_intersection(a, math_neg(b), k);
}
template <class T, int N>
inline dual<T, N> csg_round(const dual<T, N>& a, float radius) {
  return with_slopes(csg_round(a.v, radius), a);
}
template <class T, int N>
inline dual<T, N> csg_onion(const dual<T, N>& a, float thickness) {
  return with_slopes(csg_onion(a.v, thickness), math_abs(a));
}
template <class T, int N>
inline dual<T, N> csg_scale(const dual<T, N>& a, float scale) {
  auto r = dual<T, N>{csg_scale(a.v, scale)};
  for (auto i = 0; i < N; i++) r.d[i] = math_mul(lift<T>(scale), a.d[i]);
  return r;
}

// An affine map of dual coordinates, in transform_point's order (so the
// values are its floats).
template <class T, int N>
inline sdf_vec3<dual<T, N>> map_dual(
    const frame3f& f, const sdf_vec3<dual<T, N>>& p) {
  auto row = [&](float mx, float my, float mz, float o) {
    return math_add(math_add(math_add(math_mul(lift<dual<T, N>>(mx), p.x),
                                 math_mul(lift<dual<T, N>>(my), p.y)),
                        math_mul(lift<dual<T, N>>(mz), p.z)),
        lift<dual<T, N>>(o));
  };
  return {row(f.x.x, f.y.x, f.z.x, f.o.x), row(f.x.y, f.y.y, f.z.y, f.o.y),
      row(f.x.z, f.y.z, f.z.z, f.o.z)};
}
// The derivatives of a primitive along the input's axes: its gradient in
// its own space (`g`, each component an interval over a box) chained
// through the derivatives of its point.
template <class T, int N>
inline dual<T, N> chain_shape(
    const T& value, const T g[3], const sdf_vec3<dual<T, N>>& q) {
  auto r = dual<T, N>{value};
  for (auto k = 0; k < N; k++)
    r.d[k] =
        math_add(math_add(math_mul(g[0], q.x.d[k]), math_mul(g[1], q.y.d[k])),
            math_mul(g[2], q.z.d[k]));
  return r;
}

template <int N>
inline sdf_vec3<dual<float, N>> map_point(
    const sdf_tape& pool, int frame, const sdf_vec3<dual<float, N>>& p) {
  return map_dual(pool.frames[frame], p);
}
template <int N>
inline sdf_vec3<dual<float, N>> warp_point(
    const sdf_node& node, const sdf_vec3<dual<float, N>>& p) {
  return warp_vec3(node, p);
}
template <int N>
inline dual<float, N> point_coord(const sdf_vec3<dual<float, N>>& p, int axis) {
  return axis == 0 ? p.x : axis == 1 ? p.y : p.z;
}
// Analytic gradients where sdf_primitives has them, else tetrahedral
// differences of the primitive alone, in its own space.
template <int N>
inline dual<float, N> eval_shape(
    const sdf_node& node, const sdf_vec3<dual<float, N>>& q, float step) {
  auto p     = vec3f{q.x.v, q.y.v, q.z.v};
  auto value = eval_primitive(node, p);
  auto g     = vec3f{};
  if (!eval_primitive_gradient(node, p, g)) {
    auto h = step * std::max(1.0f, max(abs(p)));
    g      = tetrahedral_gradient(
            [&](vec3f x) { return eval_primitive(node, x); }, p, h) /
        (4 * h);
  }
  float slopes[3] = {g.x, g.y, g.z};
  return chain_shape(value, slopes, q);
}
template <int N>
inline dual<float, N> sdf_constant(float value, const dual<float, N>*) {
  return make_dual_constant<N>(value);
}

// A box of dual coordinates, with the ball of sdf_box_point.
template <int N>
struct sdf_dual_box_point {
  sdf_vec3<dual<interval, N>> p      = {};
  vec3f                       centre = {};
  float                       radius = 0;
};
// Over a box, with the partials along x, y and z.
inline sdf_dual_box_point<3> make_dual_box_point(const bbox3f& box) {
  auto b   = make_box_point(box);
  auto r   = sdf_dual_box_point<3>{};
  r.p      = {make_dual_variable(b.x, 0), make_dual_variable(b.y, 1),
           make_dual_variable(b.z, 2)};
  r.centre = b.centre;
  r.radius = b.radius;
  return r;
}
// Over a box around a piece of a ray, with the derivative along it.
inline sdf_dual_box_point<1> make_dual_box_point(
    const bbox3f& box, vec3f direction) {
  auto b = make_box_point(box);
  auto r = sdf_dual_box_point<1>{};
  r.p = {make_dual_along(b.x, direction.x), make_dual_along(b.y, direction.y),
      make_dual_along(b.z, direction.z)};
  r.centre = b.centre;
  r.radius = b.radius;
  return r;
}
template <int N>
inline sdf_dual_box_point<N> map_point(
    const sdf_tape& pool, int frame, const sdf_dual_box_point<N>& p) {
  auto r   = sdf_dual_box_point<N>{};
  r.p      = map_dual(pool.frames[frame], p.p);
  r.centre = transform_point(pool.frames[frame], p.centre);
  r.radius = p.radius * pool.stretches[frame];
  return r;
}
template <int N>
inline sdf_dual_box_point<N> warp_point(
    const sdf_node& node, const sdf_dual_box_point<N>& p) {
  // The ball as for intervals (from the coordinates' boxes).
  auto box    = sdf_box_point{p.p.x.v, p.p.y.v, p.p.z.v, p.centre, p.radius};
  auto warped = warp_point(node, box);
  auto r      = sdf_dual_box_point<N>{};
  r.p         = warp_vec3(node, p.p);
  r.centre    = warped.centre;
  r.radius    = warped.radius;
  return r;
}
template <int N>
inline dual<interval, N> point_coord(const sdf_dual_box_point<N>& p, int axis) {
  return axis == 0 ? p.p.x : axis == 1 ? p.p.y : p.p.z;
}
// The value as for intervals; the gradient of a primitive of Lipschitz
// factor L has components in [-L, L].
template <int N>
inline dual<interval, N> eval_shape(
    const sdf_node& node, const sdf_dual_box_point<N>& q, float step) {
  auto     box = sdf_box_point{q.p.x.v, q.p.y.v, q.p.z.v, q.centre, q.radius};
  auto     lipschitz = primitive_lipschitz(node);
  interval g[3]      = {{-lipschitz, lipschitz}, {-lipschitz, lipschitz},
           {-lipschitz, lipschitz}};
  return chain_shape(eval_shape(node, box, step), g, q.p);
}
template <int N>
inline dual<interval, N> sdf_constant(float value, const dual<interval, N>*) {
  return make_dual_constant<N>(interval{value});
}

// -----------------------------------------------------------------------------
// SMOOTH UNION GROUPS (sdf_program.h): the sdf_smooth_group_size smallest
// operand values, kept sorted as they come, folded from the smallest
// -----------------------------------------------------------------------------

// Put x among the sdf_smooth_group_size smallest values `v[0, count)`,
// kept sorted by their value (floats, or duals by theirs); NaN poisons.
inline float sort_value(float x) { return x; }
template <int N>
inline float sort_value(const dual<float, N>& x) {
  return x.v;
}
template <class S, class V>
inline void insert_smallest(S& s, const V& x) {
  auto key = sort_value(x);
  if (key != key) s.nan = true;
  if (key != key) return;
  auto i = s.count;
  if (i < sdf_smooth_group_size) {
    s.count++;
  } else if (key < sort_value(s.v[i - 1])) {
    i--;
  } else {
    return;
  }
  for (; i > 0 && sort_value(s.v[i - 1]) > key; i--) s.v[i] = s.v[i - 1];
  s.v[i] = x;
}

// The smallest floats so far (sdf_smooth_floats), the places past count
// held at +inf, so that an insertion needs no branch on the values: where
// it lands depends on the data, and insert_smallest's mispredicted
// branches were most of a 10,000-sphere blend's point values. The same
// values in the same places as insert_smallest's (equal values keep their
// order: a later one goes after).
inline void smooth_open(sdf_smooth_floats& s) {
  for (auto& v : s.v) v = flt_inf;
  s.count = 0;
  s.nan   = false;
}
inline void smooth_insert(sdf_smooth_floats& s, float x) {
  if (x != x) s.nan = true;
  if (x != x) return;
  for (auto i = sdf_smooth_group_size - 1; i > 0; i--) {
    auto shifted = s.v[i - 1] > x ? s.v[i - 1] : x;
    s.v[i]       = s.v[i] > x ? shifted : s.v[i];
  }
  s.v[0]  = s.v[0] > x ? x : s.v[0];
  s.count = std::min(s.count + 1, sdf_smooth_group_size);
}
inline float smooth_fold(const sdf_smooth_floats& s, float k) {
  if (s.nan || s.count == 0) return std::numeric_limits<float>::quiet_NaN();
  return smooth_min_sorted(s.v, s.count, std::max(k, 0.0f));
}

// Points: the floats; lanes: one per lane.
inline void smooth_add(sdf_smooth_floats& s, float x, float) {
  smooth_insert(s, x);
}
inline float smooth_close(const sdf_smooth_floats& s, float k) {
  return smooth_fold(s, k);
}
template <int N>
struct sdf_smooth_lanes {
  sdf_smooth_floats lane[N];
};
template <int N>
inline void smooth_open(sdf_smooth_lanes<N>& s) {
  for (auto& lane : s.lane) smooth_open(lane);
}
template <int N>
inline void smooth_add(
    sdf_smooth_lanes<N>& s, const sdf_lanes_of<N>& x, float) {
  for (auto i = 0; i < N; i++) smooth_insert(s.lane[i], x.v[i]);
}
template <int N>
inline sdf_lanes_of<N> smooth_close(const sdf_smooth_lanes<N>& s, float k) {
  auto r = sdf_lanes_of<N>{};
  for (auto i = 0; i < N; i++) r.v[i] = smooth_fold(s.lane[i], k);
  return r;
}

// Intervals: the fold is monotone in each operand (order statistics are,
// and so is the smooth minimum), so it lies between its values at the
// operands' lower and upper ends. Dual intervals add the hull of the
// operands' gradients: the fold's partial derivatives are at least 0 and
// sum to 1 (each smooth minimum's are h/2 and 1 - h/2), so its gradient is a
// convex combination of theirs; an operand whose lower end lies a blend
// above an earlier one's upper end has weight 0 everywhere and is left out.
inline void smooth_open(sdf_smooth_intervals& s) {
  smooth_open(s.lo);
  smooth_open(s.hi);
  s.entire   = false;
  s.least_hi = flt_inf;
  s.d[0] = s.d[1] = s.d[2] = interval{0};  // no operand may matter yet
}
inline void smooth_add(sdf_smooth_intervals& s, interval x, float) {
  if (is_entire(x)) s.entire = true;
  smooth_insert(s.lo, x.lo);
  smooth_insert(s.hi, x.hi);
}
inline interval smooth_close(const sdf_smooth_intervals& s, float k) {
  if (s.entire) return entire_interval;
  return make_interval(smooth_fold(s.lo, k), smooth_fold(s.hi, k));
}
template <int N>
inline void smooth_add(
    sdf_smooth_intervals& s, const dual<interval, N>& x, float k) {
  if (!(x.v.lo >= s.least_hi + std::max(k, 0.0f))) {
    for (auto i = 0; i < N; i++)
      s.d[i] = s.least_hi == flt_inf ? x.d[i] : join_slopes(s.d[i], x.d[i]);
  }
  s.least_hi = std::min(s.least_hi, x.v.hi);
  smooth_add(s, x.v, k);
}
template <int N>
inline dual<interval, N> smooth_close_dual(
    const sdf_smooth_intervals& s, float k) {
  auto value = smooth_close(s, k);
  if (s.entire) return with_unknown_slope<N>(value);
  auto r = dual<interval, N>{value};
  for (auto i = 0; i < N; i++) r.d[i] = s.d[i];
  return r;
}

// Duals at a point: sorted by value, folded with the binary smooth
// minimum's exact weights.
template <int N>
struct sdf_smooth_duals {
  dual<float, N> v[sdf_smooth_group_size];
  int            count;
  bool           nan;
};
template <int N>
inline void smooth_open(sdf_smooth_duals<N>& s) {
  s.count = 0;
  s.nan   = false;
}
template <int N>
inline void smooth_add(sdf_smooth_duals<N>& s, const dual<float, N>& x, float) {
  insert_smallest(s, x);
}
template <int N>
inline dual<float, N> smooth_close(const sdf_smooth_duals<N>& s, float k) {
  if (s.nan || s.count == 0)
    return with_unknown_slope<N>(std::numeric_limits<float>::quiet_NaN());
  auto m = s.v[0];
  for (auto i = 1; i < s.count; i++)
    m = csg_smooth_union(m, s.v[i], std::max(k, 0.0f));
  return m;
}

// -----------------------------------------------------------------------------
// THE LOOP
// -----------------------------------------------------------------------------

// The mapped point of a primitive: all of map_point but for intervals.
template <class P>
inline P map_shape_point(const sdf_tape& pool, int frame, const P& p) {
  return map_point(pool, frame, p);
}

// The point and the group accumulator of each value type.
// The point and the group accumulator of each value type, and how the
// accumulator closes into a value.
template <class T>
struct sdf_value_types;
template <>
struct sdf_value_types<float> {
  using point = vec3f;
  using group = sdf_smooth_floats;
  static float close(const group& s, float k) { return smooth_close(s, k); }
};
template <int N>
struct sdf_value_types<sdf_lanes_of<N>> {
  using point = sdf_lane_points_of<N>;
  using group = sdf_smooth_lanes<N>;
  static sdf_lanes_of<N> close(const group& s, float k) {
    return smooth_close(s, k);
  }
};
template <>
struct sdf_value_types<interval> {
  using point = sdf_box_point;
  using group = sdf_smooth_intervals;
  static interval close(const group& s, float k) { return smooth_close(s, k); }
};
template <int N>
struct sdf_value_types<dual<float, N>> {
  using point = sdf_vec3<dual<float, N>>;
  using group = sdf_smooth_duals<N>;
  static dual<float, N> close(const group& s, float k) {
    return smooth_close(s, k);
  }
};
template <int N>
struct sdf_value_types<dual<interval, N>> {
  using point = sdf_dual_box_point<N>;
  using group = sdf_smooth_intervals;
  static dual<interval, N> close(const group& s, float k) {
    return smooth_close_dual<N>(s, k);
  }
};
template <class T>
using sdf_point = typename sdf_value_types<T>::point;
template <class T>
using sdf_group = typename sdf_value_types<T>::group;

// Where a clause writes: its register, or its own index in an SSA list.
inline int clause_out(const sdf_clause& clause, int) { return clause.out; }
inline int clause_out(const sdf_ssa&, int index) { return index; }

// Run the clauses [begin, end) (register or SSA form) over the nodes and maps
// of `pool`, with the input point `p`: each clause writes values[out] or
// points[out]. `step` is the finite-difference step of primitives without
// an analytic gradient (dual values only).
template <class T, class Clause>
inline void run_sdf_clauses(const sdf_tape& pool, const Clause* begin,
    const Clause* end, T* values, sdf_point<T>* points, sdf_group<T>* groups,
    const sdf_point<T>& p, float step) {
  using point_t = sdf_point<T>;
  // The mapped point of the last primitive: consecutive primitives in one
  // space map it once.
  auto           cached_point = -1, cached_frame = invalidid;
  const point_t* q      = nullptr;
  auto           mapped = point_t{};
  auto           index  = 0;
  for (auto c = begin; c != end; ++c, ++index) {
    auto out = clause_out(*c, index);
    auto k   = sdf_param_float(c->param);
    switch (c->op) {
      case sdf_op::input:
        points[out]  = p;
        cached_point = -1;
        break;
      case sdf_op::map:
        points[out]  = map_point(pool, (int)c->param, points[c->a]);
        cached_point = -1;
        break;
      case sdf_op::twist:
      case sdf_op::bend:
      case sdf_op::repeat:
      case sdf_op::elongate:
      case sdf_op::mirror:
        points[out]  = warp_point(pool.nodes[c->param], points[c->a]);
        cached_point = -1;
        break;
      case sdf_op::shape: {
        auto& node = pool.nodes[c->param];
        if ((int)c->a != cached_point || node.frame != cached_frame) {
          cached_point = (int)c->a;
          cached_frame = node.frame;
          if (node.frame < 0) {
            q = &points[c->a];
          } else {
            mapped = map_shape_point(pool, node.frame, points[c->a]);
            q      = &mapped;
          }
        }
        values[out] = eval_shape(node, *q, step);
        break;
      }
      case sdf_op::scale: values[out] = csg_scale(values[c->a], k); break;
      case sdf_op::csg_union:
        values[out] = csg_union(values[c->a], values[c->b]);
        break;
      case sdf_op::csg_intersection:
        values[out] = csg_intersection(values[c->a], values[c->b]);
        break;
      case sdf_op::csg_subtraction:
        values[out] = csg_subtraction(values[c->a], values[c->b]);
        break;
      case sdf_op::csg_smooth_union:
        values[out] = csg_smooth_union(values[c->a], values[c->b], k);
        break;
      case sdf_op::csg_smooth_intersection:
        values[out] = csg_smooth_intersection(values[c->a], values[c->b], k);
        break;
      case sdf_op::csg_smooth_subtraction:
        values[out] = csg_smooth_subtraction(values[c->a], values[c->b], k);
        break;
      case sdf_op::smooth_open: smooth_open(groups[out]); break;
      case sdf_op::smooth_add:
        if (out != (int)c->a) groups[out] = groups[c->a];
        smooth_add(groups[out], values[c->b], k);
        break;
      case sdf_op::smooth_close:
        values[out] = sdf_value_types<T>::close(groups[c->a], k);
        break;
      case sdf_op::csg_round: values[out] = csg_round(values[c->a], k); break;
      case sdf_op::csg_onion: values[out] = csg_onion(values[c->a], k); break;
      case sdf_op::math_const: values[out] = sdf_constant(k, values); break;
      case sdf_op::math_x: values[out] = point_coord(points[c->a], 0); break;
      case sdf_op::math_y: values[out] = point_coord(points[c->a], 1); break;
      case sdf_op::math_z: values[out] = point_coord(points[c->a], 2); break;
#define IMPLICIT_SDF_RUN_MATH_0(id)
#define IMPLICIT_SDF_RUN_MATH_1(id) \
  case sdf_op::id:                  \
    values[out] = id(values[c->a]); \
    break;
#define IMPLICIT_SDF_RUN_MATH_2(id)               \
  case sdf_op::id:                                \
    values[out] = id(values[c->a], values[c->b]); \
    break;
#define IMPLICIT_SDF_RUN_MATH(id, name, operands) \
  IMPLICIT_SDF_RUN_MATH_##operands(id)
        IMPLICIT_SDF_MATH(IMPLICIT_SDF_RUN_MATH)
#define IMPLICIT_SDF_RUN_IMMEDIATE(id)                       \
  case sdf_op::id##_k:                                       \
    values[out] = id(values[c->a], sdf_constant(k, values)); \
    break;
        IMPLICIT_SDF_IMMEDIATE_OPS(IMPLICIT_SDF_RUN_IMMEDIATE)
#undef IMPLICIT_SDF_RUN_IMMEDIATE
#undef IMPLICIT_SDF_RUN_MATH
#undef IMPLICIT_SDF_RUN_MATH_2
#undef IMPLICIT_SDF_RUN_MATH_1
#undef IMPLICIT_SDF_RUN_MATH_0
    }
  }
}

// Storage for `Count` registers of type T, left uninitialised: a tape's
// clause writes its register before any later clause reads it, and the
// default initialisers of dual numbers and points zeroed 4-7 KiB per
// evaluation (4% of the organic model's render: a normal is one dual
// evaluation of a 100-clause tape).
template <class T, int Count>
struct sdf_scratch {
  alignas(T) unsigned char bytes[sizeof(T) * Count];
  T* data() { return reinterpret_cast<T*>(bytes); }
};

// Value of the register clauses [begin, end) at `p`: the root is the
// register the last clause writes.
template <class T>
inline T run_sdf_tape(const sdf_tape& pool, const sdf_clause* begin,
    const sdf_clause* end, const sdf_point<T>& p, float step = 0) {
  sdf_scratch<T, sdf_max_registers>         values;
  sdf_scratch<sdf_point<T>, sdf_max_points> points;
  sdf_scratch<sdf_group<T>, sdf_max_groups> groups;
  run_sdf_clauses(
      pool, begin, end, values.data(), points.data(), groups.data(), p, step);
  return values.data()[end[-1].out];
}

}  // namespace implicit
