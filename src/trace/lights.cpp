// # implicit: lights (implementation)

#include "lights.h"

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

// Sampling table of a lat-long image: cells of f x f texels, f the smallest
// power of two that keeps the cell count within max_environment_cells. A
// cell weighs the sum of its texels' largest channel times sin(theta)
// (Yocto/GL's texel weight); negative or non-finite texels weigh nothing.
static void make_environment_table(
    const image_data& image, trace_light& light) {
  auto f = 1;
  while ((int64_t)((image.width + f - 1) / f) * ((image.height + f - 1) / f) >
         max_environment_cells)
    f *= 2;
  light.width  = (image.width + f - 1) / f;
  light.height = (image.height + f - 1) / f;
  auto sums    = std::vector<double>((size_t)light.width * light.height, 0.0);
  for (auto j = 0; j < image.height; j++) {
    auto sin_theta = std::sin((j + 0.5f) * pif / image.height);
    auto row       = sums.data() + (size_t)(j / f) * light.width;
    for (auto i = 0; i < image.width; i++) {
      auto& texel  = pixel(image, i, j);
      auto  weight = std::max(texel.x, std::max(texel.y, texel.z)) * sin_theta;
      if (!(std::isfinite(weight) && weight > 0)) continue;
      row[i / f] += weight;
    }
  }
  auto weights = std::vector<float>(sums.begin(), sums.end());
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
      // The direction's pdf comes next: start reading it now.
      __builtin_prefetch(light.cell_pdfs.data() + idx);
      return transform_direction(environment.frame, latlong_direction(uv));
    }
  }
  return {0, 0, 0};
}

// Area-to-solid-angle pdf of the points where the ray crosses a shape light:
// sum of t^2 / (|cos| area) over the crossings in front of `position`.
static float shape_light_pdf(
    const trace_object& object, const trace_light& light, const ray3f& world) {
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

float sample_lights_pdf(const accel_data& accel, const lights_data& lights,
    vec3f position, vec3f direction) {
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
        auto i         = clamp((int)(uv.x * light.width), 0, light.width - 1);
        auto j         = clamp((int)(uv.y * light.height), 0, light.height - 1);
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
