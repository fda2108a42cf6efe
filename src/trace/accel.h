// # implicit: ray-scene intersection
//
// Every implicit object of the scene (SDF program, grid instance, user SDF)
// becomes a trace_object with its world bounds and the maps to its own space.
// intersect_scene() finds the closest hit: the default (`bvh`) puts every
// bounded object in an Embree BVH as one user primitive (scenes with a few
// objects use a loop over their boxes, sorted by entry, instead), so a ray
// visits only the objects whose world boxes it crosses, and solves in closed
// form (sphere, box, plane) or marches each in its own space, inside its own
// box; unbounded objects (planes) are tested beside the BVH. The reference
// (`none`) reproduces the seed's loop, the minimum over all objects at every
// step.
//
// The accelerated result does not depend on the order in which the BVH
// visits the objects: each object's hit is what its own march over its whole
// box interval gives (a march stops early only when everything it could
// still find lies beyond the closest hit so far), and equal distances go to
// the lower object index. So it equals the minimum over all objects of
// intersect_object(), and it is the same at any thread count.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "../scene/scene.h"
#include "../sdf/sdf_field.h"
#include "../sdf/sdf_split.h"
#include "box_tree.h"

// Embree's handle types (rtcore_device.h, rtcore_geometry.h), declared here so
// that only the implementation includes Embree.
struct RTCDeviceTy;
struct RTCSceneTy;

namespace implicit {

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

enum class accel_type { bvh, none };
inline const std::vector<std::string> accel_type_names = {"bvh", "none"};

// Sphere-tracing parameters, passed when tracing: an accel holds geometry
// only, so a render with other values (the viewer's iteration cap) rebuilds
// nothing. The hit threshold at distance t along a ray is
// max(hit_min, hit_relative * t): sub-pixel for camera rays, and scaled to the
// scene (hit_min = scene_epsilon * scene size, see min_hit_epsilon()) near the
// start of bounces.
struct march_params {
  int   max_iterations = 450;    // the seed's default (--stmaxiter)
  float hit_relative   = 1e-5f;  // fraction of the distance travelled
  float scene_epsilon  = 1e-6f;  // fraction of the scene size
  float overrelax      = 1.6f;   // Keinert et al. 2014 (1 disables)
  float planar         = 0.9f;   // Balint & Valasek 2018, replaces the
                                 // above when > 0; the reference mode
                                 // keeps Keinert's steps
  float fallback = 2;            // closest approach within this many
                                 // thresholds counts as a hit
};

// What make_accel() builds: fixed for the accel's lifetime.
struct accel_params {
  int linear_max = 8;      // up to this many bounded objects are tested in
                           // a loop, not through the BVH
  size_t prune_bytes = 0;  // budget of each object's pruned steps
                           // (0: sdf_field_params' default)
};

// -----------------------------------------------------------------------------
// OBJECTS
// -----------------------------------------------------------------------------

enum class object_kind { function, grid, user };

// One implicit object, ready for tracing. `local_from_world` maps world
// points to the space where the object's function is evaluated (grid space
// for grids, including the instance scale); a local distance times
// `distance_scale` bounds the world distance from below.
//
// With the `bvh` accel, an sdfunction whose root is a hard union (also below
// transforms and nested unions) becomes one object per bounded operand, all
// with the function's index, material and frame, so that a ray marches only
// the operands whose boxes it crosses; its unbounded operands stay together
// as one more object. The closest hit of the parts is the union's: the union
// is below the hit threshold exactly where one of its operands is. At a hit
// the normal is the hit part's gradient, which is the union's gradient
// wherever that part is the minimum (the minimum of functions has the
// gradient of the one that attains it, off the measure-zero set where two
// are equal and the union has a crease anyway). Every function object owns
// its program as an sdf_field: pruned per cell of an octree over its box for
// the `bvh` accel, the whole tree for the reference (`none`). Grid objects
// share their volume's grid and user objects own a copy of the user SDF, so
// an accel refers to nothing in the scene it was made from.
struct trace_object {
  object_kind kind             = object_kind::function;
  int         index            = invalidid;  // in scene
  int         material         = invalidid;
  frame3f     local_from_world = {};
  frame3f     world_from_local = {};
  float       distance_scale   = 1;
  bbox3f      local_bounds     = {};
  bbox3f      world_bounds     = {};
  float       local_padding    = 0;      // box padding, local
  bool        exact            = false;  // closed-form intersection
  bool        single           = false;  // one primitive node
  // A function that is no distance bound (field_trace.h): traced by
  // segments, with the range and the Lipschitz bound of the whole tape over
  // the padded local box.
  bool                                 segments        = false;
  interval                             whole_range     = entire_interval;
  float                                whole_lipschitz = flt_inf;
  sdf_node                             shape = {};       // that node, if single
  std::shared_ptr<const sdf_field>     field = nullptr;  // function objects
  std::shared_ptr<const grid_data>     grid  = nullptr;  // the volume's
  std::shared_ptr<const user_sdf_data> user  = nullptr;  // a copy
};

// Owner of an Embree device and scene. Move-only: the handles are released
// once, by the destructor of the last owner.
struct embree_bvh {
  RTCDeviceTy* device = nullptr;
  RTCSceneTy*  scene  = nullptr;

