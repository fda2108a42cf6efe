// Tests for light sampling: pdfs integrate to 1 over the sphere of
// directions and agree with the directions sample_lights() produces.

#include "lights.h"

#include <doctest/doctest.h>

#include "../math/random.h"
#include "../math/sampling.h"

using namespace implicit;

namespace {

// Integral of sample_lights_pdf over all directions from `position`, by
// stratified quadrature in (cos theta, phi).
double integrate_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, vec3f position, int n = 800) {
  auto sum = 0.0;
  for (auto j = 0; j < n; j++) {
    for (auto i = 0; i < 2 * n; i++) {
      auto u = (i + 0.5f) / (2 * n), v = (j + 0.5f) / n;
      auto direction = sample_sphere({u, v});
      sum += sample_lights_pdf(scene, accel, lights, position, direction);
    }
  }
  return sum * (4 * pif) / (2.0 * n * n);
}

// A lat-long environment with a bright spot, so importance sampling matters.
scene_data environment_scene() {
  auto scene    = scene_data{};
  auto texture  = texture_data{};
  texture.image = make_image(32, 16);
  for (auto j = 0; j < 16; j++)
    for (auto i = 0; i < 32; i++)
      pixel(texture.image, i, j) = {
          0.1f + 0.05f * i, 0.2f, 0.1f + j * 0.02f, 1};
  pixel(texture.image, 5, 3) = {50, 40, 30, 1};
  scene.textures.push_back(texture);
  auto environment         = environment_data{};
  environment.emission     = {1, 1, 1};
  environment.emission_tex = 0;
  // A rotated environment frame exercises the frame in both directions.
  environment.frame = {{0, 0, 1}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 0}};
  scene.environments.push_back(environment);
  return scene;
}

sdf_function_data emitter(sdf_node node, vec3f origin) {
  auto function             = sdf_function_data{};
  function.program          = make_primitive_program(node);
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -origin};
  function.material         = 0;
  return function;
}

}  // namespace

TEST_CASE("lights: environment pdf integrates to 1 and matches its samples") {
  auto scene  = environment_scene();
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 1);
  CHECK(integrate_pdf(scene, accel, lights, {0, 0, 0}) ==
        doctest::Approx(1.0).epsilon(0.01));
  // Importance-sampled estimate of the environment's integral equals the
  // quadrature of the same integral.
  auto quadrature = 0.0;
  auto n          = 600;
  for (auto j = 0; j < n; j++)
    for (auto i = 0; i < 2 * n; i++)
      quadrature += eval_environment(
          scene, sample_sphere({(i + 0.5f) / (2 * n), (j + 0.5f) / n}))
                        .x;
  quadrature *= 4 * pif / (2.0 * n * n);
  auto rng      = make_rng(5);
  auto estimate = 0.0;
  auto samples  = 200000;
  for (auto k = 0; k < samples; k++) {
    auto direction = sample_lights(
        scene, accel, lights, {0, 0, 0}, rand1f(rng), rand1f(rng), rand2f(rng));
    auto pdf = sample_lights_pdf(scene, accel, lights, {0, 0, 0}, direction);
    INFO(direction.x, " ", direction.y, " ", direction.z, " k ", k);
    REQUIRE(pdf > 0);
    estimate += eval_environment(scene, direction).x / pdf;
  }
  estimate /= samples;
  CHECK(estimate == doctest::Approx(quadrature).epsilon(0.01).scale(0));
}

TEST_CASE("lights: box and sphere light pdfs integrate to 1 from outside") {
  auto scene        = scene_data{};
  auto material     = material_data{};
  material.emission = {5, 5, 5};
  scene.materials.push_back(material);
  auto box = sdf_node{};
  box.type = sdf_type::box;
  box.size = {0.5f, 0.4f, 1e-5f};  // the seed's flat light
  scene.sdfunctions.push_back(emitter(box, {-0.2f, 0.25f, 1.2f}));
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.3f;
  scene.sdfunctions.push_back(emitter(sphere, {1, 1, -1}));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 2);
  for (auto position : {vec3f{0, 0, 0}, vec3f{0.3f, 0.1f, -0.2f}}) {
    CHECK(integrate_pdf(scene, accel, lights, position, 1200) ==
          doctest::Approx(1.0).epsilon(0.02));
  }
  // Samples point at the lights and have a positive pdf.
  auto rng = make_rng(9);
  for (auto k = 0; k < 1000; k++) {
    auto direction = sample_lights(
        scene, accel, lights, {0, 0, 0}, rand1f(rng), rand1f(rng), rand2f(rng));
    CHECK(sample_lights_pdf(scene, accel, lights, {0, 0, 0}, direction) > 0);
  }
}

