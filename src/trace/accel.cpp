// # implicit: ray-scene intersection (implementation)

#include "accel.h"

#include <cstring>

#include "../sdf/sdf_primitives.h"
#include "../sdf/sdf_zero_bounds.h"
#include "../util/error.h"
#include "accel_embree.h"
#include "field_trace.h"
#include "sphere_trace.h"

namespace implicit {

// -----------------------------------------------------------------------------
// OBJECTS
// -----------------------------------------------------------------------------

// Fill the maps and bounds shared by every kind of object.
static void finish_object(trace_object& object) {
  object.world_from_local = inverse(object.local_from_world);
  auto stretch            = max_stretch(object.local_from_world);
  object.distance_scale   = stretch > 0 ? 1 / stretch : 0;
  object.world_bounds =
      transform_bbox(object.world_from_local, object.local_bounds);
}

// Box of an object's field: its local box with room for the box padding and
// the rounding of points on it (points outside use the whole program).
static bbox3f field_box(const trace_object& object) {
  auto& box = object.local_bounds;
  if (is_empty(box) || !is_finite(box)) return {};
  return expand(box, 2 * object.local_padding + 1e-3f * length(size(box)));
}

// Padding of object boxes against rounding, so that surfaces lying on a box
// face (boxes, thin boxes) are never clipped: a fraction of the scene size
// (the default march_params::scene_epsilon) plus a floor.
inline constexpr float box_padding_relative = 1e-6f;
inline constexpr float box_padding_min      = 1e-8f;

// One object per part of each function (the parts of a top-level union
// when type is bvh); their programs go to `programs`, in the same order.
static void add_function_objects(const scene_data& scene, accel_type type,
    accel_data& accel, std::vector<sdf_program>& programs) {
  for (auto i = 0; i < (int)scene.sdfunctions.size(); i++) {
    auto& function = scene.sdfunctions[i];
    auto  parts    = type == accel_type::bvh
                         ? split_sdf_union(function.program)
                         : std::vector<sdf_program>{function.program};
    for (auto& part : parts) {
      auto object             = trace_object{};
      object.kind             = object_kind::function;
      object.index            = i;
      object.material         = function.material;
      object.local_from_world = function.local_from_world;
      // Functions that are no distance bound without a box of their own
      // get the box of their zero set; an unbounded one cannot be traced.
      auto unbounded      = false;
      object.local_bounds = sdf_surface_bounds(part, unbounded);
      if (unbounded)
        throw io_error("sdfunctions[" + std::to_string(i) + "] (\"" +
                       function.name + "\"): " + unbounded_surface_message);
      object.exact  = has_exact_intersection(part);
      object.single = part.nodes.size() == 1;
      if (object.single) object.shape = part.nodes[0];
      finish_object(object);
      // Lipschitz bounds above 1 shrink the safe step; without one, the
      // object is traced by segments (field_trace.h).
      auto lipschitz  = sdf_lipschitz(part);
      object.segments = !std::isfinite(lipschitz);
      if (!object.segments) object.distance_scale /= std::max(1.0f, lipschitz);
      accel.objects.push_back(object);
      programs.push_back(std::move(part));
    }
  }
}

// One object per grid instance and per user SDF.
static void add_grid_and_user_objects(
    const scene_data& scene, accel_data& accel) {
  for (auto i = 0; i < (int)scene.vol_instances.size(); i++) {
    auto& instance  = scene.vol_instances[i];
    auto  object    = trace_object{};
    object.kind     = object_kind::grid;
    object.index    = i;
    object.material = instance.material;
    object.grid     = scene.volumes.at(instance.volume).grid;
    // A scene parsed without its files has no grids: an empty one is never
    // hit, as before.
    if (!object.grid) object.grid = std::make_shared<const grid_data>();
    // Grid space = instance space divided by the scale, less the file's
    // placement (a .vdb's own transform; the seed's formats have none).
    auto placement          = grid_placement(*object.grid);
    auto unscale            = frame3f{{1 / instance.scale, 0, 0},
        {0, 1 / instance.scale, 0}, {0, 0, 1 / instance.scale}, -placement};
    object.local_from_world = unscale * instance.local_from_world;
    object.local_bounds     = grid_solid_bounds(*object.grid);
    object.exact            = true;
    finish_object(object);
    accel.objects.push_back(object);
  }
  for (auto i = 0; i < (int)scene.user_sdfs.size(); i++) {
    auto& user              = scene.user_sdfs[i];
    auto  object            = trace_object{};
    object.kind             = object_kind::user;
    object.index            = i;
    object.material         = user.material;
    object.user             = std::make_shared<const user_sdf_data>(user);
    object.local_from_world = user.local_from_world;
    object.local_bounds     = user.bounds;
    finish_object(object);
    object.distance_scale /= std::max(1.0f, user.lipschitz);
    accel.objects.push_back(object);
  }
}

// Scene size from the finite extents (planes are infinite along two axes),
// the box padding, and each object's padding in local units (the world
// padding times the largest stretch of local_from_world).
static void set_scene_size(accel_data& accel) {
  for (auto& object : accel.objects) {
    accel.extent = merge(accel.extent, object.world_bounds);
    auto box     = object.world_bounds;
    for (auto a = 0; a < 3; a++) {
      if (!std::isfinite(at(box.min, a))) at(box.min, a) = 0;
      if (!std::isfinite(at(box.max, a))) at(box.max, a) = 0;
    }
    accel.bounds = merge(accel.bounds, box);
  }
  accel.size =
      is_empty(accel.bounds) ? 1 : std::max(length(size(accel.bounds)), 1e-6f);
  accel.padding = box_padding_relative * accel.size + box_padding_min;
  for (auto& object : accel.objects)
    object.local_padding = accel.padding * max_stretch(object.local_from_world);
}

// Objects with finite boxes go into the BVH's list (`bounded`, with their
// padded boxes by axis), the others beside it; empty boxes (an
// intersection of disjoint shapes) can never be hit.
static void sort_objects_by_bounds(accel_data& accel) {
  for (auto i = 0; i < (int)accel.objects.size(); i++) {
    auto& box = accel.objects[i].world_bounds;
    if (is_empty(box) || box.min.y > box.max.y || box.min.z > box.max.z)
      continue;
    if (is_finite(box)) {
      accel.bounded.push_back(i);
    } else {
      accel.unbounded.push_back(i);
    }
  }
  // Boxes padded in count to a multiple of 4 (whatever the padding holds
  // is never read as an object: callers look at the first bounded.size()
  // entries).
  auto lanes = (accel.bounded.size() + 3) / 4 * 4;
  for (auto a = 0; a < 3; a++) {
    accel.bounded_min[a].assign(lanes, 0.0f);
    accel.bounded_max[a].assign(lanes, 0.0f);
  }
  for (size_t k = 0; k < accel.bounded.size(); k++) {
    auto box =
        expand(accel.objects[accel.bounded[k]].world_bounds, accel.padding);
    for (auto a = 0; a < 3; a++) {
      accel.bounded_min[a][k] = at(box.min, a);
      accel.bounded_max[a][k] = at(box.max, a);
    }
  }
}

// The tree of the bounded objects' padded local boxes, mapped to world
// space, for the camera's first pass (camera_blocks.h).
static box_tree make_block_tree(const accel_data& accel) {
  auto boxes = std::vector<bbox3f>{};
  for (auto i : accel.bounded) {
    auto& object = accel.objects[i];
    boxes.push_back(transform_bbox(object.world_from_local,
        expand(object.local_bounds, object.local_padding)));
  }
  return make_box_tree(boxes);
}

accel_data make_accel(
    const scene_data& scene, accel_type type, const accel_params& params) {
  if (params.linear_max < 0 || params.linear_max > linear_max_objects)
    throw io_error(
        "accel parameter linear_max: " + std::to_string(params.linear_max) +
        " is out of range [0, " + std::to_string(linear_max_objects) + "]");
  auto accel = accel_data{};
  accel.type = type;
  // Programs of the function objects, made into fields once the padding is
  // known.
  auto programs = std::vector<sdf_program>{};
  add_function_objects(scene, type, accel, programs);
  add_grid_and_user_objects(scene, accel);
  set_scene_size(accel);
  // Fields: pruned over the object's box (bvh), or the whole tree (none).
  for (auto k = 0; k < (int)programs.size(); k++) {
    auto& object    = accel.objects[k];
    auto  box       = type == accel_type::bvh ? field_box(object) : bbox3f{};
    auto  field     = sdf_field_params{};
    field.max_bytes = params.prune_bytes;
    object.field    = std::make_shared<const sdf_field>(
        make_sdf_field(programs[k], box, field));
    if (object.segments) init_field_bounds(object);
  }
  for (auto i = 0; i < (int)accel.objects.size(); i++)
    if (accel.objects[i].segments) accel.segmented.push_back(i);
  sort_objects_by_bounds(accel);
  if (type == accel_type::bvh && (int)accel.bounded.size() > params.linear_max)
    accel.bvh = make_embree_bvh(accel);
  if (type == accel_type::bvh) accel.block_tree = make_block_tree(accel);
  return accel;
}

// -----------------------------------------------------------------------------
// EVALUATION
// -----------------------------------------------------------------------------

// Distance in the object's own space.
static float eval_local(const trace_object& object, vec3f p) {
  switch (object.kind) {
    case object_kind::function: return eval_sdf(*object.field, p);
    case object_kind::grid: return eval_grid(*object.grid, p);
    case object_kind::user: return object.user->eval(p);
  }
  return flt_max;
}

float eval_object_distance(const trace_object& object, vec3f p_world) {
  return eval_local(object, transform_point(object.local_from_world, p_world)) *
         object.distance_scale;
}

vec3f eval_object_normal(
    const trace_object& object, vec3f p_world, float step) {
  auto p     = transform_point(object.local_from_world, p_world);
  auto local = vec3f{};
  // Finite-difference step in local units.
  auto h = step / std::max(object.distance_scale, 1e-20f);
  switch (object.kind) {
    case object_kind::function:
      local = object.segments ? eval_field_gradient(*object.field, p, h)
                              : eval_sdf_gradient(*object.field, p, h);
      break;
    case object_kind::grid: local = eval_grid_gradient(*object.grid, p); break;
    case object_kind::user:
      local = tetrahedral_gradient(object.user->eval, p, h);
      break;
  }
  // Gradients are covectors: world = transpose(local_from_world) * local.
  return normalize(transpose(rotation(object.local_from_world)) * local);
}

// -----------------------------------------------------------------------------
// INTERSECTION
// -----------------------------------------------------------------------------

// March a ray in an object's space with the local distance `eval`, chosen
// once per ray so that the loop inlines it.
template <typename Eval>
static march_result march_local(const accel_data& accel,
    const march_params& params, const Eval& eval, const ray3f& local,
    float scale, float t0, float t1, float cutoff) {
  auto distance = [&](float t) { return eval(ray_point(local, t)) * scale; };
  return sphere_trace(
      distance, t0, t1, cutoff, params, min_hit_epsilon(accel, params));
}

// March one object: single primitives get their own loop (no switch per
// step), CSG programs, grids and user functions the general evaluation.
static march_result march_object(const accel_data& accel,
    const march_params& params, const trace_object& object, const ray3f& local,
    float t0, float t1, float cutoff) {
  auto scale = object.distance_scale;
  auto march = [&](const auto& eval) {
    return march_local(accel, params, eval, local, scale, t0, t1, cutoff);
  };
  switch (object.kind) {
    case object_kind::function: {
      if (object.single) {
        // One loop per primitive, its node's fields captured by value. Box,
        // sphere, plane and capped cone are solved in closed form before
        // this.
        auto node = object.shape;
#define IMPLICIT_SDF_MARCH(id, name) \
  case sdf_type::id:                 \
    return march([node](vec3f p) { return eval_##id(node, p); });
        switch (node.type) {
          IMPLICIT_SDF_PRIMITIVES(IMPLICIT_SDF_MARCH)
          IMPLICIT_SDF_OPERATOR_CASES break;
        }
#undef IMPLICIT_SDF_MARCH
      }
      auto& field = *object.field;
      if (!field.octree) {
        auto& tape = field.full;
        return march([&](vec3f p) { return eval_sdf(tape, p); });
      }
      auto cursor = sdf_field_cursor{};
      return march([&](vec3f p) { return eval_sdf(field, p, cursor); });
    }
    case object_kind::grid: {
      auto& grid = *object.grid;
      return march([&](vec3f p) { return eval_grid(grid, p); });
    }
    case object_kind::user: {
      auto& eval = object.user->eval;
      return march([&](vec3f p) { return eval(p); });
    }
  }
  return {};
}

scene_intersection intersect_object(const accel_data& accel,
    const march_params& march, int index, const ray3f& ray, float cutoff) {
  auto& object = accel.objects[index];
  auto  isec   = scene_intersection{};
  // In the object's space t keeps its meaning (the direction is not
  // renormalized), and its own box is tighter than the world box.
  auto local = transform_ray(object.local_from_world, ray);
  if (object.exact && object.kind == object_kind::function) {
    auto hit = false;
    auto t   = 0.0f;
    intersect_sdf_exact(object.shape, local, hit, t);
    isec.evaluations = 1;
    if (hit) {
      isec.hit      = true;
      isec.object   = index;
      isec.distance = t;
      isec.epsilon  = hit_epsilon(accel, march, t);
    }
    return isec;
  }
  auto t0 = 0.0f, t1 = 0.0f;
  auto box = expand(object.local_bounds, object.local_padding);
  if (!intersect_bbox(local, box, t0, t1) || t0 > cutoff) return isec;
  if (object.exact) {
    local.tmin = t0;
    local.tmax = t1;
    auto t     = 0.0f;
    if (intersect_grid(*object.grid, local, t, isec.evaluations)) {
      isec.hit      = true;
      isec.object   = index;
      isec.distance = t;
      isec.epsilon  = hit_epsilon(accel, march, t);
    }
    return isec;
  }
  auto result      = object.segments
                         ? trace_field(object, march, local, t0, t1, cutoff,
                               min_hit_epsilon(accel, march))
                         : march_object(accel, march, object, local, t0, t1, cutoff);
  isec.evaluations = result.evaluations;
  if (result.hit) {
    isec.hit      = true;
    isec.object   = index;
    isec.distance = result.distance;
    isec.epsilon  = result.epsilon;
  }
  return isec;
}

// Whether `isec` replaces `best`: closer, or as close with a lower index.
static bool is_closer(
    const scene_intersection& isec, const scene_intersection& best) {
  if (!isec.hit) return false;
  if (!best.hit) return true;
  return isec.distance < best.distance ||
         (isec.distance == best.distance && isec.object < best.object);
}

// The seed's loop: the minimum of all objects' distances at every step
// (objects traced by segments have no distance: intersect_reference()).
static scene_intersection intersect_reference_march(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  if (accel.segmented.size() == accel.objects.size()) return {};
  auto closest  = invalidid;
  auto distance = [&](float t) {
    auto p    = ray_point(ray, t);
    auto best = flt_max;
    for (auto i = 0; i < (int)accel.objects.size(); i++) {
      if (accel.objects[i].segments) continue;
      auto d = eval_object_distance(accel.objects[i], p);
      if (d < best) {
        best    = d;
        closest = i;
      }
    }
    return best;
  };
  // Stop where the ray leaves every object's box (the seed marched on to
  // the iteration cap).
  auto t0 = 0.0f, t1 = 0.0f;
  auto hit_min = min_hit_epsilon(accel, march);
  if (!intersect_bbox(ray, expand(accel.extent, hit_min), t0, t1)) return {};
  // The reference keeps Keinert's fixed over-relaxation.
  auto params   = march;
  params.planar = 0;
  auto result = sphere_trace(distance, ray.tmin, t1, flt_max, params, hit_min);
  auto isec   = scene_intersection{};
  isec.evaluations =
      result.evaluations * (int)(accel.objects.size() - accel.segmented.size());
  if (result.hit) {
    distance(result.distance);  // sets `closest` at the hit point
    isec.hit      = true;
    isec.object   = closest;
    isec.distance = result.distance;
    isec.epsilon  = result.epsilon;
  }
  return isec;
}

// The reference: the seed's loop over the distance objects, and each object
// that is no distance bound traced alone with its whole tape.
static scene_intersection intersect_reference(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  auto best = intersect_reference_march(accel, march, ray);
  for (auto index : accel.segmented) {
    auto isec = intersect_object(accel, march, index, ray, best.distance);
    isec.evaluations += best.evaluations;
    if (is_closer(isec, best)) {
      best = isec;
    } else {
      best.evaluations = isec.evaluations;
    }
  }
  return best;
}

// Whether the bounded objects go through the BVH (else a loop).
static bool uses_bvh(const accel_data& accel) { return accel.bvh.scene; }

// Four floats as one value (GCC/Clang vector extension): arithmetic and
// comparisons act per lane, and `c ? x : y` selects per lane.
using float4 = float __attribute__((vector_size(16)));

static float4 load4(const float* values) {
  auto v = float4{};
  std::memcpy(&v, values, sizeof(v));
  return v;
}

// Entry distance of the ray into each bounded box, or +inf where it misses
// the box within [tmin, tmax], four boxes at a time: `entries` gets the
// count rounded up to 4 (at most linear_max_objects, a multiple of 4).
// NaN-safe like intersect_bbox(): a ray lying in a slab's plane keeps its
// interval (a NaN slab time loses every comparison).
static void enter_boxes(
    const accel_data& accel, const ray3f& ray, float entries[]) {
  auto inverse = vec3f{1 / ray.d.x, 1 / ray.d.y, 1 / ray.d.z};
  auto count   = (int)accel.bounded.size();
  for (auto k = 0; k < count; k += 4) {
    auto t0 = float4{} + ray.tmin, t1 = float4{} + ray.tmax;
    for (auto a = 0; a < 3; a++) {
      auto o = at(ray.o, a), inv = at(inverse, a);
      auto ta = (load4(accel.bounded_min[a].data() + k) - o) * inv;
      auto tb = (load4(accel.bounded_max[a].data() + k) - o) * inv;
      // The x86 minps/maxps forms: `tb < ta ? tb : ta` keeps ta when either
      // is NaN, as intersect_bbox()'s swap does.
      auto near = tb < ta ? tb : ta, far = ta > tb ? ta : tb;
      t0 = near > t0 ? near : t0;
      t1 = far < t1 ? far : t1;
    }
    auto entry = t0 <= t1 ? t0 : float4{} + flt_inf;
    std::memcpy(entries + k, &entry, sizeof(entry));
  }
}

// Few bounded objects: test their boxes in a loop and visit the crossed ones
// nearest first, which is what the BVH does, without its per-ray cost. The
// result is the same: each object's march ignores the visiting order.
static scene_intersection intersect_linear(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  float boxes[linear_max_objects];
  enter_boxes(accel, ray, boxes);
  float entries[linear_max_objects];
  int   indices[linear_max_objects];
  auto  count = 0;
  for (auto k = 0; k < (int)accel.bounded.size(); k++) {
    auto t0 = boxes[k];
    if (t0 == flt_inf) continue;
    // Insertion sort by entry distance.
    auto slot = count++;
    for (; slot > 0 && entries[slot - 1] > t0; slot--) {
      entries[slot] = entries[slot - 1];
      indices[slot] = indices[slot - 1];
    }
    entries[slot] = t0;
    indices[slot] = accel.bounded[k];
  }
  auto best        = scene_intersection{};
  auto evaluations = 0;
  for (auto k = 0; k < count && entries[k] <= best.distance; k++) {
    auto isec = intersect_object(accel, march, indices[k], ray, best.distance);
    evaluations += isec.evaluations;
    if (is_closer(isec, best)) best = isec;
  }
  best.evaluations = evaluations;
  return best;
}

// Whether any of few bounded objects is hit.
static bool intersect_linear_any(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  float entries[linear_max_objects];
  enter_boxes(accel, ray, entries);
  for (auto k = 0; k < (int)accel.bounded.size(); k++) {
    if (entries[k] == flt_inf) continue;
    if (intersect_object(accel, march, accel.bounded[k], ray, ray.tmax).hit)
      return true;
  }
  return false;
}

scene_intersection intersect_scene(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  if (accel.type == accel_type::none)
    return intersect_reference(accel, march, ray);
  auto best = uses_bvh(accel) ? intersect_embree(accel, march, ray)
                              : intersect_linear(accel, march, ray);
  for (auto index : accel.unbounded) {
    auto isec = intersect_object(accel, march, index, ray, best.distance);
    best.evaluations += isec.evaluations;
    if (is_closer(isec, best)) {
      isec.evaluations = best.evaluations;
      best             = isec;
    }
  }
  return best;
}

bool intersect_scene_any(
    const accel_data& accel, const march_params& march, const ray3f& ray) {
  if (accel.type == accel_type::none)
    return intersect_reference(accel, march, ray).hit;
  for (auto index : accel.unbounded)
    if (intersect_object(accel, march, index, ray, ray.tmax).hit) return true;
  return uses_bvh(accel) ? intersect_embree_any(accel, march, ray)
                         : intersect_linear_any(accel, march, ray);
}

}  // namespace implicit
