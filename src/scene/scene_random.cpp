// # implicit: random scenes (implementation)

#include "scene_random.h"

#include <cmath>
#include <string>
#include <utility>

#include "../math/random.h"
#include "../math/sampling.h"

namespace implicit {

// A uniformly random rotation: a uniformly random axis, then a uniformly
// random turn about it.
static mat3f random_rotation(rng_state& rng) {
  auto frame = basis_fromz(sample_sphere(rand2f(rng)));
  auto angle = 2 * pif * rand1f(rng);
  auto c = std::cos(angle), s = std::sin(angle);
  return {frame.x * c + frame.y * s, frame.y * c - frame.x * s, frame.z};
}

// One primitive of each kind (0 box, 1 sphere, 2 torus, 3 capped cone; any
// other kind leaves the default node), about one unit across; `center` is its
// centre in local coordinates (boxes have a corner at the origin).
static sdf_node random_primitive(int kind, rng_state& rng, vec3f& center) {
  auto node = sdf_node{};
  center    = {0, 0, 0};
  switch (kind) {
    case 0:
      node.type = sdf_type::box;
      node.size = {1, 0.6f, 0.8f};
      center    = node.size * 0.5f;
      break;
    case 1:
      node.type   = sdf_type::sphere;
      node.radius = 0.5f;
      break;
    case 2:
      node.type    = sdf_type::torus;
      node.radius  = 0.4f;
      node.radius2 = 0.12f;
      break;
    case 3:
      node.type    = sdf_type::capped_cone;
      node.height  = 0.5f;
      node.radius  = 0.5f;
      node.radius2 = 0.4f * rand1f(rng);
      break;
  }
  return node;
}

void add_random_primitives(scene_data& scene, int count, float extent,
    float size, int materials, uint64_t seed) {
  auto rng = make_rng(seed);
  for (auto i = 0; i < count; i++) {
    auto center   = vec3f{};
    auto node     = random_primitive(i % 4, rng, center);
    auto rotation = random_rotation(rng);
    auto scale    = vec3f{0.6f + 0.8f * rand1f(rng), 0.6f + 0.8f * rand1f(rng),
                     0.6f + 0.8f * rand1f(rng)} *
                 size;
    auto position = (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} - 0.5f) *
                    (2 * extent - size);
    auto world_from_local = frame3f{rotation.x * scale.x, rotation.y * scale.y,
        rotation.z * scale.z, {0, 0, 0}};
    world_from_local.o = position - transform_vector(world_from_local, center);
    auto function      = sdf_function_data{};
    function.name      = "object" + std::to_string(i);
    function.program   = make_primitive_program(node);
    function.local_from_world = inverse(world_from_local);
    function.material         = materials > 1 ? rand1i(rng, materials) : 0;
    scene.sdfunctions.push_back(function);
  }
}

scene_data make_model_scene(
    sdf_program program, const material_data& material) {
  auto scene = scene_data{};
  scene.materials.push_back(material);
  auto function     = sdf_function_data{};
  function.name     = "model";
  function.program  = std::move(program);
  function.material = 0;
  scene.sdfunctions.push_back(std::move(function));
  auto sky     = environment_data{};
  sky.emission = {1, 1, 1};
  scene.environments.push_back(sky);
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({1.6f, 1.9f, 3.2f}, {0, 0, 0}, {0, 1, 0});
  camera.focus  = 4;
  camera.aspect = 1;
  scene.cameras.push_back(camera);
  return scene;
}

}  // namespace implicit
