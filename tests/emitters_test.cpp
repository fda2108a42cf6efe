// Render tests of emitters of every kind (trace/render.h): BSDF sampling
// alone, one-sample and two-sample MIS and every light picker converge to
// the same image, also through a medium; a closed form (a point inside an
// emissive shell); the same image at any thread count with many lights.

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <memory>

#include "math/random.h"
#include "sdf/sdf_expression.h"
#include "sdf/sdf_grid.h"
#include "trace/render.h"

using namespace implicit;

namespace {

sdf_node make_node(sdf_type type) {
  auto node = sdf_node{};
  node.type = type;
  return node;
}

sdf_function_data make_function(
    const sdf_program& program, vec3f origin, int material) {
  auto function             = sdf_function_data{};
  function.program          = program;
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -origin};
  function.material         = material;
  return function;
}

sdf_function_data make_function(sdf_node node, vec3f origin, int material) {
  return make_function(make_primitive_program(node), origin, material);
}

camera_data look_at(vec3f from, vec3f to) {
  auto camera   = camera_data{};
  camera.frame  = lookat_frame(from, to, {0, 1, 0});
  camera.aspect = 1;
  camera.focus  = length(from - to);
  return camera;
}

// A matte floor seen from above, lit only by emitters floating over it
// (material 1 emits; material 2 emits through a checker texture).
scene_data floor_scene() {
  auto scene            = scene_data{};
  auto floor            = material_data{};
  floor.color           = {0.8f, 0.8f, 0.8f};
  auto lamp             = material_data{};
  lamp.emission         = {6, 5, 4};
  auto textured         = lamp;
  textured.emission_tex = 0;
  auto texture          = texture_data{};
  texture.image         = make_image(8, 8);
  for (auto j = 0; j < 8; j++)
    for (auto i = 0; i < 8; i++)
      pixel(texture.image, i, j) =
          (i + j) % 2 ? vec4f{1, 1, 1, 1} : vec4f{0.2f, 0.4f, 0.1f, 1};
  scene.textures.push_back(texture);
  scene.materials = {floor, lamp, textured};
  auto box        = make_node(sdf_type::box);
  box.size        = {4, 0.01f, 4};
  scene.sdfunctions.push_back(make_function(box, {-2, -0.01f, -2}, 0));
  scene.cameras.push_back(look_at({0, 2.2f, 0.01f}, {0, 0, 0}));
  return scene;
}

// Mean of the image's RGB.
vec3f image_mean(const image_data& image) {
  auto sum = vec3f{0, 0, 0};
  for (auto& p : image.pixels) sum += xyz(p);
  return sum / (float)image.pixels.size();
}

image_data render(const scene_data& scene, const trace_params& params) {
  auto copy    = scene;
  auto context = make_render_context(std::move(copy), params);
  auto image   = image_data{};
  render_image(*context, params, image);
  return image;
}

// The image means of BSDF sampling alone, one-sample and two-sample MIS with
// every light picker agree: MIS within `tolerance`, BSDF sampling alone
// (noisier) within twice that. 24 px, `samples` spp, no clamping.
void check_estimators_agree(const scene_data& scene, int bounces,
    int samples = 256, float tolerance = 0.02f) {
  auto params         = trace_params{};
  params.resolution   = 24;
  params.samples      = samples;
  params.bounces      = bounces;
  params.clamp        = 1e6f;
  params.implicit_mis = false;
  auto reference      = image_mean(render(scene, params)).y;
  params.implicit_mis = true;
  CHECK(reference > 0.02f);
  for (auto mis : {mis_type::two_sample, mis_type::one_sample}) {
    for (auto sampler : {light_sampler_type::bvh, light_sampler_type::power,
             light_sampler_type::uniform}) {
      params.mis           = mis;
      params.light_sampler = sampler;
      auto mean            = image_mean(render(scene, params)).y;
      INFO("mis ", mis_type_names[(int)mis], " lights ",
          light_sampler_type_names[(int)sampler], " mean ", mean,
          " BSDF alone ", reference);
      CHECK(mean == doctest::Approx(reference).epsilon(2 * tolerance).scale(0));
      if (mis != mis_type::two_sample || sampler != light_sampler_type::bvh)
        continue;
      // The defaults against the others, at the MIS tolerance.
      params.mis           = mis_type::one_sample;
      params.light_sampler = light_sampler_type::uniform;
      auto seed            = image_mean(render(scene, params)).y;
      CHECK(mean == doctest::Approx(seed).epsilon(tolerance).scale(0));
    }
  }
}

}  // namespace

