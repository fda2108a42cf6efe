// # implicit: lights (implementation)

#include "lights.h"

#include <tbb/parallel_for.h>

#include "../math/sampling.h"
#include "../sdf/sdf_primitives.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SHAPE LIGHTS
// -----------------------------------------------------------------------------

// Rigid maps keep areas and distances, so local samples are world samples.
static bool is_rigid(const frame3f& frame) {
  auto det = determinant(rotation(frame));
  return std::abs(max_stretch(frame) - 1) < 1e-3f &&
         std::abs(std::abs(det) - 1) < 3e-3f;
}

// Face areas of a box of size s: -x, +x, -y, +y, -z, +z.
static std::vector<float> box_faces_cdf(vec3f s) {
  auto areas = std::vector<float>{
      s.y * s.z, s.y * s.z, s.x * s.z, s.x * s.z, s.x * s.y, s.x * s.y};
  for (auto i = 1; i < 6; i++) areas[i] += areas[i - 1];
  return areas;
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

lights_data make_lights(const scene_data& scene, const accel_data& accel) {
  auto lights = lights_data{};
  for (auto i = 0; i < (int)accel.objects.size(); i++) {
    auto& object = accel.objects[i];
    if (object.material < 0 || object.material >= (int)scene.materials.size())
      continue;
    if (max(scene.materials[object.material].emission) <= 0) continue;
    if (object.kind != object_kind::function || !object.single) continue;
    if (!is_rigid(object.local_from_world)) continue;
    auto& node   = object.shape;
    auto  light  = trace_light{};
    light.object = i;
    if (node.type == sdf_type::box) {
      light.shape = light_shape::box;
      light.cdf   = box_faces_cdf(node.size);
      light.area  = light.cdf.back();
    } else if (node.type == sdf_type::sphere) {
      light.shape = light_shape::sphere;
      light.area  = 4 * pif * node.radius * node.radius;
    } else {
      continue;
    }
    if (light.area <= 0) continue;
    // Rigid: the local sphere about the shape's centre is the world one
    // (1% larger, so that rounding never rejects a crossing).
    auto local_center =
        node.type == sdf_type::box ? node.size * 0.5f : vec3f{0, 0, 0};
    auto local_radius =
        node.type == sdf_type::box ? length(node.size) * 0.5f : node.radius;
    light.center = transform_point(object.world_from_local, local_center);
    light.radius = local_radius * 1.01f;
    lights.lights.push_back(light);
  }
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

// -----------------------------------------------------------------------------
// SAMPLING
// -----------------------------------------------------------------------------

vec3f sample_lights(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, float rl, float rel, vec2f ruv) {
  if (lights.lights.empty()) return {0, 0, 0};
  auto& light = lights.lights[sample_uniform((int)lights.lights.size(), rl)];
  switch (light.shape) {
    case light_shape::box: {
      auto& object = accel.objects[light.object];
      auto  size   = object.shape.size;
      auto  face   = sample_discrete(light.cdf, rel);
      auto  p      = transform_point(
                object.world_from_local, box_face_point(size, face, ruv));
      return normalize(p - position);
    }
    case light_shape::sphere: {
      auto& object = accel.objects[light.object];
      auto  radius = object.shape.radius;
      auto  p =
          transform_point(object.world_from_local, sample_sphere(ruv) * radius);
      return normalize(p - position);
    }
    case light_shape::environment: {
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
  }
  return {0, 0, 0};
}

// Whether the ray can cross the light's bounding sphere ahead of its origin:
// the origin is inside, or the sphere is ahead and the line passes within
// its radius (the offset from the centre computed directly, not as a
// difference of squares, which would lose the radius far from the light).
static bool may_cross_light(const trace_light& light, const ray3f& ray) {
  auto to     = light.center - ray.o;
  auto radius = light.radius * light.radius;
  if (dot(to, to) <= radius) return true;
  auto along = dot(to, ray.d);
  if (along <= 0) return false;
  auto offset = to - ray.d * (along / dot(ray.d, ray.d));
  return dot(offset, offset) <= radius;
}

// Area-to-solid-angle pdf of the points where the ray crosses a shape light:
// sum of t^2 / (|cos| area) over the crossings in front of `position`.
static float shape_light_pdf(
    const trace_object& object, const trace_light& light, const ray3f& world) {
  if (!may_cross_light(light, world)) return 0;
  auto  ray  = transform_ray(object.local_from_world, world);
  auto& node = object.shape;
  auto  pdf  = 0.0f;
  auto  add  = [&](float t, vec3f normal) {
    if (t <= 0) return;
    auto cosine = std::abs(dot(normal, ray.d));
    if (cosine > 0) pdf += t * t / (cosine * light.area);
  };
  if (light.shape == light_shape::box) {
    auto box = bbox3f{{0, 0, 0}, node.size};
    auto t0 = 0.0f, t1 = 0.0f;
    auto unclipped = ray3f{ray.o, ray.d, flt_lowest, flt_max};
    if (!intersect_bbox(unclipped, box, t0, t1)) return 0;
    for (auto t : {t0, t1}) {
      // The face is the axis where the point sits closest to a side.
      auto p      = ray_point(ray, t),
           q      = abs(p - node.size * 0.5f) - node.size * 0.5f;
      auto axis   = (q.x > q.y && q.x > q.z) ? 0 : (q.y > q.z ? 1 : 2);
      auto n      = vec3f{};
      at(n, axis) = 1;
      add(t, n);
    }
  } else {
    auto t0 = 0.0f, t1 = 0.0f;
    if (!intersect_sphere(ray, node.radius, t0, t1)) return 0;
    for (auto t : {t0, t1}) add(t, normalize(ray_point(ray, t)));
  }
  return pdf;
}

float sample_lights_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, vec3f direction) {
  if (lights.lights.empty()) return 0;
  auto pdf = 0.0f;
  auto ray = ray3f{position, direction, 0, flt_max};
  for (auto index = 0; index < (int)lights.lights.size(); index++) {
    auto& light  = lights.lights[index];
    auto  picked = sample_uniform_pdf((int)lights.lights.size());
    switch (light.shape) {
      case light_shape::box:
      case light_shape::sphere:
        pdf +=
            picked * shape_light_pdf(accel.objects[light.object], light, ray);
        break;
      case light_shape::environment: {
        if (light.cells.entries.empty()) {
          pdf += picked / (4 * pif);
          break;
        }
        auto wl = transform_direction(
            lights.env_from_world[light.environment], direction);
        auto uv        = latlong_uv(wl);
        auto sin_theta = std::sqrt(wl.x * wl.x + wl.z * wl.z);
        if (light.environment < (int)scene.environments.size())
          prefetch_texture(
              scene, scene.environments[light.environment].emission_tex, uv);
        auto i = clamp((int)(uv.x * light.width), 0, light.width - 1);
        auto j = clamp((int)(uv.y * light.height), 0, light.height - 1);
        if (sin_theta > 0)
          pdf +=
              picked * light.cell_pdfs[(size_t)j * light.width + i] / sin_theta;
        break;
      }
    }
  }
  return pdf;
}

}  // namespace implicit
