// # user_sdf: an SDF written in C++ (the seed's "in-app defined SDF")
//
// Builds a scene in code: a floor, a light and a user-defined gyroid shell
// clipped to a sphere, given as a callable with its bounds and Lipschitz
// bound, and renders it. Usage: user_sdf [output.png] [samples]

#include <cstdio>
#include <string>

#include "image/image_io.h"
#include "trace/render.h"

using namespace implicit;

// An sdfunction placed at `origin` (world -> local is a translation).
static sdf_function_data make_box(vec3f size, vec3f corner, int material) {
  auto node                 = sdf_node{};
  node.type                 = sdf_type::box;
  node.size                 = size;
  auto function             = sdf_function_data{};
  function.program          = make_primitive_program(node);
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -corner};
  function.material         = material;
  return function;
}

int main(int argc, char** argv) {
  auto output  = argc > 1 ? std::string{argv[1]} : std::string{"user_sdf.png"};
  auto samples = argc > 2 ? std::atoi(argv[2]) : 64;

  auto scene      = scene_data{};
  auto floor      = material_data{};
  floor.color     = {0.7f, 0.7f, 0.7f};
  auto light      = material_data{};
  light.emission  = {30, 30, 30};
  auto shell      = material_data{};
  shell.type      = material_type::glossy;
  shell.color     = {0.8f, 0.3f, 0.1f};
  shell.roughness = 0.3f;
  scene.materials = {floor, light, shell};
  scene.sdfunctions.push_back(make_box({4, 1e-4f, 4}, {-2, 0, -2}, 0));
  scene.sdfunctions.push_back(
      make_box({0.6f, 1e-4f, 0.6f}, {-0.3f, 1.6f, -0.3f}, 1));

  // Gyroid sheet intersected with a ball. The gyroid's gradient is at most
  // sqrt(6)*k for frequency k, so its Lipschitz bound is that; the max with
  // the (1-Lipschitz) ball keeps the larger bound.
  auto k    = 12.0f;
  auto user = user_sdf_data{};
  user.name = "gyroid";
  user.eval = [k](vec3f p) {
    auto q      = p * k;
    auto gyroid = std::sin(q.x) * std::cos(q.y) +
                  std::sin(q.y) * std::cos(q.z) + std::sin(q.z) * std::cos(q.x);
    auto sheet = (std::abs(gyroid) - 0.3f) / k;
    auto ball  = length(p) - 0.5f;
    return std::max(sheet, ball);
  };
  user.bounds           = {{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};
  user.lipschitz        = std::sqrt(6.0f);
  user.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -0.5f, 0}};
  user.material         = 2;
  scene.user_sdfs.push_back(user);

  auto environment     = environment_data{};
  environment.emission = {0.2f, 0.25f, 0.3f};
  scene.environments.push_back(environment);
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({1.2f, 1.1f, 1.8f}, {0, 0.45f, 0}, {0, 1, 0});
  camera.aspect = 1.5f;
  camera.focus  = 2;
  scene.cameras.push_back(camera);

  auto params       = trace_params{};
  params.resolution = 480;
  params.samples    = samples;
  try {
    auto context = make_render_context(std::move(scene), params);
    auto image   = image_data{};
    render_image(*context, params, image);
    save_image(output, image);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "user_sdf: error: %s\n", error.what());
    return 1;
  }
  std::printf("saved %s\n", output.c_str());
  return 0;
}
