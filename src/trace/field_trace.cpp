// # implicit: tracing functions that are no distance bounds (implementation)

#include "field_trace.h"

#include <algorithm>
#include <cmath>

#include "../sdf/sdf_primitives.h"
#include "segment_trace.h"

namespace implicit {

void init_field_bounds(trace_object& object) {
  auto& tape             = object.field->full;
  auto  box              = expand(object.local_bounds, object.local_padding);
  object.whole_range     = eval_sdf_interval(tape, box);
  object.whole_lipschitz = eval_sdf_lipschitz(tape, box);
}

namespace {

// Fraction of a cell by which locate() looks past a point that lies on the
// cell's exit face (where the last region ended), so that it finds the cell
// the ray enters, not the one it leaves.
inline constexpr float field_probe_fraction = 1e-4f;

// df/dt along a ray of direction d over a leaf: its gradient's hull
// projected on d, within its bound of |gradient| times |d|.
interval leaf_derivative(const sdf_cell& leaf, vec3f d) {
  auto along = interval{0};
  for (auto a = 0; a < 3; a++)
    if (at(d, a) != 0) along = along + mul_point(leaf.gradient[a], at(d, a));
  auto slope = leaf.lipschitz * length(d);
  auto lo = std::max(along.lo, -slope), hi = std::min(along.hi, slope);
  return lo <= hi ? interval{lo, hi} : along;  // empty: roundings apart
}

// The object's field along one ray, as segment_trace() wants it (see the
// adaptor's members there). Regions are leaf cells (or invalidid: the whole
// tape); the last located leaf's box clips the pieces bound() is asked for.
struct field_ray {
  const sdf_field* field = nullptr;
  ray3f            ray   = {};
  segment_region   whole = {};  // the whole tape over the object's stretch
  // The last located leaf (cursor.cell, its cell, its box, the path to it),
  // kept: a march asks for it at every step.
  mutable sdf_field_cursor cursor = {};
  // Where the ray leaves that leaf: the ray parameter, the axis of the face
  // and the face's plane (the next find puts the point on it).
  mutable float exit_t = flt_nan, exit_plane = 0;
  mutable int   exit_axis = 0;

  // The only reads of the octree's cells.
  const sdf_cell& leaf(int region) const {
    if (region == cursor.cell && cursor.leaf) return *cursor.leaf;
    return get_sdf_cell(*field, region);
  }
  const sdf_clause* begin(int region) const {
    if (region < 0) return field->full.clauses.data();
    return leaf(region).clauses;
  }
  const sdf_clause* end(int region) const {
    if (region < 0) return begin(region) + field->full.clauses.size();
    return begin(region) + leaf(region).count;
  }
  bool is_constant(int region) const {
    return region >= 0 && leaf(region).count == 0;
  }

  // The leaf at the ray point t (its box in cursor.box) and where the ray
  // leaves that box.
  int find(float t, float& exit) const {
    // At the exit of the last leaf, the point is put on the face it left
    // by, which find_sdf_cell places in the leaf the ray enters: the ray
    // point itself may round to either side.
    auto p = ray_point(ray, t);
    if (t == exit_t) at(p, exit_axis) = exit_plane;
    auto  index = find_sdf_cell(*field, p, cursor, ray.d);
    auto& box   = cursor.box;
    exit        = flt_max;
    for (auto a = 0; a < 3; a++) {
      auto d = at(ray.d, a);
      if (d == 0) continue;
      auto plane = d > 0 ? at(box.max, a) : at(box.min, a);
      auto t_a   = (plane - at(ray.o, a)) / d;
      if (t_a < exit) {
        exit       = t_a;
        exit_axis  = a;
        exit_plane = plane;
      }
    }
    exit_t = exit;
    return index;
  }

  segment_region locate(float t) const {
    if (!field->octree) return whole;
    auto exit  = 0.0f;
    auto index = find(t, exit);
    if (index >= 0 && !(exit > t)) {
      auto probe = max(size(cursor.box)) * field_probe_fraction / length(ray.d);
      index      = find(t + probe, exit);
    }
    if (index < 0) return whole;
    auto& located = *cursor.leaf;
    auto  range   = located.range;
    // A leaf on one side of the surface is crossed without its slope.
    auto derivative = segment_one_side(range) ? entire_interval
                                              : leaf_derivative(located, ray.d);
    return {index, std::min(exit, whole.t_exit), range, derivative, false};
  }

  float value(int region, float t) const {
    auto cell = region < 0 ? nullptr : &leaf(region);
    return eval_sdf_leaf(*field, cell, ray_point(ray, t));
  }

  // The same values as value(), in one pass of the leaf's tape.
  void values(int region, const float* t, float* f, int count) const {
    if (is_constant(region)) {
      std::fill(f, f + count, leaf(region).bound);
      return;
    }
    vec3f points[segment_batch_size];
    for (auto k = 0; k < count; k++) points[k] = ray_point(ray, t[k]);
    eval_sdf(field->full, begin(region), end(region), points, f, count);
  }

  vec2f value_slope(int region, float t) const {
    if (is_constant(region)) return {leaf(region).bound, 0};
    auto f = eval_sdf_slope(
        field->full, begin(region), end(region), ray_point(ray, t), ray.d);
    return {f.v, f.d[0]};
  }

  float split(int region, float t0, float t1) const {
    if (is_constant(region)) return flt_nan;
    auto u = find_sdf_jump(field->full, begin(region), end(region),
        ray_point(ray, t0), ray_point(ray, t1));
    return t0 + (t1 - t0) * u;  // NaN stays NaN
  }

  segment_bound bound(int region, float t0, float t1) const {
    if (is_constant(region)) return {leaf(region).range, interval{0}};
    auto a = ray_point(ray, t0), b = ray_point(ray, t1);
    auto piece = bbox3f{min(a, b), max(a, b)};
    // A simplified tape holds inside its cell only: keep the piece there
    // (it leaves it by rounding only).
    if (region >= 0 && region == cursor.cell) {
      auto inside = intersect(piece, cursor.box);
      if (!is_empty(inside)) piece = inside;
    }
    // df/dt over the piece, by forward-mode derivatives along the ray.
    auto f =
        eval_sdf_slope(field->full, begin(region), end(region), piece, ray.d);
    return {f.v, f.d[0]};
  }
};

}  // namespace

march_result trace_field(const trace_object& object, const march_params& params,
    const ray3f& local, float t0, float t1, float cutoff, float hit_min) {
  auto& field    = *object.field;
  auto  function = field_ray{};
  function.field = &field;
  function.ray   = local;
  auto slope     = object.whole_lipschitz * length(local.d);
  function.whole = {invalidid, t1, object.whole_range, {-slope, slope}};
  return segment_trace(function, t0, t1, cutoff, params, hit_min);
}

vec3f eval_field_gradient(const sdf_field& field, vec3f p, float step) {
  auto cursor = sdf_field_cursor{};
  auto f      = dual<float>{};
  if (find_sdf_cell(field, p, cursor) >= 0 && cursor.leaf->count > 0) {
    auto& leaf = *cursor.leaf;
    f = eval_sdf_dual(field.full, leaf.clauses, leaf.clauses + leaf.count, p);
  } else {
    f = eval_sdf_dual(field.full, p);
  }
  auto g = gradient(f);
  auto l = length(g);
  if (l > 0 && std::isfinite(l)) return g / l;
  g = tetrahedral_gradient(
      [&](vec3f q) { return eval_sdf(field, q, cursor); }, p, step);
  l = length(g);
  return l > 0 && std::isfinite(l) ? g / l : vec3f{0, 0, 1};
}

}  // namespace implicit