TEST_CASE("emitters: analytic shapes, CSG parts and textures light alike") {
  auto scene    = floor_scene();
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 0.35f;
  torus.radius2 = 0.08f;
  auto tilted   = make_function(torus, {-0.5f, 0.7f, 0.3f}, 1);
  auto c = std::cos(0.8f), s = std::sin(0.8f);
  tilted.local_from_world =
      frame3f{{1, 0, 0}, {0, c, s}, {0, -s, c}, {0, 0, 0}} *
      tilted.local_from_world;
  scene.sdfunctions.push_back(tilted);
  // A lamp: a bulb and a stem, one hard union (two lights).
  auto lamp     = sdf_program{};
  auto bulb     = make_node(sdf_type::sphere);
  bulb.radius   = 0.15f;
  auto stem     = make_node(sdf_type::capsule);
  stem.height   = 0.25f;
  stem.radius   = 0.04f;
  auto lowered  = add_transform(lamp, add_node(lamp, bulb),
       {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0.3f, 0}});
  auto operands = std::vector<int>{lowered, add_node(lamp, stem)};
  fold_sdf_operands(lamp, operands, make_node(sdf_type::op_union));
  scene.sdfunctions.push_back(make_function(lamp, {0.5f, 0.9f, -0.2f}, 1));
  // A textured emissive ball and a box.
  auto ball   = make_node(sdf_type::sphere);
  ball.radius = 0.2f;
  scene.sdfunctions.push_back(make_function(ball, {0.3f, 0.5f, 0.6f}, 2));
  auto box = make_node(sdf_type::box);
  box.size = {0.3f, 0.05f, 0.2f};
  scene.sdfunctions.push_back(make_function(box, {-0.4f, 1.1f, -0.6f}, 1));
  check_estimators_agree(scene, 3);
}

TEST_CASE("emitters: expressions and warped primitives light alike") {
  // Functions that are no distance bounds (traced by segments): a quartic
  // blob scaled by 1000 and a twisted box.
  auto scene = floor_scene();
  auto blob  = sdf_program{};
  parse_sdf_expression(blob, "1000*(16*x^4 + 16*y^4 + 16*z^4 + 4*x*y - 0.5)");
  scene.sdfunctions.push_back(make_function(blob, {-0.4f, 0.7f, 0.2f}, 1));
  auto bar    = sdf_program{};
  auto box    = make_node(sdf_type::box);
  box.size    = {0.1f, 0.5f, 0.1f};
  auto twist  = make_node(sdf_type::op_twist);
  twist.value = 3;
  twist.left  = add_transform(bar, add_node(bar, box),
       {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.05f, 0.25f, 0.05f}});
  add_node(bar, twist);
  scene.sdfunctions.push_back(make_function(bar, {0.5f, 0.8f, -0.3f}, 2));
  check_estimators_agree(scene, 3);
}

TEST_CASE("emitters: grids and user functions light alike, also in media") {
  auto scene    = floor_scene();
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 0.3f;
  torus.radius2 = 0.1f;
  auto volume   = volume_data{};
  volume.grid =
      std::make_shared<const grid_data>(bake_grid(make_primitive_program(torus),
          {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.5f, -0.5f, -0.5f}},
          {{0, 0, 0}, {1, 1, 1}}, 0.05f));
  scene.volumes.push_back(volume);
  auto instance             = vol_instance_data{};
  instance.volume           = 0;
  instance.material         = 1;
  instance.local_from_world = {
      {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -0.8f, 0.3f}};
  scene.vol_instances.push_back(instance);
  auto user             = user_sdf_data{};
  user.eval             = [](vec3f p) { return length(p) - 0.2f; };
  user.bounds           = {{-0.2f, -0.2f, -0.2f}, {0.2f, 0.2f, 0.2f}};
  user.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5f, -1, 0}};
  user.material         = 2;
  scene.user_sdfs.push_back(user);
  SUBCASE("in air") { check_estimators_agree(scene, 3); }
  SUBCASE("through an absorbing, scattering slab") {
    // Light samples see through the slab, paths scatter in it: 8 bounces so
    // that both reach the same path lengths.
    auto medium       = material_data{};
    medium.type       = material_type::volumetric;
    medium.color      = {0.5f, 0.5f, 0.5f};
    medium.scattering = {0.6f, 0.6f, 0.6f};
    medium.trdepth    = 0.2f;
    scene.materials.push_back(medium);
    auto slab = make_node(sdf_type::box);
    slab.size = {4, 0.15f, 4};
    scene.sdfunctions.push_back(
        make_function(slab, {-2, 0.3f, -2}, (int)scene.materials.size() - 1));
    check_estimators_agree(scene, 8, 384, 0.03f);
  }
}