TEST_CASE(
    "lights: non-rigid or unsupported emitters are left to BSDF sampling") {
  auto scene        = scene_data{};
  auto material     = material_data{};
  material.emission = {5, 5, 5};
  scene.materials.push_back(material);
  auto torus    = sdf_node{};
  torus.type    = sdf_type::torus;
  torus.radius  = 1;
  torus.radius2 = 0.2f;
  scene.sdfunctions.push_back(emitter(torus, {0, 2, 0}));
  auto sphere                 = sdf_node{};
  sphere.type                 = sdf_type::sphere;
  sphere.radius               = 0.3f;
  auto squashed               = emitter(sphere, {1, 1, -1});
  squashed.local_from_world.y = {0, 2, 0};
  scene.sdfunctions.push_back(squashed);
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  CHECK(lights.lights.empty());
  CHECK(sample_lights_pdf(scene, accel, lights, {0, 0, 0}, {0, 1, 0}) == 0);
}

TEST_CASE("lights: picks and pdfs agree for two shape lights") {
  auto scene        = scene_data{};
  auto material     = material_data{};
  material.emission = {5, 5, 5};
  scene.materials.push_back(material);
  auto box = sdf_node{};
  box.type = sdf_type::box;
  box.size = {0.5f, 0.4f, 1e-5f};
  scene.sdfunctions.push_back(emitter(box, {-0.2f, 0.25f, 1.2f}));
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.3f;
  auto center   = vec3f{1, 1, -1};
  scene.sdfunctions.push_back(emitter(sphere, center));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 2);
  auto expected  = 0.5f;  // lights are picked uniformly
  auto rng       = make_rng(21);
  auto samples   = 100000;
  auto to_sphere = 0;
  auto cone      = std::sqrt(1 - 0.09f / dot(center, center));
  // E[1 / pdf] over light samples is the solid angle the lights cover.
  auto inverse_pdf = 0.0;
  auto missed      = 0;
  for (auto k = 0; k < samples; k++) {
    auto direction = sample_lights(
        scene, accel, lights, {0, 0, 0}, rand1f(rng), rand1f(rng), rand2f(rng));
    if (dot(direction, normalize(center)) >= cone) to_sphere++;
    auto pdf = sample_lights_pdf(scene, accel, lights, {0, 0, 0}, direction);
    // A point on the flat box's 10-micron rim can round to a ray that misses
    // the box; such samples are rare and weigh nothing in a render.
    if (pdf > 0)
      inverse_pdf += 1 / pdf;
    else
      missed++;
  }
  CHECK(missed < samples / 1000);
  CHECK((double)to_sphere / samples ==
        doctest::Approx(expected).epsilon(0.01).scale(0));
  auto covered = 0.0;
  auto n       = 1200;
  for (auto j = 0; j < n; j++)
    for (auto i = 0; i < 2 * n; i++)
      if (sample_lights_pdf(scene, accel, lights, {0, 0, 0},
              sample_sphere({(i + 0.5f) / (2 * n), (j + 0.5f) / n})) > 0)
        covered += 4 * pif / (2.0 * n * n);
  CHECK(
      inverse_pdf / samples == doctest::Approx(covered).epsilon(0.02).scale(0));
}

TEST_CASE("lights: large environments are sampled by cells of texels") {
  // 1030x500 texels need 2x2 cells (515x250), the last ones partial.
  auto  scene = environment_scene();
  auto& image = scene.textures[0].image;
  image       = make_image(1030, 500);
  for (auto j = 0; j < image.height; j++)
    for (auto i = 0; i < image.width; i++)
      pixel(image, i, j) = {0.1f + (i % 7) * 0.1f, 0.2f, 0.3f, 1};
  pixel(image, 1029, 499) = {80, 80, 80, 1};
  auto accel              = make_accel(scene, accel_type::bvh, {});
  auto lights             = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 1);
  CHECK(lights.lights[0].width == 515);
  CHECK(lights.lights[0].height == 250);
  CHECK(integrate_pdf(scene, accel, lights, {0, 0, 0}, 1000) ==
        doctest::Approx(1.0).epsilon(0.01));
  auto rng = make_rng(8);
  for (auto k = 0; k < 10000; k++) {
    auto direction = sample_lights(
        scene, accel, lights, {0, 0, 0}, rand1f(rng), rand1f(rng), rand2f(rng));
    REQUIRE(sample_lights_pdf(scene, accel, lights, {0, 0, 0}, direction) > 0);
  }
}

