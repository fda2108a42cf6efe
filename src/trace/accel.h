// # implicit: ray-scene intersection
//
// Every implicit object of the scene (SDF program, grid instance, user SDF)
// becomes a trace_object with its world bounds and the maps to its own space.
// intersect_scene() finds the closest hit: the default (`bvh`) visits only
// the objects whose boxes the ray crosses, nearest first, and marches each in
// its own space inside its box; the reference (`none`) reproduces the seed's
// loop, the minimum over all objects at every step.
#pragma once

#include <string>
#include <vector>

#include "../scene/scene.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

enum class accel_type { bvh, none };
inline const std::vector<std::string> accel_type_names = {"bvh", "none"};

// Sphere-tracing parameters. The hit threshold at distance t along a ray is
// max(hit_min, hit_relative * t): sub-pixel for camera rays, and scaled to the
// scene (hit_min = scene_epsilon * scene size) near the start of bounces.
struct march_params {
  int   max_iterations = 450;    // the seed's default (--stmaxiter)
  float hit_relative   = 1e-5f;  // fraction of the distance travelled
  float scene_epsilon  = 1e-6f;  // fraction of the scene size
  float overrelax      = 1.6f;   // Keinert et al. 2014 (1 disables)
  float fallback       = 2;      // closest approach within this many
                                 // thresholds counts as a hit
};

// -----------------------------------------------------------------------------
// OBJECTS
// -----------------------------------------------------------------------------

enum class object_kind { function, grid, user };

// One implicit object, ready for tracing. `local_from_world` maps world
// points to the space where the object's function is evaluated (grid space
// for grids, including the instance scale); a local distance times
// `distance_scale` bounds the world distance from below.
struct trace_object {
  object_kind          kind             = object_kind::function;
  int                  index            = invalidid;  // in the scene array
  int                  material         = invalidid;
  frame3f              local_from_world = {};
  frame3f              world_from_local = {};
  float                distance_scale   = 1;
  bbox3f               local_bounds     = {};
  bbox3f               world_bounds     = {};
  bool                 exact            = false;  // closed-form intersection
  const sdf_program*   program          = nullptr;
  const grid_data*     grid             = nullptr;
  const user_sdf_data* user             = nullptr;
};

// The objects and what the tracer needs to know about the whole scene.
struct accel_data {
  accel_type                type    = accel_type::bvh;
  std::vector<trace_object> objects = {};
  bbox3f                    bounds  = {};  // finite bounds of all objects
  bbox3f                    extent  = {};  // all bounds, maybe infinite
  float                     size    = 1;   // diagonal of bounds
  float                     hit_min = 1e-6f;
  march_params              march   = {};
};

// Build the objects of a scene. The scene must outlive the result.
accel_data make_accel(
    const scene_data& scene, accel_type type, const march_params& march);

// -----------------------------------------------------------------------------
// INTERSECTION
// -----------------------------------------------------------------------------

struct scene_intersection {
  bool  hit         = false;
  int   object      = invalidid;  // index in accel_data::objects
  float distance    = flt_max;
  float epsilon     = 0;  // hit threshold at the hit (world units)
  int   evaluations = 0;  // SDF evaluations (or grid voxels) spent
};

// Closest hit along a ray with unit direction in [ray.tmin, ray.tmax].
scene_intersection intersect_scene(const accel_data& accel, const ray3f& ray);

// Closest hit with one object only.
scene_intersection intersect_object(
    const accel_data& accel, int object, const ray3f& ray);

// Signed distance bound of one object at a world point (world units).
float eval_object_distance(const trace_object& object, vec3f p_world);

// World-space unit normal of an object at a world point near its surface;
// `step` is the finite-difference step in world units when one is needed.
vec3f eval_object_normal(const trace_object& object, vec3f p_world, float step);

// Hit threshold at distance t along a ray.
inline float hit_epsilon(const accel_data& accel, float t) {
  return std::max(accel.hit_min, accel.march.hit_relative * t);
}

}  // namespace implicit
