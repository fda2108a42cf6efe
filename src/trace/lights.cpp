// # implicit: lights (implementation)

#include "lights.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>

#include "../math/random.h"
#include "../math/sampling.h"

namespace implicit {

// -----------------------------------------------------------------------------
// ENVIRONMENTS
// -----------------------------------------------------------------------------

// Most cells of an environment's sampling table (512x256).
static constexpr int64_t max_environment_cells = int64_t{1} << 17;

// How much coarser cells may raise the second moment of an environment-only
// estimate, E[(L / pdf)^2] / E[L / pdf]^2 (1 when the pdf follows every
// texel): 1% of the squared mean, so at most 1% more variance.
static constexpr double max_cell_second_moment_rise = 0.01;

// Per-cell sums of texel weights and of their squares, over cells of f x f
// texels (the last row and column partial).
struct cell_sums {
  int                 width = 0, height = 0, f = 1;
  std::vector<double> weights = {}, squares = {};
};

// Sums over cells twice as large: ceil(ceil(n / f) / 2) = ceil(n / 2f), so
// cell (i, j) of the result holds the texels i / 2f, j / 2f as before.
static cell_sums coarser_cells(const cell_sums& fine) {
  auto coarse   = cell_sums{};
  coarse.width  = (fine.width + 1) / 2;
  coarse.height = (fine.height + 1) / 2;
  coarse.f      = fine.f * 2;
  coarse.weights.assign((size_t)coarse.width * coarse.height, 0.0);
  coarse.squares.assign(coarse.weights.size(), 0.0);
  for (auto j = 0; j < fine.height; j++) {
    for (auto i = 0; i < fine.width; i++) {
      auto from = (size_t)j * fine.width + i;
      auto to   = (size_t)(j / 2) * coarse.width + i / 2;
      coarse.weights[to] += fine.weights[from];
      coarse.squares[to] += fine.squares[from];
    }
  }
  return coarse;
}

// E[(L / pdf)^2] / E[L / pdf]^2 of sampling a cell by weight and a texel in
// it uniformly: sum over cells of texels * squares / weight, over the total.
static double cell_second_moment(
    const cell_sums& cells, const image_data& image) {
  auto sum = 0.0, total = 0.0;
  for (auto j = 0; j < cells.height; j++) {
    auto rows = std::min(cells.f, image.height - j * cells.f);
    for (auto i = 0; i < cells.width; i++) {
      auto columns = std::min(cells.f, image.width - i * cells.f);
      auto k       = (size_t)j * cells.width + i;
      if (cells.weights[k] <= 0) continue;
      sum += (double)rows * columns * cells.squares[k] / cells.weights[k];
      total += cells.weights[k];
    }
  }
  return total > 0 ? sum / total : 1;
}

// Sampling table of a lat-long image. A texel weighs its largest channel
// times sin(theta) (Yocto/GL's texel weight); negative or non-finite texels
// weigh nothing. Cells are f x f texels, f a power of two: the smallest that
// keeps the count within max_environment_cells, then doubled while that
// raises the second moment by at most max_cell_second_moment_rise. A smooth
// sky ends with a few thousand cells, whose pdfs stay in L1 on every bounce;
// a small sun keeps cells as fine as the budget allows.
static void make_environment_table(
    const image_data& image, trace_light& light) {
  auto f = 1;
  while ((int64_t)((image.width + f - 1) / f) * ((image.height + f - 1) / f) >
         max_environment_cells)
    f *= 2;
  auto cells   = cell_sums{};
  cells.width  = (image.width + f - 1) / f;
  cells.height = (image.height + f - 1) / f;
  cells.f      = f;
  cells.weights.assign((size_t)cells.width * cells.height, 0.0);
  cells.squares.assign(cells.weights.size(), 0.0);
  // Rows of cells in parallel (a large sky is read at start-up, before the
  // render), each summing its texels in the same order as a serial loop.
  tbb::parallel_for(0, cells.height, [&](int cell_row) {
    auto row = (size_t)cell_row * cells.width;
    for (auto j = cell_row * f; j < std::min((cell_row + 1) * f, image.height);
         j++) {
      auto sin_theta = std::sin((j + 0.5f) * pif / image.height);
      for (auto i = 0; i < image.width; i++) {
        auto& texel = pixel(image, i, j);
        auto weight = std::max(texel.x, std::max(texel.y, texel.z)) * sin_theta;
        if (!(std::isfinite(weight) && weight > 0)) continue;
        cells.weights[row + i / f] += weight;
        cells.squares[row + i / f] += (double)weight * weight;
      }
    }
  });
  auto budget = cell_second_moment(cells, image) + max_cell_second_moment_rise;
  while (cells.width > 1 || cells.height > 1) {
    auto coarse = coarser_cells(cells);
    if (cell_second_moment(coarse, image) > budget) break;
    cells = std::move(coarse);
  }
  light.width  = cells.width;
  light.height = cells.height;
  auto weights = std::vector<float>(cells.weights.begin(), cells.weights.end());
  light.cells  = make_alias_table(weights);
  if (light.cells.entries.empty()) return;
  auto scale = (double)light.width * light.height /
               (light.cells.total * 2 * (double)pif * (double)pif);
  light.cell_pdfs.resize(weights.size());
  for (size_t k = 0; k < weights.size(); k++) {
    auto valid = std::isfinite(weights[k]) && weights[k] > 0;  // as the table
    light.cell_pdfs[k] = valid ? (float)(weights[k] * scale) : 0.0f;
  }
}

// -----------------------------------------------------------------------------
// SHAPE LIGHTS
// -----------------------------------------------------------------------------

// Rigid maps keep areas and distances, so local samples are world samples.
static bool is_rigid(const frame3f& frame) {
  auto det = determinant(rotation(frame));
  return std::abs(max_stretch(frame) - 1) < 1e-3f &&
         std::abs(std::abs(det) - 1) < 3e-3f;
}

// Lines that survey each emitter's surface, and most crossings followed
// along one (a line through a sponge of an emitter stops counting there).
inline constexpr int light_survey_lines     = 256;
inline constexpr int light_survey_crossings = 32;
// Seed of the survey's lines (one stream per object: any thread count
// surveys the same lines).
inline constexpr uint64_t light_survey_seed = 0x5eed11647;
// A cone light's sphere reaches this fraction beyond the farthest surface
// point the survey found (the survey may miss a tip; directions toward it
// are then left to BSDF sampling, which is still unbiased).
inline constexpr float light_sphere_margin = 0.01f;
// Normals found by the survey, widened by this angle (radians) for the
// normals it missed.
inline constexpr float light_normal_margin = 0.1f;
// Below this |cos| between a line and the normal, the step past a crossing
// is taken as at this cosine (grazing crossings).
inline constexpr float light_survey_min_cos = 0.05f;

// What the lines through an emitter's sphere found: how many lines, how many
// crossings, how far from the centre the farthest crossing lies, and the
// normals.
struct surface_survey {
  int                crossings = 0;
  float              farthest  = 0;
  std::vector<vec3f> normals   = {};
};

// Isotropic lines through the ball (center, radius): a uniform direction,
// then a uniform point of the disk across it (Cauchy-Crofton: the expected
// number of crossings of a surface of area A is A / (2 pi radius^2)). The
// lines are marched with the default march parameters: the survey is an
// estimate, made once, whatever a render's iteration cap.
static surface_survey survey_surface(
    const accel_data& accel, int index, vec3f center, float radius) {
  auto& object = accel.objects[index];
  auto  march  = march_params{};
  auto  survey = surface_survey{};
  auto  rng    = make_rng(light_survey_seed, (uint64_t)index);
  for (auto line = 0; line < light_survey_lines; line++) {
    auto rd        = rand2f(rng);
    auto rp        = rand2f(rng);
    auto direction = sample_sphere(rd);
    auto disk      = sample_disk(rp) * radius;
    auto across    = basis_fromz(direction);
    auto origin    = center + across.x * disk.x + across.y * disk.y -
                  direction * (radius * 1.01f);
    auto ray = ray3f{origin, direction, 0, radius * 2.02f};
    for (auto k = 0; k < light_survey_crossings; k++) {
      auto isec = intersect_object(accel, march, index, ray);
      if (!isec.hit) break;
      auto p      = ray_point(ray, isec.distance);
      auto normal = eval_object_normal(object, p, isec.epsilon * 0.5f);
      survey.crossings++;
      survey.farthest = std::max(survey.farthest, distance(p, center));
      survey.normals.push_back(normal);
      // Past the crossing: closed-form shapes need only a rounding step
      // (a flat box is 1e-5 thick); marches a step beyond the fallback of
      // their hit threshold, or they would find the surface they leave.
      auto step = 4 * flt_eps * (isec.distance + radius);
      if (!(object.exact && object.kind == object_kind::function)) {
        auto cosine =
            std::max(std::abs(dot(normal, direction)), light_survey_min_cos);
        step = ((march.fallback + 2) * isec.epsilon +
                   2 * min_hit_epsilon(accel, march)) /
               cosine;
      }
      ray.tmin = isec.distance + step;
    }
  }
  return survey;
}

// Mean texel of a texture (1 without one).
static vec3f mean_texel(const scene_data& scene, int texture) {
  if (texture < 0 || texture >= (int)scene.textures.size()) return {1, 1, 1};
  auto& pixels = scene.textures[texture].image.pixels;
  if (pixels.empty()) return {1, 1, 1};
  auto sum = std::array<double, 3>{};
  for (auto& texel : pixels)
    for (auto c = 0; c < 3; c++) sum[c] += (&texel.x)[c];
  auto n = (double)pixels.size();
  return {(float)(sum[0] / n), (float)(sum[1] / n), (float)(sum[2] / n)};
}

// A light for emissive object `index`: surveyed, its sphere shrunk to the
// surface found, its power pi * area * mean emission.
static trace_light make_shape_light(
    const scene_data& scene, const accel_data& accel, int index) {
  auto& object = accel.objects[index];
  auto  light  = trace_light{};
  light.object = index;
  // The sphere about the local box's centre through its corners bounds the
  // object; the survey then finds how much of it the surface fills.
  auto box    = expand(object.local_bounds, object.local_padding);
  auto center = transform_point(object.world_from_local, implicit::center(box));
  auto radius = length(size(box)) * 0.5f * max_stretch(object.world_from_local);
  auto survey = survey_surface(accel, index, center, radius);
  auto& material = scene.materials[object.material];
  auto  emission = material.emission * mean_texel(scene, material.emission_tex);
  // An emitter no line met still gets the area of one crossing, so that
  // light sampling reaches it.
  auto crossings = std::max(survey.crossings, 1);
  auto area      = 2 * pif * radius * radius * crossings / light_survey_lines;
  light.bounds.power = pif * area * mean(emission) * material.opacity;
  bound_normals(survey.normals, light_normal_margin, light.bounds);
  auto& node = object.shape;
  if (object.kind == object_kind::function && object.single &&
      node.type == sdf_type::box && is_rigid(object.local_from_world)) {
    light.shape         = light_shape::box;
    light.center        = center;
    light.radius        = radius * 1.01f;
    light.bounds.bounds = object.world_bounds;
    light.bounds.reach  = expand(object.world_bounds, 1e-3f * radius);
    return light;
  }
  light.shape  = light_shape::cone;
  light.center = center;
  light.radius =
      survey.crossings > 0
          ? std::min(radius, survey.farthest * (1 + light_sphere_margin))
          : radius;
  auto sphere         = bbox3f{center - light.radius, center + light.radius};
  light.bounds.bounds = intersect(object.world_bounds, sphere);
  light.bounds.reach  = sphere;
  return light;
}

// Whether an object emits and is bounded (unbounded emitters, planes, are
// left to BSDF sampling).
static bool is_shape_light(
    const scene_data& scene, const trace_object& object) {
  if (object.material < 0 || object.material >= (int)scene.materials.size())
    return false;
  auto& material = scene.materials[object.material];
  if (!(max(material.emission) > 0) || !(material.opacity > 0)) return false;
  auto& box = object.world_bounds;
  return !is_empty(object.local_bounds) && !is_empty(box) && is_finite(box) &&
         box.min.y <= box.max.y && box.min.z <= box.max.z;
}

lights_data make_lights(const scene_data& scene, const accel_data& accel) {
  auto lights = lights_data{};
  lights.object_lights.assign(accel.objects.size(), invalidid);
  auto emitters = std::vector<int>{};
  for (auto i = 0; i < (int)accel.objects.size(); i++)
    if (is_shape_light(scene, accel.objects[i])) emitters.push_back(i);
  // Surveys in parallel, each on its own stream: the same at any thread
  // count.
  lights.lights.resize(emitters.size());
  tbb::parallel_for(0, (int)emitters.size(), [&](int k) {
    lights.lights[k] = make_shape_light(scene, accel, emitters[k]);
  });
  lights.shapes = (int)lights.lights.size();
  auto bounds   = std::vector<light_bounds>{};
  for (auto k = 0; k < lights.shapes; k++) {
    lights.object_lights[emitters[k]] = k;
    bounds.push_back(lights.lights[k].bounds);
    auto previous = lights.power_cdf.empty() ? 0.0f : lights.power_cdf.back();
    lights.power_cdf.push_back(previous + lights.lights[k].bounds.power);
  }
  lights.tree = make_light_tree(bounds);
  for (auto i = 0; i < (int)scene.environments.size(); i++) {
    auto& environment = scene.environments[i];
    lights.env_from_world.push_back(inverse(environment.frame));
    if (max(environment.emission) <= 0) continue;
    auto light        = trace_light{};
    light.shape       = light_shape::environment;
    light.environment = i;
    auto texture      = environment.emission_tex;
    if (texture >= 0 && texture < (int)scene.textures.size()) {
      make_environment_table(scene.textures[texture].image, light);
      if (light.cells.entries.empty()) continue;
    }
    lights.lights.push_back(std::move(light));
  }
  for (auto k = lights.shapes; k < (int)lights.lights.size(); k++)
    if (lights.shapes == 0 || !lights.lights[k].cells.entries.empty())
      lights.picked_environments.push_back(k);
  return lights;
}

vec3f eval_environment(
    const scene_data& scene, const lights_data& lights, vec3f direction) {
  // Lights made for another scene (or none, lights_data{}) have no frames.
  if (lights.env_from_world.size() != scene.environments.size())
    return eval_environment(scene, direction);
  auto emission = vec3f{0, 0, 0};
  for (auto i = 0; i < (int)scene.environments.size(); i++)
    emission += eval_environment(
        scene, scene.environments[i], lights.env_from_world[i], direction);
  return emission;
}

vec3f eval_environment_light(const scene_data& scene, const lights_data& lights,
    const trace_light& light, vec3f direction) {
  auto& environment = scene.environments[light.environment];
  if (lights.env_from_world.size() != scene.environments.size())
    return eval_environment(scene, environment, direction);
  return eval_environment(
      scene, environment, lights.env_from_world[light.environment], direction);
}

// -----------------------------------------------------------------------------
// PICKING A LIGHT
// -----------------------------------------------------------------------------

// The environments' share of picks (bvh and power): pbrt-v4's, one part
// per picked environment and one for all shape lights together. A constant
// environment beside shape lights gets none: its radiance is the same in
// every direction, so a BSDF sample, drawn by f cos, finds it at least about
// as well as a direction uniform on the sphere, and it counts with MIS
// weight 1 as its light pdf is 0 (pbrt-v4 leaves uniform infinite lights to
// BSDF samples the same way). Every light sample then goes to the shapes:
// examples/sdfunction's noise per sample fell from 1.09x Cycles' to 0.85x.
static float environment_share(const lights_data& lights) {
  auto environments = (int)lights.picked_environments.size();
  if (environments == 0) return 0;
  if (lights.shapes == 0) return 1;
  return (float)environments / (float)(environments + 1);
}

// Pick probability of environment light `light` (bvh and power).
static float environment_probability(const lights_data& lights, int light) {
  auto& picked = lights.picked_environments;
  if (std::find(picked.begin(), picked.end(), light) == picked.end()) return 0;
  return environment_share(lights) / (float)picked.size();
}

// Probability of shape light `light` among the shape lights.
static float shape_probability(
    const lights_data& lights, const light_context& context, int light) {
  switch (context.sampler) {
    case light_sampler_type::bvh:
      return light_tree_probability(
          lights.tree, light, context.position, context.normal);
    case light_sampler_type::power:
      return lights.lights[light].bounds.power / lights.power_cdf.back();
    case light_sampler_type::uniform: return 1.0f / lights.shapes;
  }
  return 0;
}

float pick_light_probability(
    const lights_data& lights, const light_context& context, int light) {
  auto count = (int)lights.lights.size();
  if (light < 0 || light >= count) return 0;
  if (context.sampler == light_sampler_type::uniform)
    return sample_uniform_pdf(count);
  if (light >= lights.shapes) return environment_probability(lights, light);
  return (1 - environment_share(lights)) *
         shape_probability(lights, context, light);
}

// Pick a light with one number.
static light_pick pick_light(
    const lights_data& lights, const light_context& context, float r) {
  auto count = (int)lights.lights.size();
  if (count == 0) return {};
  if (context.sampler == light_sampler_type::uniform)
    return {sample_uniform(count, r), sample_uniform_pdf(count)};
  auto share = environment_share(lights);
  if (r < share) {
    auto environments = (int)lights.picked_environments.size();
    return {lights.picked_environments[sample_uniform(environments, r / share)],
        share / environments};
  }
  r         = clamp((r - share) / (1 - share), 0.0f, 1 - flt_eps / 2);
  auto pick = light_pick{};
  if (context.sampler == light_sampler_type::bvh) {
    pick = sample_light_tree(lights.tree, context.position, context.normal, r);
  } else {
    pick.index       = sample_discrete(lights.power_cdf, r);
    pick.probability = shape_probability(lights, context, pick.index);
  }
  pick.probability *= 1 - share;
  return pick;
}

// -----------------------------------------------------------------------------
// DIRECTIONS
// -----------------------------------------------------------------------------

// Face areas of a box of size s: -x, +x, -y, +y, -z, +z.
static float box_face_area(vec3f s, int face) {
  auto axis = face / 2;
  return at(s, (axis + 1) % 3) * at(s, (axis + 2) % 3);
}

// Point on face `face` of the box [0,s] at uv.
static vec3f box_face_point(vec3f s, int face, vec2f uv) {
  auto axis = face / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
  auto p      = vec3f{};
  at(p, axis) = (face % 2) ? at(s, axis) : 0;
  at(p, u)    = uv.x * at(s, u);
  at(p, v)    = uv.y * at(s, v);
  return p;
}

// Weights of picking each face of the box [0,s] from local point p: the
// faces that look at p (p beyond their plane) by area * cos / d^2 at their
// centre, an estimate of their solid angle (`facing` true); from inside, all
// by area. Returns the total.
static float box_face_weights(
    vec3f s, vec3f p, float weights[6], bool& facing) {
  auto total = 0.0f;
  facing     = true;
  for (auto face = 0; face < 6; face++) {
    auto axis     = face / 2;
    auto height   = (face % 2) ? at(p, axis) - at(s, axis) : -at(p, axis);
    weights[face] = 0;
    if (!(height > 0)) continue;
    auto middle   = box_face_point(s, face, {0.5f, 0.5f});
    auto d        = length(p - middle);
    weights[face] = box_face_area(s, face) * height / (d * d * d);
    total += weights[face];
  }
  if (total > 0) return total;
  facing = false;
  for (auto face = 0; face < 6; face++) {
    weights[face] = box_face_area(s, face);
    total += weights[face];
  }
  return total;
}

// A face that looks at the point and whose estimated solid angle exceeds
// this is sampled uniformly in solid angle: a lamp near a wall, where area
// sampling's cos / d^2 varies across the face (1.9x lower relMSE at 16 spp
// on bench/lamp_near_wall.json). Smaller faces are sampled by area, where
// the two nearly agree and area sampling is cheaper (at 0.1 sr, 06_gridsdf
// took 1.7% more instructions for the same noise).
constexpr auto box_face_solid_angle_min = 0.3f;

// The spherical rectangle of face `face` of the box [0,s] seen from local
// point p, in the coordinates (u, v, axis) of box_face_point relative to p.
static spherical_rectangle box_face_rectangle(vec3f s, vec3f p, int face) {
  auto axis = face / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
  auto plane = (face % 2) ? at(s, axis) : 0.0f;
  return make_spherical_rectangle(-at(p, u), at(s, u) - at(p, u), -at(p, v),
      at(s, v) - at(p, v), plane - at(p, axis));
}

// Solid-angle pdf of the box sampler along `direction` from `position`: the
// face weight of the point where the ray enters the box (or, from inside,
// leaves it) times t^2 / (|cos| area). From outside a ray enters a box once,
// through a face that looks at the point, so no other point of the faces
// sampled lies along it.
static float box_light_pdf(
    const trace_object& object, vec3f position, vec3f direction) {
  auto  s = object.shape.size;
  auto  p = transform_point(object.local_from_world, position);
  auto  d = transform_direction(object.local_from_world, direction);
  float weights[6];
  auto  facing = false;
  auto  total  = box_face_weights(s, p, weights, facing);
  auto  t0 = 0.0f, t1 = 0.0f;
  if (!intersect_bbox({p, d, 0, flt_max}, {{0, 0, 0}, s}, t0, t1)) return 0;
  auto inside = t0 <= 0;
  auto t      = inside ? t1 : t0;
  // The face: the axis whose slab bound the interval there.
  auto face = -1;
  auto best = flt_max;
  for (auto axis = 0; axis < 3; axis++) {
    auto da = at(d, axis);
    if (da == 0) continue;
    // Entering through the near plane, leaving through the far one.
    auto far_side = (da > 0) == inside;
    auto plane    = far_side ? at(s, axis) : 0.0f;
    auto gap      = std::abs((plane - at(p, axis)) / da - t);
    if (gap < best) {
      best = gap;
      face = 2 * axis + (far_side ? 1 : 0);
    }
  }
  if (face < 0 || weights[face] <= 0) return 0;
  if (facing && weights[face] > box_face_solid_angle_min) {
    auto solid_angle = box_face_rectangle(s, p, face).solid_angle;
    return solid_angle > 0 ? weights[face] / total / solid_angle : 0;
  }
  auto cosine = std::abs(at(d, face / 2));
  return weights[face] / total * t * t / (cosine * box_face_area(s, face));
}

// Direction toward a point of the box's faces, and its solid-angle pdf, the
// one box_light_pdf() gives: the point sampled is where the ray enters the
// box (or, from inside, leaves it).
static vec3f sample_box_light(const trace_object& object, vec3f position,
    float rel, vec2f ruv, float& pdf) {
  auto  s = object.shape.size;
  auto  p = transform_point(object.local_from_world, position);
  float weights[6];
  auto  facing = false;
  auto  total  = box_face_weights(s, p, weights, facing);
  auto  r      = rel * total;
  auto  face   = 5;
  for (auto k = 0; k < 6; k++) {
    if (weights[k] > 0 && r < weights[k]) {
      face = k;
      break;
    }
    r -= weights[k];
  }
  while (weights[face] <= 0) face--;  // rounding past the last weight
  if (facing && weights[face] > box_face_solid_angle_min) {
    auto rect   = box_face_rectangle(s, p, face);
    auto offset = sample_spherical_rectangle(rect, ruv);
    auto axis = face / 2, u = (axis + 1) % 3, v = (axis + 2) % 3;
    auto point = p;
    at(point, u) += offset.x;
    at(point, v) += offset.y;
    at(point, axis) = (face % 2) ? at(s, axis) : 0.0f;
    pdf = rect.solid_angle > 0 ? weights[face] / total / rect.solid_angle : 0;
    return normalize(
        transform_point(object.world_from_local, point) - position);
  }
  auto point = box_face_point(s, face, ruv);
  auto to    = point - p;
  auto t     = length(to);
  auto along = std::abs(at(to, face / 2));
  pdf        = along > 0 ? weights[face] / total * t * t * t /
                        (along * box_face_area(s, face))
                         : 0;
  return normalize(transform_point(object.world_from_local, point) - position);
}

// Solid-angle pdf of the cone of a light's sphere: uniform inside it, or over
// every direction from inside the sphere.
static float cone_light_pdf(
    const trace_light& light, vec3f position, vec3f direction) {
  auto to = light.center - position;
  auto d2 = dot(to, to), r2 = light.radius * light.radius;
  if (d2 <= r2) return 1 / (4 * pif);
  // Within the cone: the line passes within the radius, ahead (the offset
  // from the centre computed directly, not as a difference of squares,
  // which would lose the radius far from the light).
  auto along = dot(to, direction);
  if (along <= 0) return 0;
  auto offset = to - direction * along;
  if (dot(offset, offset) > r2) return 0;
  return sample_cone_pdf(sphere_cone_size(r2, d2));
}

// Direction in the cone of a light's sphere, and its pdf (cone_light_pdf()'s
// but at the rim, where rounding may leave the direction just outside).
static vec3f sample_cone_light(
    const trace_light& light, vec3f position, vec2f ruv, float& pdf) {
  auto to = light.center - position;
  auto d2 = dot(to, to), r2 = light.radius * light.radius;
  if (d2 <= r2) {
    pdf = 1 / (4 * pif);
    return sample_sphere(ruv);
  }
  auto size = sphere_cone_size(r2, d2);
  pdf       = sample_cone_pdf(size);
  return sample_cone(to / std::sqrt(d2), size, ruv);
}

// Solid-angle pdf of an environment light (and, for a textured one, start
// reading its texels along the direction).
static float environment_light_pdf(const scene_data& scene,
    const lights_data& lights, const trace_light& light, vec3f direction) {
  if (light.cells.entries.empty()) return 1 / (4 * pif);
  auto wl =
      transform_direction(lights.env_from_world[light.environment], direction);
  auto uv        = latlong_uv(wl);
  auto sin_theta = std::sqrt(wl.x * wl.x + wl.z * wl.z);
  prefetch_texture(
      scene, scene.environments[light.environment].emission_tex, uv);
  auto i = clamp((int)(uv.x * light.width), 0, light.width - 1);
  auto j = clamp((int)(uv.y * light.height), 0, light.height - 1);
  if (!(sin_theta > 0)) return 0;
  return light.cell_pdfs[(size_t)j * light.width + i] / sin_theta;
}

static vec3f sample_environment_light(
    const scene_data& scene, const trace_light& light, float rel, vec2f ruv) {
  auto& environment = scene.environments[light.environment];
  if (light.cells.entries.empty())
    return transform_direction(environment.frame, sample_sphere(ruv));
  auto u   = ruv.x;
  auto idx = sample_alias(light.cells, rel, u);
  auto uv  = vec2f{((idx % light.width) + u) / light.width,
      ((idx / light.width) + ruv.y) / light.height};
  // Its radiance is looked up once the ray is traced: start reading it.
  prefetch_texture(scene, environment.emission_tex, uv);
  return transform_direction(environment.frame, latlong_direction(uv));
}

// Solid-angle pdf of one light's directions.
static float direction_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const trace_light& light, vec3f position,
    vec3f direction) {
  switch (light.shape) {
    case light_shape::cone: return cone_light_pdf(light, position, direction);
    case light_shape::box:
      if (cone_light_pdf(light, position, direction) <= 0) return 0;
      return box_light_pdf(accel.objects[light.object], position, direction);
    case light_shape::environment:
      return environment_light_pdf(scene, lights, light, direction);
  }
  return 0;
}