// E[(L / pdf)^2] / E[L / pdf]^2 of the light samples of a one-light scene,
// from `samples` directions: 1 when the pdf follows the radiance exactly.
static double light_second_moment(
    const scene_data& scene, int samples, uint64_t seed) {
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  auto rng    = make_rng(seed);
  auto sum = 0.0, squares = 0.0;
  for (auto k = 0; k < samples; k++) {
    auto direction = sample_lights(
        scene, accel, lights, {0, 0, 0}, rand1f(rng), rand1f(rng), rand2f(rng));
    auto pdf = sample_lights_pdf(scene, accel, lights, {0, 0, 0}, direction);
    auto value =
        pdf > 0 ? max(eval_environment(scene, lights, direction)) / pdf : 0.0f;
    sum += value;
    squares += (double)value * value;
  }
  return squares * samples / (sum * sum);
}

TEST_CASE("lights: smooth environments get coarse cells, small suns fine") {
  // A smooth sky of 2048x1024 texels: the cap would give 512x256 cells, but
  // far coarser ones sample it as well.
  auto  scene = environment_scene();
  auto& image = scene.textures[0].image;
  image       = make_image(2048, 1024);
  for (auto j = 0; j < image.height; j++)
    for (auto i = 0; i < image.width; i++)
      pixel(image, i, j) = {1 + 0.5f * std::sin(i * 2 * pif / image.width),
          0.5f + (float)j / image.height, 0.5f, 1};
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 1);
  CHECK(lights.lights[0].width < 512);
  CHECK(lights.lights[0].width == 2 * lights.lights[0].height);
  CHECK(integrate_pdf(scene, accel, lights, {0, 0, 0}, 1000) ==
        doctest::Approx(1.0).epsilon(0.01));
  // Coarse cells still follow the radiance: within the 1% budget (and the
  // bilinear texels' spread), Monte Carlo noise aside.
  CHECK(light_second_moment(scene, 200000, 5) < 1.02);

  // A sun of one texel on a dim sky keeps the finest cells the image has.
  image = make_image(256, 128);
  for (auto j = 0; j < image.height; j++)
    for (auto i = 0; i < image.width; i++)
      pixel(image, i, j) = {0.1f, 0.1f, 0.1f, 1};
  pixel(image, 77, 40) = {5000, 5000, 4000, 1};
  accel                = make_accel(scene, accel_type::bvh, {});
  lights               = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 1);
  CHECK(lights.lights[0].width == 256);
  CHECK(lights.lights[0].height == 128);
  CHECK(integrate_pdf(scene, accel, lights, {0, 0, 0}, 1000) ==
        doctest::Approx(1.0).epsilon(0.01));
}

TEST_CASE("lights: environments with kept inverse frames equal the scene's") {
  // A textured rotated environment, a constant one and a dark one (not a
  // light, still summed): the same radiance to the bit as inverting frames.
  auto scene        = environment_scene();
  auto constant     = environment_data{};
  constant.emission = {0.5f, 0.25f, 2};
  constant.frame    = {{1, 0, 0}, {0, 0, 1}, {0, -1, 0}, {1, 2, 3}};
  auto dark         = scene.environments[0];
  dark.emission     = {0, 0, 0};
  dark.frame        = {{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}, {0, 0, 0}};
  scene.environments.push_back(constant);
  scene.environments.push_back(dark);
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  CHECK(lights.lights.size() == 2);
  REQUIRE(lights.env_from_world.size() == 3);
  auto rng = make_rng(9);
  for (auto k = 0; k < 10000; k++) {
    auto direction = sample_sphere(rand2f(rng));
    auto expected  = eval_environment(scene, direction);
    CHECK(eval_environment(scene, lights, direction) == expected);
    // Lights without frames (not made for this scene) fall back.
    CHECK(eval_environment(scene, lights_data{}, direction) == expected);
  }
}
