// # implicit: lights
//
// Every bounded emissive object is a light, whatever its kind (analytic
// primitive, CSG part, grid, user function): it is sampled by directions
// uniform in the cone of a sphere around its emitting surface (for a sphere,
// the sphere itself: the exact visible cap), except rigid boxes, sampled on
// the faces that look at the shading point (uniformly in solid angle where a
// face looks large, by area elsewhere). Environments are constant, or
// lat-long textures importance sampled by texel luminance times sin(theta),
// summed over cells of at most 2^17 per image, as coarse as the image
// allows, through an alias table. Unbounded emitters (planes), and constant
// environments beside shape lights (bvh and power selection), are left to
// BSDF sampling, which reaches them with full weight.
//
// One light is picked per sample: by a BVH over the lights' bounds, power
// and normals (light_tree.h), by power, or uniformly (the seed's way), with
// the environments keeping a fixed share. A light sample counts only the
// emission of its own light along its direction (eval_light in trace.cpp),
// so the pdf that weights a BSDF sample landing on an emitter is that one
// light's: pick probability times its direction pdf. Why the estimate stays
// unbiased is written above sample_light_pdf().
#pragma once

#include <string>
#include <vector>

#include "../math/alias.h"
#include "accel.h"
#include "light_tree.h"

namespace implicit {

// -----------------------------------------------------------------------------
// LIGHTS
// -----------------------------------------------------------------------------

// How a light is picked: a BVH over the lights (pbrt-v4's BVHLightSampler),
// in proportion to power, or uniformly among all lights (the seed's way).
enum class light_sampler_type { bvh, power, uniform };
inline const std::vector<std::string> light_sampler_type_names = {
    "bvh", "power", "uniform"};

// How a light's directions are drawn: uniform in the cone of a sphere around
// the emitting surface (any object), points on the faces of a rigid box that
// look at the shading point, or an environment's cells.
enum class light_shape { cone, box, environment };

// One light. Textured environments keep an alias table over cells of texels
// and the cells' weights. Cells keep the tables small enough to stay in
// cache (at most 512x256 cells, 1.5 MB, against 16 MB for a table over
// 2048x1024 texels; the seed's smooth sky needs only 64x32, 24 KB);
// directions are uniform in uv within a cell, so the pdf is the cell's
// probability over its solid angle, whatever the weights.
struct trace_light {
  light_shape shape       = light_shape::cone;
  int         object      = invalidid;  // in accel_data::objects
  int         environment = invalidid;  // in scene_data::environments
  // The sphere of a cone light: directions toward it are sampled. Every
  // point that the survey of the surface found lies inside it (see
  // make_lights); for a box, the box's sphere (rejects rays early).
  vec3f center = {0, 0, 0};
  float radius = 0;
  // Bounds, power and normals of the emitting surface (shape lights).
  light_bounds bounds = {};
  // Environment cells.
  alias_table cells = {};
  // Solid-angle pdf of each cell (row-major) times sin(theta): its
  // probability over the cell's uv area and 2 pi^2 (one float per cell, so
  // the lookup on every bounce stays in cache and needs no division).
  std::vector<float> cell_pdfs = {};
  int                width = 0, height = 0;  // environment cells
};

struct lights_data {
  // Shape lights first (lights[0, shapes) are the tree's emitters), then
  // environments.
  std::vector<trace_light> lights = {};
  int                      shapes = 0;
  // The light of each accel object, invalidid for objects that are none.
  std::vector<int> object_lights = {};
  light_tree       tree          = {};
  // Cumulative power of the shape lights (power selection).
  std::vector<float> power_cdf = {};
  // The environment lights that bvh and power selection pick: the textured
  // ones (a constant one is left to BSDF samples, see environment_share),
  // or all when there is no shape light.
  std::vector<int> picked_environments = {};
  // Inverse frame of every scene environment (lights or not), so that
  // escaped rays need no 3x3 inverse.
  std::vector<frame3f> env_from_world = {};
};

// Collect the lights of a scene. Each emissive object's surface is surveyed
// by lines through its bounds (Cauchy-Crofton): their crossings give its
// area (hence power), its normals and a sphere around it.
lights_data make_lights(const scene_data& scene, const accel_data& accel);

// Radiance of the scene's environments along a world direction, as
// eval_environment(scene, direction) with the inverse frames kept in
// `lights` by make_lights() (without them, it inverts them per call).
vec3f eval_environment(
    const scene_data& scene, const lights_data& lights, vec3f direction);

// Radiance of one environment light along a world direction.
vec3f eval_environment_light(const scene_data& scene, const lights_data& lights,
    const trace_light& light, vec3f direction);

// -----------------------------------------------------------------------------
// SAMPLING
// -----------------------------------------------------------------------------

// Where light is wanted: the shading point, its normal on the side it
// scatters to ({0, 0, 0} when it scatters to both sides: transmission,
// media), and how lights are picked.
struct light_context {
  vec3f              position = {0, 0, 0};
  vec3f              normal   = {0, 0, 0};
  light_sampler_type sampler  = light_sampler_type::bvh;
};

// Probability of picking light `light` at the context's point.
float pick_light_probability(
    const lights_data& lights, const light_context& context, int light);

// A direction toward one light, the light, and the probability density of
// the sample (pick probability times the light's solid-angle pdf); light
// invalidid and pdf 0 when no light can be sampled.
struct light_sample {
  int   light     = invalidid;
  vec3f direction = {0, 0, 0};
  float pdf       = 0;
};

// Pick a light with `rl`, a face or cell with `rel`, a direction with `ruv`.
// For a textured environment it also starts reading the texels the
// direction's radiance needs once its ray is traced (large skies miss the
// cache).
light_sample sample_lights(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, float rl,
    float rel, vec2f ruv);

// Density with which sample_lights() produces `direction` through light
// `light`: its pick probability times its solid-angle pdf.
//
// Why light samples and BSDF samples together count each emitter once
// (two-sample MIS, Veach 1997). The direct light of emitter k at x is
// I_k = integral of f(w) E_k(x, w) dw, where E_k is the emission of k's
// surfaces along w, attenuated by what the ray crosses and zero behind
// anything that blocks it. The light sample draws w with density
// p_k(w) = P(k | x) q_k(w) and adds f E_k w_l / p_k; the BSDF sample draws w
// with density p_b(w) and, where its path lands on k unscattered, adds
// f E_k w_b / p_b, with w_l = p_k^2 / (p_k^2 + p_b^2) and w_b = p_b^2 /
// (p_k^2 + p_b^2). Their expected sum is the integral of f E_k (w_l + w_b):
// where p_k > 0 the weights sum to 1; where p_k = 0 (outside the cone, a
// light the tree gives no chance at x, a constant environment that is never
// picked, an emitter that is no light) the light
// sample never lands and w_b = 1; where f > 0 the BSDF has p_b > 0. So the sum
// is I_k for every k, whatever the cone, the pick probabilities or the
// survey's accuracy, provided the pdf used in w_b is the density that
// sample_lights() draws with: this function, for the light of the emitter
// that the BSDF sample hit, seen from the point it left. Summing over k
// (every emitting surface belongs to one light, or to none) gives the direct
// light; nothing else of the path is weighted. One-sample MIS and media use
// the mixture density below instead, and follow the sampled direction as
// the path itself.
float sample_light_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, int light,
    vec3f direction);

// Density with which sample_lights() produces `direction` through any
// light: the sum of sample_light_pdf() over the lights (only those whose
// bounds the direction meets are visited). Like sample_lights(), it starts
// reading the sky's texels along the direction: the pdf of a direction is
// wanted just before its ray is traced.
float sample_lights_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, vec3f direction);

}  // namespace implicit