  embree_bvh()                             = default;
  embree_bvh(const embree_bvh&)            = delete;
  embree_bvh& operator=(const embree_bvh&) = delete;
  embree_bvh(embree_bvh&& other) noexcept;
  embree_bvh& operator=(embree_bvh&& other) noexcept;
  ~embree_bvh();
};

// The objects and what the tracer needs to know about the whole scene.
// Move-only (it owns the BVH); objects must not change after make_accel().
struct accel_data {
  accel_type                type    = accel_type::bvh;
  std::vector<trace_object> objects = {};
  bbox3f                    bounds  = {};  // finite bounds of all objects
  bbox3f                    extent  = {};  // all bounds, maybe infinite
  float                     size    = 1;   // diagonal of bounds
  float                     padding = 0;   // of world boxes, see make_accel
  std::vector<int>          bounded = {};  // BVH primitive -> object
  // Their padded world boxes by axis (structure of arrays, the count padded
  // to a multiple of 4): without a BVH the loop over them tests four at a
  // time.
  std::array<std::vector<float>, 3> bounded_min = {}, bounded_max = {};
  std::vector<int> unbounded = {};  // objects tested beside the BVH
  std::vector<int> segmented = {};  // objects with `segments` (all kinds)
  embree_bvh       bvh       = {};  // see accel_params::linear_max
  // The padded local boxes of the bounded objects in world space, as a tree
  // whose items index `bounded` (bvh only): for the camera's first pass.
  box_tree block_tree = {};
};

// Most bounded objects that intersect_scene() may test in a loop, sorted by
// box entry, rather than through the BVH (whose per-ray cost is higher for
// few objects); accel_params::linear_max picks the number up to this.
inline constexpr int linear_max_objects = 16;  // a multiple of 4

// Build the objects of a scene. The result keeps no reference to the scene.
// Throws io_error for parameters out of range.
accel_data make_accel(
    const scene_data& scene, accel_type type, const accel_params& params = {});

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
// Thread-safe; allocates nothing.
scene_intersection intersect_scene(
    const accel_data& accel, const march_params& march, const ray3f& ray);

// Whether anything is hit in [ray.tmin, ray.tmax] (shadow rays): stops at the
// first hit found. Always equal to intersect_scene(accel, march, ray).hit.
bool intersect_scene_any(
    const accel_data& accel, const march_params& march, const ray3f& ray);

// Closest hit with one object only, marching its whole box interval. The
// march may give up, reporting no hit, once it is sure that its hit (if any)
// lies beyond `cutoff`; hits at or before `cutoff` are always the same.
scene_intersection intersect_object(const accel_data& accel,
    const march_params& march, int object, const ray3f& ray,
    float cutoff = flt_max);

// Signed distance bound of one object at a world point (world units).
float eval_object_distance(const trace_object& object, vec3f p_world);

// World-space unit normal of an object at a world point near its surface;
// `step` is the finite-difference step in world units when one is needed.
vec3f eval_object_normal(const trace_object& object, vec3f p_world, float step);

// Smallest hit threshold (near the start of rays), in world units.
inline float min_hit_epsilon(
    const accel_data& accel, const march_params& march) {
  return march.scene_epsilon * accel.size;
}

// Hit threshold at distance t along a ray.
inline float hit_epsilon(
    const accel_data& accel, const march_params& march, float t) {
  return std::max(min_hit_epsilon(accel, march), march.hit_relative * t);
}

}  // namespace implicit
