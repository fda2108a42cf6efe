// # implicit: where a block of camera rays may first meet a surface
// (implementation)

#include "camera_blocks.h"

#include <algorithm>
#include <cmath>

namespace implicit {

// The block's rays in an object's space: their origin, the planes through
// it that bound their cone (inward normals: four sides, and the plane
// facing the cone's middle direction, which keeps boxes behind the camera
// out), and a bound of how much the map to that space stretches lengths
// (t keeps world units).
struct block_cone {
  vec3f origin     = {};
  vec3f normals[5] = {};
  float stretch    = 1;
};

// The cone of the directions through the four corners (in order around the
// block) from `origin`, mapped by `local_from_world`.
static block_cone make_block_cone(
    const frame3f& local_from_world, vec3f origin, const vec3f (&corners)[4]) {
  auto cone   = block_cone{};
  cone.origin = transform_point(local_from_world, origin);
  vec3f local[4];
  auto  middle = vec3f{0, 0, 0};
  for (auto k = 0; k < 4; k++) {
    local[k] = transform_vector(local_from_world, corners[k]);
    middle += local[k];
  }
  for (auto k = 0; k < 4; k++) {
    auto n          = cross(local[k], local[(k + 1) % 4]);
    cone.normals[k] = dot(n, middle) < 0 ? -n : n;
  }
  cone.normals[4] = middle;
  // Largest singular value, from above: Gershgorin's bound of the largest
  // eigenvalue of M^T M (exact for rotations and axis-aligned scales).
  auto m = rotation(local_from_world);
  auto a = mat3f{transpose(m) * m.x, transpose(m) * m.y, transpose(m) * m.z};
  auto row_max = 0.0f;
  for (auto i = 0; i < 3; i++)
    row_max = std::max(row_max,
        std::abs(at(a.x, i)) + std::abs(at(a.y, i)) + std::abs(at(a.z, i)));
  cone.stretch = std::sqrt(row_max);
  return cone;
}

// Whether a box may meet the cone: no plane has all of it outside (a box
// with infinite sides always may).
static bool may_meet(const block_cone& cone, const bbox3f& box) {
  for (auto& n : cone.normals) {
    auto far = vec3f{n.x >= 0 ? box.max.x : box.min.x,
        n.y >= 0 ? box.max.y : box.min.y, n.z >= 0 ? box.max.z : box.min.z};
    if (dot(n, far - cone.origin) < 0) return false;
  }
  return true;
}

// Least t at which a ray of the cone may reach a point of the box.
static float box_start(const block_cone& cone, const bbox3f& box) {
  auto nearest = min(max(cone.origin, box.min), box.max);
  return distance(cone.origin, nearest) / cone.stretch;
}

// Whether a cell's values let a march stop in it: one that stops where
// |f| < epsilon (sphere tracing) may stop where f < epsilon; a change of
// side (segment tracing, epsilon 0) needs a value <= 0; NaN may do either.
static bool may_stop(const interval& range, float epsilon) {
  return !(range.lo > epsilon);
}

// Least start over the cells of an object's octree that meet the cone and
// may hold a hit, nearest cells first, with an explicit stack; `best` is
// the least start found so far (of this and earlier objects).
static float field_start(
    const sdf_field& field, const block_cone& cone, float epsilon, float best) {
  struct entry {
    int    cell = 0;
    bbox3f box  = {};
    float  t    = 0;
  };
  constexpr auto max_stack = 8 * 32;
  entry          stack[max_stack];
  auto           count = 0;
  stack[count++]       = {0, field.box, box_start(cone, field.box)};
  while (count > 0) {
    auto top = stack[--count];
    if (top.t >= best || !may_meet(cone, top.box)) continue;
    auto& cell = get_sdf_cell(field, top.cell);
    if (!may_stop(cell.range, epsilon)) continue;
    if (cell.children < 0 || count + 8 > max_stack) {
      best = top.t;  // a leaf (or no room to look closer)
      continue;
    }
    entry children[8];
    for (auto k = 0; k < 8; k++) {
      auto box    = sdf_octant_box(top.box, k);
      children[k] = {cell.children + k, box, box_start(cone, box)};
    }
    std::sort(children, children + 8,
        [](const entry& a, const entry& b) { return a.t > b.t; });
    for (auto& child : children)
      if (child.t < best) stack[count++] = child;
  }
  return best;
}

// An object's least start, or `best` if it has none smaller.
static float object_start(const accel_data& accel, const march_params& march,
    const trace_object& object, vec3f origin, const vec3f (&corners)[4],
    float best) {
  auto cone  = make_block_cone(object.local_from_world, origin, corners);
  auto box   = expand(object.local_bounds, object.local_padding);
  auto field = object.field.get();
  if (is_empty(box) || !may_meet(cone, box)) return best;
  if (!field || !field->octree || object.exact ||
      !(inside(field->box, box.min) && inside(field->box, box.max)) ||
      !(object.distance_scale > 0))
    return std::min(best, box_start(cone, box));
  // A distance field's march stops where its value (times the object's
  // distance scale) is below the hit threshold, at most that of the far
  // side of the object's box; a function's march at a change of side.
  auto epsilon = 0.0f;
  if (!object.segments) {
    auto far = distance(origin, center(object.world_bounds)) +
               length(size(object.world_bounds));
    epsilon = 2 * hit_epsilon(accel, march, far) / object.distance_scale;
  }
  return field_start(*field, cone, epsilon, best);
}

// The least start of the bounded objects, or `best` if none has a smaller
// one: the nodes of accel.block_tree that meet the cone (in world space),
// nearest first, with an explicit stack; a node no nearer than `best` holds
// no object that could start before it.
static float tree_start(const accel_data& accel, const march_params& march,
    vec3f origin, const vec3f (&corners)[4], float best) {
  auto& tree = accel.block_tree;
  if (tree.nodes.empty()) return best;
  auto cone = make_block_cone(identity_frame, origin, corners);
  // A path to a leaf leaves at most one sibling per level on the stack; the
  // median splits make a tree of 2^31 items fewer than 32 levels deep.
  constexpr auto max_stack = 64;
  int            stack[max_stack];
  auto           count = 0;
  stack[count++]       = 0;
  while (count > 0) {
    auto& node = tree.nodes[stack[--count]];
    if (!may_meet(cone, node.box) || box_start(cone, node.box) >= best)
      continue;
    if (node.count > 0) {
      for (auto k = node.index; k < node.index + node.count; k++)
        best = object_start(accel, march,
            accel.objects[accel.bounded[tree.items[k]]], origin, corners, best);
      continue;
    }
    auto near = node.index, far = node.index + 1;
    if (box_start(cone, tree.nodes[far].box) <
        box_start(cone, tree.nodes[near].box))
      std::swap(near, far);
    stack[count++] = far;
    stack[count++] = near;
  }
  return best;
}

float camera_block_start(const accel_data& accel, const march_params& march,
    const camera_data& camera, vec2i size, vec2i lo, vec2i hi, bool tent) {
  if (accel.type != accel_type::bvh || camera.orthographic ||
      camera.aperture != 0)
    return 0;
  // The samples' reach, a quarter pixel wider against rounding.
  auto  reach = (tent ? 0.5f : 0.0f) + 0.25f;
  auto  u0 = (lo.x - reach) / size.x, u1 = (hi.x + reach) / size.x;
  auto  v0 = (lo.y - reach) / size.y, v1 = (hi.y + reach) / size.y;
  vec2f uvs[4] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
  vec3f corners[4];
  auto  origin = vec3f{};
  for (auto k = 0; k < 4; k++) {
    auto ray   = eval_camera(camera, uvs[k], {0, 0});
    corners[k] = ray.d;
    origin     = ray.o;
  }
  auto best = flt_max;
  for (auto i : accel.unbounded)
    best = object_start(accel, march, accel.objects[i], origin, corners, best);
  best = tree_start(accel, march, origin, corners, best);
  if (best == flt_max) return flt_max;
  // Rounding of the distances: start a little before.
  return std::max(0.0f, best * (1 - 1e-3f) - 2 * min_hit_epsilon(accel, march));
}

}  // namespace implicit