TEST_CASE("emitters: inside an emissive shell, a matte ball reflects it") {
  // A shell of radius 2 (an onion of a sphere) emits 1 inward; a matte ball
  // of albedo 0.5 inside sees it everywhere, never itself: radiance 0.5.
  auto scene      = scene_data{};
  auto ball       = material_data{};
  ball.color      = {0.5f, 0.5f, 0.5f};
  auto shell      = material_data{};
  shell.emission  = {1, 1, 1};
  scene.materials = {ball, shell};
  auto onion      = sdf_program{};
  auto sphere     = make_node(sdf_type::sphere);
  sphere.radius   = 2;
  auto layer      = make_node(sdf_type::op_onion);
  layer.thickness = 0.05f;
  layer.left      = add_node(onion, sphere);
  add_node(onion, layer);
  scene.sdfunctions.push_back(make_function(onion, {0, 0, 0}, 1));
  sphere.radius = 0.5f;
  scene.sdfunctions.push_back(make_function(sphere, {0, 0, 0}, 0));
  scene.cameras.push_back(look_at({0, 0.3f, 1.5f}, {0, 0, 0}));
  auto params       = trace_params{};
  params.resolution = 16;
  params.samples    = 64;
  params.bounces    = 4;
  for (auto mis : {0, 1, 2}) {
    params.implicit_mis = mis > 0;
    params.mis       = mis == 1 ? mis_type::one_sample : mis_type::two_sample;
    auto image       = render(scene, params);
    auto ball_pixel  = pixel(image, 8, 8);
    auto shell_pixel = pixel(image, 0, 0);
    INFO("mode ", mis);
    CHECK(ball_pixel.y == doctest::Approx(0.5f).epsilon(0.03));
    CHECK(shell_pixel.y == doctest::Approx(1.0f).epsilon(1e-4));
    // The whole ball region, well inside its silhouette.
    auto sum = 0.0, count = 0.0;
    for (auto j = 5; j < 11; j++)
      for (auto i = 5; i < 11; i++) {
        sum += pixel(image, i, j).y;
        count++;
      }
    CHECK(sum / count == doctest::Approx(0.5).epsilon(0.01));
  }
}

TEST_CASE("emitters: many lights give the same image at any thread count") {
  auto scene  = floor_scene();
  auto rng    = make_rng(17);
  auto sphere = make_node(sdf_type::sphere);
  for (auto k = 0; k < 60; k++) {
    sphere.radius = 0.02f + 0.05f * rand1f(rng);
    auto x        = rand1f(rng) * 3 - 1.5f;
    auto y        = 0.1f + rand1f(rng);
    auto z        = rand1f(rng) * 3 - 1.5f;
    scene.sdfunctions.push_back(make_function(sphere, {x, y, z}, 1 + k % 2));
  }
  auto params       = trace_params{};
  params.resolution = 24;
  params.samples    = 4;
  auto one          = image_data{};
  {
    auto control =
        tbb::global_control(tbb::global_control::max_allowed_parallelism, 1);
    one = render(scene, params);
  }
  auto two = render(scene, params);
  REQUIRE(one.pixels.size() == two.pixels.size());
  CHECK(std::memcmp(one.pixels.data(), two.pixels.data(),
            one.pixels.size() * sizeof(vec4f)) == 0);
  CHECK(image_mean(one).x > 0.01f);
}