// -----------------------------------------------------------------------------
// SAMPLING
// -----------------------------------------------------------------------------

light_sample sample_lights(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, float rl,
    float rel, vec2f ruv) {
  auto pick = pick_light(lights, context, rl);
  if (pick.index < 0 || !(pick.probability > 0)) return {};
  auto& light     = lights.lights[pick.index];
  auto  direction = vec3f{0, 0, 0};
  auto  pdf       = 0.0f;  // the density BSDF samples see, direction_pdf()
  switch (light.shape) {
    case light_shape::cone:
      direction = sample_cone_light(light, context.position, ruv, pdf);
      break;
    case light_shape::box:
      direction = sample_box_light(
          accel.objects[light.object], context.position, rel, ruv, pdf);
      break;
    case light_shape::environment:
      direction = sample_environment_light(scene, light, rel, ruv);
      pdf       = environment_light_pdf(scene, lights, light, direction);
      break;
  }
  pdf *= pick.probability;
  if (!(pdf > 0)) return {};
  return {pick.index, direction, pdf};
}

float sample_light_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, int light,
    vec3f direction) {
  auto probability = pick_light_probability(lights, context, light);
  if (!(probability > 0)) return 0;
  return probability * direction_pdf(scene, accel, lights, lights.lights[light],
                           context.position, direction);
}

float sample_lights_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, vec3f direction) {
  auto count = (int)lights.lights.size();
  if (count == 0) return 0;
  auto pdf = 0.0f;
  for (auto k = lights.shapes; k < count; k++)
    pdf += sample_light_pdf(scene, accel, lights, context, k, direction);
  if (lights.shapes == 0) return pdf;
  // Shape lights whose reach the direction meets, through the tree.
  auto share    = environment_share(lights);
  auto weighted = context.sampler == light_sampler_type::bvh;
  visit_light_tree(lights.tree, context.position, context.normal, direction,
      weighted, [&](int light, float tree_probability) {
        // The same product as pick_light_probability(), without walking
        // the tree again.
        auto probability = weighted
                               ? (1 - share) * tree_probability
                               : pick_light_probability(lights, context, light);
        pdf += probability * direction_pdf(scene, accel, lights,
                                 lights.lights[light], context.position,
                                 direction);
      });
  return pdf;
}

}  // namespace implicit
