// # implicit: ray-scene intersection (implementation)

#include "accel.h"

#include "../util/error.h"
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
  object.world_bounds = transform_bbox(object.world_from_local, object.local_bounds);
}

accel_data make_accel(
    const scene_data& scene, accel_type type, const march_params& march) {
  auto accel  = accel_data{};
  accel.type  = type;
  accel.march = march;
  for (auto i = 0; i < (int)scene.sdfunctions.size(); i++) {
    auto& function          = scene.sdfunctions[i];
    auto  object            = trace_object{};
    object.kind             = object_kind::function;
    object.index            = i;
    object.material         = function.material;
    object.program          = &function.program;
    object.local_from_world = function.local_from_world;
    object.local_bounds     = sdf_bounds(function.program);
    object.exact            = has_exact_intersection(function.program);
    finish_object(object);
    // Lipschitz bounds above 1 shrink the safe step.
    object.distance_scale /= std::max(1.0f, sdf_lipschitz(function.program));
    accel.objects.push_back(object);
  }
  for (auto i = 0; i < (int)scene.vol_instances.size(); i++) {
    auto& instance  = scene.vol_instances[i];
    auto  object    = trace_object{};
    object.kind     = object_kind::grid;
    object.index    = i;
    object.material = instance.material;
    object.grid     = &scene.volumes.at(instance.volume).grid;
    // Grid space = instance space divided by the scale.
    auto unscale = frame3f{{1 / instance.scale, 0, 0}, {0, 1 / instance.scale, 0},
        {0, 0, 1 / instance.scale}, {0, 0, 0}};
    object.local_from_world = unscale * instance.local_from_world;
    object.local_bounds     = grid_bounds(*object.grid);
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
    object.user             = &user;
    object.local_from_world = user.local_from_world;
    object.local_bounds     = user.bounds;
    finish_object(object);
    object.distance_scale /= std::max(1.0f, user.lipschitz);
    accel.objects.push_back(object);
  }
  // Scene size from the finite extents (planes are infinite along two axes).
  for (auto& object : accel.objects) {
    accel.extent = merge(accel.extent, object.world_bounds);
    auto box = object.world_bounds;
    for (auto a = 0; a < 3; a++) {
      if (!std::isfinite(at(box.min, a))) at(box.min, a) = 0;
      if (!std::isfinite(at(box.max, a))) at(box.max, a) = 0;
    }
    accel.bounds = merge(accel.bounds, box);
  }
  accel.size    = is_empty(accel.bounds) ? 1 : std::max(length(size(accel.bounds)), 1e-6f);
  accel.hit_min = accel.march.scene_epsilon * accel.size;
  return accel;
}

// -----------------------------------------------------------------------------
// EVALUATION
// -----------------------------------------------------------------------------

// Distance in the object's own space.
static float eval_local(const trace_object& object, vec3f p) {
  switch (object.kind) {
    case object_kind::function: return eval_sdf(*object.program, p);
    case object_kind::grid: return eval_grid(*object.grid, p);
    case object_kind::user: return object.user->eval(p);
  }
  return flt_max;
}

float eval_object_distance(const trace_object& object, vec3f p_world) {
  return eval_local(object, transform_point(object.local_from_world, p_world)) *
         object.distance_scale;
}

vec3f eval_object_normal(const trace_object& object, vec3f p_world, float step) {
  auto p     = transform_point(object.local_from_world, p_world);
  auto local = vec3f{};
  // Finite-difference step in local units.
  auto h = step / std::max(object.distance_scale, 1e-20f);
  switch (object.kind) {
    case object_kind::function:
      local = eval_sdf_gradient(*object.program, p, h);
      break;
    case object_kind::grid: local = eval_grid_gradient(*object.grid, p); break;
    case object_kind::user: {
      auto& f  = object.user->eval;
      auto  k0 = vec3f{1, -1, -1}, k1 = vec3f{-1, -1, 1},
           k2 = vec3f{-1, 1, -1}, k3 = vec3f{1, 1, 1};
      local = k0 * f(p + k0 * h) + k1 * f(p + k1 * h) + k2 * f(p + k2 * h) +
              k3 * f(p + k3 * h);
      break;
    }
  }
  // Gradients are covectors: world = transpose(L) * local.
  return normalize(transform_normal(object.world_from_local, local));
}

