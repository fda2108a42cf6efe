// # implicit: scene evaluation

#include "scene.h"

#include "../math/sampling.h"
#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CAMERAS
// -----------------------------------------------------------------------------

int find_camera(const scene_data& scene, const std::string& name) {
  if (scene.cameras.empty()) return invalidid;
  auto find = [&](const std::string& n) {
    for (auto i = 0; i < (int)scene.cameras.size(); i++)
      if (scene.cameras[i].name == n) return i;
    return invalidid;
  };
  if (!name.empty()) {
    auto idx = find(name);
    if (idx != invalidid) return idx;
    auto names = std::string{};
    for (auto& camera : scene.cameras)
      names += (names.empty() ? "" : ", ") + camera.name;
    throw io_error(
        "camera \"" + name + "\" not found (cameras: " + names + ")");
  }
  for (auto n : {"default", "camera", "camera0", "camera1"}) {
    auto idx = find(n);
    if (idx != invalidid) return idx;
  }
  return 0;
}

vec2i camera_resolution(const camera_data& camera, int resolution) {
  if (camera.aspect >= 1) {
    return {
        resolution, std::max(1, (int)std::round(resolution / camera.aspect))};
  } else {
    return {
        std::max(1, (int)std::round(resolution * camera.aspect)), resolution};
  }
}

// Yocto/GL 4.2 eval_camera: film along the longer side, lens model with
// focus distance and aperture; the camera looks down -z.
ray3f eval_camera(const camera_data& camera, vec2f image_uv, vec2f lens_uv) {
  auto film = camera.aspect >= 1
                  ? vec2f{camera.film, camera.film / camera.aspect}
                  : vec2f{camera.film * camera.aspect, camera.film};
  if (!camera.orthographic) {
    auto q  = vec3f{film.x * (0.5f - image_uv.x), film.y * (image_uv.y - 0.5f),
        camera.lens};
    auto dc = -normalize(q);
    auto e  = vec3f{
        lens_uv.x * camera.aperture / 2, lens_uv.y * camera.aperture / 2, 0};
    // From the lens centre the ray to the focus plane is dc itself: skip the
    // division and second normalization (a pinhole's every ray).
    if (e.x == 0 && e.y == 0)
      return {transform_point(camera.frame, e),
          transform_direction(camera.frame, dc)};
    auto p = dc * camera.focus / std::abs(dc.z);
    auto d = normalize(p - e);
    return {
        transform_point(camera.frame, e), transform_direction(camera.frame, d)};
  } else {
    auto scale = 1 / camera.lens;
    auto q     = vec3f{film.x * (0.5f - image_uv.x) * scale,
        film.y * (image_uv.y - 0.5f) * scale, camera.lens};
    auto e     = vec3f{-q.x, -q.y, 0} + vec3f{lens_uv.x * camera.aperture / 2,
                                        lens_uv.y * camera.aperture / 2, 0};
    auto p     = vec3f{-q.x, -q.y, -camera.focus};
    auto d     = normalize(p - e);
    return {
        transform_point(camera.frame, e), transform_direction(camera.frame, d)};
  }
}

void add_missing_camera(scene_data& scene, const bbox3f& bounds) {
  if (!scene.cameras.empty()) return;
  auto camera   = camera_data{};
  camera.name   = "default";
  camera.lens   = 0.050f;
  camera.film   = 0.036f;
  camera.aspect = 16.0f / 9.0f;
  auto box      = is_finite(bounds) && !is_empty(bounds)
                      ? bounds
                      : bbox3f{{-1, -1, -1}, {1, 1, 1}};
  auto c        = center(box);
  auto radius   = std::max(length(size(box)) / 2, 1e-3f);
  auto distance = 2 * radius * camera.lens / (camera.film / camera.aspect);
  auto from     = c + vec3f{0, 0, 1} * distance;
  camera.frame  = lookat_frame(from, c, {0, 1, 0});
  camera.focus  = distance;
  scene.cameras.push_back(camera);
}

// -----------------------------------------------------------------------------
// TEXTURES AND ENVIRONMENTS
// -----------------------------------------------------------------------------

vec4f eval_texture(const scene_data& scene, int texture, vec2f uv) {
  if (texture < 0 || texture >= (int)scene.textures.size()) return {1, 1, 1, 1};
  return eval_image(scene.textures[texture].image, uv);
}

void prefetch_texture(const scene_data& scene, int texture, vec2f uv) {
  if (texture < 0 || texture >= (int)scene.textures.size()) return;
  prefetch_image(scene.textures[texture].image, uv);
}

vec3f eval_environment(const scene_data& scene,
    const environment_data& environment, const frame3f& env_from_world,
    vec3f direction) {
  // Without a texture the lat-long mapping (two atan2) is not needed.
  auto texture = environment.emission_tex;
  if (texture < 0 || texture >= (int)scene.textures.size())
    return environment.emission;
  auto wl = transform_direction(env_from_world, direction);
  return environment.emission *
         xyz(eval_texture(scene, environment.emission_tex, latlong_uv(wl)));
}

vec3f eval_environment(const scene_data& scene,
    const environment_data& environment, vec3f direction) {
  return eval_environment(
      scene, environment, inverse(environment.frame), direction);
}

vec3f eval_environment(const scene_data& scene, vec3f direction) {
  auto emission = vec3f{0, 0, 0};
  for (auto& environment : scene.environments)
    emission += eval_environment(scene, environment, direction);
  return emission;
}

}  // namespace implicit