// -----------------------------------------------------------------------------
// INTERSECTION
// -----------------------------------------------------------------------------

// Hit of one object in [t0, t1] (already clipped to its box).
static scene_intersection intersect_object_in(const accel_data& accel,
    int index, const ray3f& ray, float t0, float t1) {
  auto& object = accel.objects[index];
  auto  isec   = scene_intersection{};
  auto  local  = transform_ray(object.local_from_world, ray);
  local.tmin   = t0;
  local.tmax   = t1;
  if (object.exact) {
    auto hit = false;
    auto t   = 0.0f;
    if (object.kind == object_kind::grid) {
      hit = intersect_grid(*object.grid, local, t, isec.evaluations);
    } else {
      intersect_sdf_exact(*object.program, local, hit, t);
      isec.evaluations = 1;
    }
    if (hit) {
      isec.hit      = true;
      isec.object   = index;
      isec.distance = t;
      isec.epsilon  = hit_epsilon(accel, t);
    }
    return isec;
  }
  auto distance = [&](float t) {
    return eval_local(object, ray_point(local, t)) * object.distance_scale;
  };
  auto march = sphere_trace(distance, t0, t1, accel.march, accel.hit_min);
  isec.evaluations = march.evaluations;
  if (march.hit) {
    isec.hit      = true;
    isec.object   = index;
    isec.distance = march.distance;
    isec.epsilon  = march.epsilon;
  }
  return isec;
}

// Box interval of an object along the ray, padded so that surfaces lying on
// the box are not clipped by rounding.
static bool object_interval(const accel_data& accel, const trace_object& object,
    const ray3f& ray, float& t0, float& t1) {
  auto pad = accel.hit_min + accel.march.hit_relative * 1e-3f;
  auto box = expand(object.world_bounds, pad);
  return intersect_bbox(ray, box, t0, t1);
}

scene_intersection intersect_object(
    const accel_data& accel, int index, const ray3f& ray) {
  auto t0 = 0.0f, t1 = 0.0f;
  if (!object_interval(accel, accel.objects[index], ray, t0, t1)) return {};
  return intersect_object_in(accel, index, ray, t0, t1);
}

// The seed's loop: the minimum of all objects' distances at every step.
static scene_intersection intersect_reference(
    const accel_data& accel, const ray3f& ray) {
  auto closest  = invalidid;
  auto distance = [&](float t) {
    auto p    = ray_point(ray, t);
    auto best = flt_max;
    for (auto i = 0; i < (int)accel.objects.size(); i++) {
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
  if (!intersect_bbox(ray, expand(accel.extent, accel.hit_min), t0, t1))
    return {};
  auto march = sphere_trace(distance, ray.tmin, t1, accel.march, accel.hit_min);
  auto isec        = scene_intersection{};
  isec.evaluations = march.evaluations * (int)accel.objects.size();
  if (march.hit) {
    distance(march.distance);  // sets `closest` at the hit point
    isec.hit      = true;
    isec.object   = closest;
    isec.distance = march.distance;
    isec.epsilon  = march.epsilon;
  }
  return isec;
}

scene_intersection intersect_scene(const accel_data& accel, const ray3f& ray) {
  if (accel.type == accel_type::none) return intersect_reference(accel, ray);
  auto best        = scene_intersection{};
  auto tmax        = ray.tmax;
  auto evaluations = 0;
  for (auto i = 0; i < (int)accel.objects.size(); i++) {
    auto clipped = ray;
    clipped.tmax = tmax;
    auto t0 = 0.0f, t1 = 0.0f;
    if (!object_interval(accel, accel.objects[i], clipped, t0, t1)) continue;
    auto isec = intersect_object_in(accel, i, ray, t0, t1);
    evaluations += isec.evaluations;
    if (isec.hit && isec.distance < tmax) {
      best = isec;
      tmax = isec.distance;
    }
  }
  best.evaluations = evaluations;
  return best;
}

}  // namespace implicit
