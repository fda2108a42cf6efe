// Tests for light sampling: pdfs integrate to 1 over the sphere of
// directions and agree with the directions sample_lights() produces; every
// kind of emitter is a light whose samples estimate the same integral as
// BSDF-like samples; the light tree picks emitters with the probabilities
// it reports.

#include "lights.h"

#include <doctest/doctest.h>

#include <cmath>

#include "../math/random.h"
#include "../math/sampling.h"
#include "../sdf/sdf_grid.h"

using namespace implicit;

namespace {

light_context at_point(vec3f position, vec3f normal = {0, 0, 0},
    light_sampler_type sampler = light_sampler_type::bvh) {
  return {position, normal, sampler};
}

// Integral of sample_lights_pdf over all directions, by stratified
// quadrature in (cos theta, phi).
double integrate_pdf(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, int n = 800) {
  auto sum = 0.0;
  for (auto j = 0; j < n; j++) {
    for (auto i = 0; i < 2 * n; i++) {
      auto u = (i + 0.5f) / (2 * n), v = (j + 0.5f) / n;
      auto direction = sample_sphere({u, v});
      sum += sample_lights_pdf(scene, accel, lights, context, direction);
    }
  }
  return sum * (4 * pif) / (2.0 * n * n);
}

// A light sample from independent random numbers (drawn in order).
light_sample draw_light(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const light_context& context, rng_state& rng) {
  auto rl  = rand1f(rng);
  auto rel = rand1f(rng);
  auto ruv = rand2f(rng);
  return sample_lights(scene, accel, lights, context, rl, rel, ruv);
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

sdf_function_data emitter(const sdf_program& program, vec3f origin) {
  auto function             = sdf_function_data{};
  function.program          = program;
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -origin};
  function.material         = 0;
  return function;
}

sdf_function_data emitter(sdf_node node, vec3f origin) {
  return emitter(make_primitive_program(node), origin);
}

sdf_node make_node(sdf_type type) {
  auto node = sdf_node{};
  node.type = type;
  return node;
}

// A scene whose only material emits.
scene_data emissive_scene() {
  auto scene        = scene_data{};
  auto material     = material_data{};
  material.emission = {5, 5, 5};
  scene.materials.push_back(material);
  return scene;
}

}  // namespace

TEST_CASE("lights: environment pdf integrates to 1 and matches its samples") {
  auto scene  = environment_scene();
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 1);
  auto context = at_point({0, 0, 0});
  CHECK(integrate_pdf(scene, accel, lights, context) ==
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
    auto sample = draw_light(scene, accel, lights, context, rng);
    REQUIRE(sample.pdf > 0);
    // The pdf a sample reports is the one BSDF samples will see.
    CHECK(sample.pdf ==
          sample_lights_pdf(scene, accel, lights, context, sample.direction));
    estimate += eval_environment(scene, sample.direction).x / sample.pdf;
  }
  estimate /= samples;
  CHECK(estimate == doctest::Approx(quadrature).epsilon(0.01).scale(0));
}

TEST_CASE("lights: box and sphere light pdfs integrate to 1") {
  auto scene = emissive_scene();
  auto box   = make_node(sdf_type::box);
  box.size   = {0.5f, 0.4f, 1e-5f};  // the seed's flat light
  scene.sdfunctions.push_back(emitter(box, {-0.2f, 0.25f, 1.2f}));
  box.size = {0.3f, 0.2f, 0.4f};  // a solid box
  scene.sdfunctions.push_back(emitter(box, {-1, -0.5f, -0.8f}));
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 0.3f;
  scene.sdfunctions.push_back(emitter(sphere, {1, 1, -1}));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 3);
  CHECK(lights.lights[0].shape == light_shape::box);
  CHECK(lights.lights[1].shape == light_shape::box);
  CHECK(lights.lights[2].shape == light_shape::cone);
  // From outside all, near the flat box's face and the solid box's top
  // (sampled in solid angle), and from inside the solid box and the sphere.
  for (auto position : {vec3f{0, 0, 0}, vec3f{0.3f, 0.1f, -0.2f},
           vec3f{0.05f, 0.45f, 1.05f}, vec3f{-0.85f, -0.2f, -0.6f},
           vec3f{-0.9f, -0.4f, -0.7f}, vec3f{1.1f, 0.9f, -1}}) {
    for (auto sampler : {light_sampler_type::bvh, light_sampler_type::power,
             light_sampler_type::uniform}) {
      auto context = at_point(position, {0, 0, 0}, sampler);
      INFO("position ", position.x, " ", position.y, " ", position.z,
          " sampler ", light_sampler_type_names[(int)sampler]);
      CHECK(integrate_pdf(scene, accel, lights, context, 1200) ==
            doctest::Approx(1.0).epsilon(0.02));
      // A sample's pdf (computed from the point sampled) is the one BSDF
      // samples see along its direction.
      auto rng = make_rng(31);
      for (auto k = 0; k < 1000; k++) {
        auto sample = draw_light(scene, accel, lights, context, rng);
        REQUIRE(sample.light >= 0);
        CHECK(sample.pdf ==
              doctest::Approx(sample_light_pdf(scene, accel, lights, context,
                                  sample.light, sample.direction))
                  .epsilon(1e-3));
      }
    }
  }
}

TEST_CASE("lights: every bounded emitter is a light, planes are not") {
  auto scene    = emissive_scene();
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 1;
  torus.radius2 = 0.2f;
  scene.sdfunctions.push_back(emitter(torus, {0, 2, 0}));
  auto sphere                 = make_node(sdf_type::sphere);
  sphere.radius               = 0.3f;
  auto squashed               = emitter(sphere, {1, 1, -1});
  squashed.local_from_world.y = {0, 2, 0};
  scene.sdfunctions.push_back(squashed);
  scene.sdfunctions.push_back(emitter(make_node(sdf_type::plane), {0, -1, 0}));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 2);
  CHECK(lights.object_lights == std::vector<int>{0, 1, invalidid});
  // The torus's sphere is shrunk to its surface (radius 1.2, not the box's
  // half diagonal, 1.71).
  CHECK(lights.lights[0].radius == doctest::Approx(1.2f).epsilon(0.02));
  CHECK(lights.lights[0].radius >= 1.2f);
  // The ellipsoid is sampled by a cone too.
  CHECK(lights.lights[1].shape == light_shape::cone);
  CHECK(sample_lights_pdf(scene, accel, lights, at_point({0, 0, 0}),
            normalize(vec3f{0, 2, 1})) > 0);
}

TEST_CASE("lights: the survey measures areas and normals") {
  // Power = pi * area * emission: a sphere of radius 0.3 (area 1.131), a
  // torus (4 pi^2 R r = 7.90), a flat box (2 * 0.2, whose normals are +-y).
  auto scene    = emissive_scene();
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 0.3f;
  scene.sdfunctions.push_back(emitter(sphere, {1, 1, -1}));
  auto torus    = make_node(sdf_type::torus);
  torus.radius  = 1;
  torus.radius2 = 0.2f;
  scene.sdfunctions.push_back(emitter(torus, {0, 2, 0}));
  auto box = make_node(sdf_type::box);
  box.size = {0.5f, 1e-5f, 0.4f};
  scene.sdfunctions.push_back(emitter(box, {-2, 1, 0}));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 3);
  auto area = [&](int k) { return lights.lights[k].bounds.power / (5 * pif); };
  CHECK(area(0) == doctest::Approx(4 * pif * 0.09f).epsilon(0.1));
  CHECK(area(1) == doctest::Approx(4 * pif * pif * 0.2f).epsilon(0.1));
  CHECK(area(2) == doctest::Approx(0.4f).epsilon(0.1));
  CHECK(lights.lights[0].bounds.cos_spread == -1);  // a sphere: all
  auto& flat = lights.lights[2].bounds;
  CHECK(flat.two_sided);
  CHECK(std::abs(flat.axis.y) > 0.99f);
  CHECK(flat.cos_spread > 0.99f);
}

TEST_CASE("lights: picks and pdfs agree for two shape lights") {
  auto scene = emissive_scene();
  auto box   = make_node(sdf_type::box);
  box.size   = {0.5f, 0.4f, 1e-5f};
  scene.sdfunctions.push_back(emitter(box, {-0.2f, 0.25f, 1.2f}));
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 0.3f;
  auto center   = vec3f{1, 1, -1};
  scene.sdfunctions.push_back(emitter(sphere, center));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 2);
  auto context   = at_point({0, 0, 0}, {0, 0, 0}, light_sampler_type::uniform);
  auto expected  = 0.5f;  // lights are picked uniformly
  auto rng       = make_rng(21);
  auto samples   = 100000;
  auto to_sphere = 0;
  // E[1 / pdf] over light samples is the solid angle the lights cover.
  auto inverse_pdf = 0.0;
  for (auto k = 0; k < samples; k++) {
    auto sample = draw_light(scene, accel, lights, context, rng);
    REQUIRE(sample.pdf > 0);
    if (sample.light == 1) to_sphere++;
    inverse_pdf += 1 / sample.pdf;
  }
  CHECK((double)to_sphere / samples ==
        doctest::Approx(expected).epsilon(0.01).scale(0));
  auto covered = 0.0;
  auto n       = 1200;
  for (auto j = 0; j < n; j++)
    for (auto i = 0; i < 2 * n; i++)
      if (sample_lights_pdf(scene, accel, lights, context,
              sample_sphere({(i + 0.5f) / (2 * n), (j + 0.5f) / n})) > 0)
        covered += 4 * pif / (2.0 * n * n);
  CHECK(
      inverse_pdf / samples == doctest::Approx(covered).epsilon(0.02).scale(0));
}

namespace {

// Mean and variance of the mean of a sum of samples.
struct estimate {
  double sum = 0, squares = 0;
  int    count = 0;
  void   add(double x) {
      sum += x;
      squares += x * x;
      count++;
  }
  double mean() const { return sum / count; }
  double variance() const {
    auto m = mean();
    return (squares / count - m * m) / count;
  }
};

// The projected solid angle that each light covers from `position` above a
// surface of normal `normal`: the integral of max(0, n . w) over the
// directions whose first hit is the light's object. Estimated by light
// samples (hit * cos / pdf, zero for the other lights' samples) and by
// cosine-weighted directions (pi * hit), as a BSDF would sample; with
// `gain`, light samples must also have less variance per sample.
void check_light_estimate(
    const scene_data& scene, vec3f position, vec3f normal, bool gain = true) {
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.shapes >= 1);
  auto context     = at_point(position, normal);
  auto first_light = [&](vec3f direction) {
    auto isec = intersect_scene(accel, march_params{}, {position, direction});
    return isec.hit ? lights.object_lights[isec.object] : invalidid;
  };
  auto sampled    = std::vector<estimate>(lights.shapes);
  auto reference  = std::vector<estimate>(lights.shapes);
  auto rng        = make_rng(77);
  auto light_runs = 40000, cosine_runs = 200000;
  for (auto k = 0; k < light_runs; k++) {
    auto sample = draw_light(scene, accel, lights, context, rng);
    auto hit    = sample.light >= 0 ? first_light(sample.direction) : -1;
    for (auto light = 0; light < lights.shapes; light++) {
      auto value = 0.0;
      if (sample.light == light && hit == light)
        value = std::max(0.0f, dot(normal, sample.direction)) / sample.pdf;
      sampled[light].add(value);
    }
  }
  for (auto k = 0; k < cosine_runs; k++) {
    auto hit = first_light(sample_hemisphere_cos(normal, rand2f(rng)));
    for (auto light = 0; light < lights.shapes; light++)
      reference[light].add(hit == light ? pif : 0.0);
  }
  for (auto light = 0; light < lights.shapes; light++) {
    auto& l     = sampled[light];
    auto& r     = reference[light];
    auto  error = std::sqrt(l.variance() + r.variance());
    INFO("light ", light, " object ", lights.lights[light].object,
        " light samples ", l.mean(), " +- ", std::sqrt(l.variance()),
        " cosine samples ", r.mean(), " +- ", std::sqrt(r.variance()));
    CHECK(r.mean() > 0.005);
    // Unbiased: within 4 standard errors of each other.
    CHECK(std::abs(l.mean() - r.mean()) < 4 * error);
  }
  // And worth it: the estimate of all lights together has less variance per
  // sample than cosine samples.
  if (gain) {
    auto total_light = estimate{}, total_cosine = estimate{};
    for (auto& e : sampled) {
      total_light.sum += e.sum;
      total_light.squares += e.squares;
    }
    total_light.count = light_runs;
    for (auto& e : reference) {
      total_cosine.sum += e.sum;
      total_cosine.squares += e.squares;
    }
    total_cosine.count = cosine_runs;
    CHECK(total_light.variance() * light_runs <
          total_cosine.variance() * cosine_runs);
  }
}

}  // namespace

TEST_CASE("lights: samples of every kind of emitter are unbiased") {
  auto above = vec3f{0, 1, 0};
  SUBCASE("sphere, solid box, flat box") {
    auto scene    = emissive_scene();
    auto sphere   = make_node(sdf_type::sphere);
    sphere.radius = 0.3f;
    scene.sdfunctions.push_back(emitter(sphere, {0.6f, 1, -0.4f}));
    auto box = make_node(sdf_type::box);
    box.size = {0.4f, 0.2f, 0.3f};
    scene.sdfunctions.push_back(emitter(box, {-0.8f, 0.7f, 0.2f}));
    box.size = {0.5f, 1e-5f, 0.4f};
    scene.sdfunctions.push_back(emitter(box, {-0.25f, 1.5f, -0.2f}));
    check_light_estimate(scene, {0, 0, 0}, above);
  }
  SUBCASE("boxes up close, sampled in solid angle") {
    // A flat lamp 0.15 above the point (about 2 sr) and a solid box's
    // face 0.1 beside it: both look larger than the solid-angle threshold.
    auto scene = emissive_scene();
    auto box   = make_node(sdf_type::box);
    box.size   = {0.5f, 1e-5f, 0.4f};
    scene.sdfunctions.push_back(emitter(box, {-0.3f, 0.15f, -0.15f}));
    box.size = {0.3f, 0.4f, 0.2f};
    scene.sdfunctions.push_back(emitter(box, {0.1f, -0.1f, -0.05f}));
    // Lights this large are found as well by cosine samples: no gain asked.
    check_light_estimate(scene, {0, 0, 0}, above, false);
  }
  SUBCASE("rotated and scaled shapes") {
    auto scene    = emissive_scene();
    auto torus    = make_node(sdf_type::torus);
    torus.radius  = 0.5f;
    torus.radius2 = 0.1f;
    auto tilted   = emitter(torus, {0.3f, 1.2f, 0});
    auto c = std::cos(0.6f), s = std::sin(0.6f);
    tilted.local_from_world =
        frame3f{{1, 0, 0}, {0, c, s}, {0, -s, c}, {0, 0, 0}} *
        tilted.local_from_world;
    scene.sdfunctions.push_back(tilted);
    auto capsule                 = make_node(sdf_type::capsule);
    capsule.height               = 0.3f;
    capsule.radius               = 0.1f;
    auto stretched               = emitter(capsule, {-0.7f, 0.8f, 0.3f});
    stretched.local_from_world.x = {0.5f, 0, 0};  // twice as wide
    scene.sdfunctions.push_back(stretched);
    auto box                    = make_node(sdf_type::box);
    box.size                    = {0.3f, 0.2f, 0.4f};
    auto squashed               = emitter(box, {0.2f, 0.6f, -0.9f});
    squashed.local_from_world.y = {0, 3, 0};  // not rigid: a cone light
    scene.sdfunctions.push_back(squashed);
    check_light_estimate(scene, {0, 0, 0}, above);
  }
  SUBCASE("CSG: a hard union (one light per part), smooth and cut shapes") {
    auto scene    = emissive_scene();
    auto lamp     = sdf_program{};
    auto sphere   = make_node(sdf_type::sphere);
    sphere.radius = 0.2f;
    auto stem     = make_node(sdf_type::capsule);
    stem.height   = 0.3f;
    stem.radius   = 0.05f;
    auto bulb     = add_node(lamp, sphere);
    auto moved    = add_transform(
           lamp, bulb, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -0.4f, 0}});
    auto rod  = add_node(lamp, stem);
    auto join = make_node(sdf_type::op_union);
    fold_sdf_operands(lamp, {moved, rod}, join);
    scene.sdfunctions.push_back(emitter(lamp, {0.2f, 0.9f, 0.1f}));
    auto blob    = sdf_program{};
    auto a       = add_node(blob, sphere);
    auto b       = add_transform(blob, add_node(blob, sphere),
              {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.25f, 0, 0}});
    auto smooth  = make_node(sdf_type::op_smooth_union);
    smooth.blend = 0.1f;
    fold_sdf_operands(blob, {a, b}, smooth);
    scene.sdfunctions.push_back(emitter(blob, {-0.8f, 0.7f, 0}));
    auto cut      = sdf_program{};
    auto cube     = make_node(sdf_type::box);
    cube.size     = {0.4f, 0.4f, 0.4f};
    auto solid    = add_node(cut, cube);
    sphere.radius = 0.25f;
    auto hole     = add_node(cut, sphere);
    auto minus    = make_node(sdf_type::op_subtraction);
    fold_sdf_operands(cut, {solid, hole}, minus);
    scene.sdfunctions.push_back(emitter(cut, {0.5f, 0.5f, -1}));
    check_light_estimate(scene, {0, 0, 0}, above);
  }
  SUBCASE("grid and user function") {
    auto scene    = emissive_scene();
    auto torus    = make_node(sdf_type::torus);
    torus.radius  = 0.3f;
    torus.radius2 = 0.1f;
    auto volume   = volume_data{};
    volume.grid   = std::make_shared<const grid_data>(
        bake_grid(make_primitive_program(torus),
              {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.5f, -0.5f, -0.5f}},
              {{0, 0, 0}, {1, 1, 1}}, 0.05f));
    scene.volumes.push_back(volume);
    auto instance             = vol_instance_data{};
    instance.volume           = 0;
    instance.material         = 0;
    instance.local_from_world = {
        {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.2f, -0.6f, 0.1f}};
    scene.vol_instances.push_back(instance);
    auto user = user_sdf_data{};
    user.eval = [](vec3f p) {
      return length(vec2f{length(vec2f{p.x, p.z}) - 0.3f, p.y}) - 0.08f;
    };
    user.bounds           = {{-0.4f, -0.1f, -0.4f}, {0.4f, 0.1f, 0.4f}};
    user.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.7f, -1, 0}};
    user.material         = 0;
    scene.user_sdfs.push_back(user);
    check_light_estimate(scene, {0, 0, 0}, above);
  }
  SUBCASE("from inside a cone light's sphere") {
    // Inside the torus's hole every direction may hit it.
    auto scene    = emissive_scene();
    auto torus    = make_node(sdf_type::torus);
    torus.radius  = 0.5f;
    torus.radius2 = 0.15f;
    scene.sdfunctions.push_back(emitter(torus, {0, 0.1f, 0}));
    check_light_estimate(scene, {0, 0, 0}, above, false);
  }
}

TEST_CASE("lights: a receiver's normal hides the lights behind it") {
  // A flat light facing down over a floor point, one below it: seen from the
  // floor's upper side, only the first has a chance.
  auto scene = emissive_scene();
  auto box   = make_node(sdf_type::box);
  box.size   = {0.5f, 1e-5f, 0.5f};
  scene.sdfunctions.push_back(emitter(box, {-0.25f, 1, -0.25f}));
  scene.sdfunctions.push_back(emitter(box, {-0.25f, -1, -0.25f}));
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.shapes == 2);
  auto up = at_point({0, 0, 0}, {0, 1, 0});
  CHECK(pick_light_probability(lights, up, 0) == 1);
  CHECK(pick_light_probability(lights, up, 1) == 0);
  // Without a normal both have a chance (about even: the same size and
  // distance, powers surveyed by different lines).
  auto both = at_point({0, 0, 0});
  CHECK(pick_light_probability(lights, both, 0) ==
        doctest::Approx(0.5f).epsilon(0.1));
}

TEST_CASE("lights: pick probabilities sum to 1 with environments") {
  auto scene        = environment_scene();
  auto material     = material_data{};
  material.emission = {2, 2, 2};
  scene.materials.push_back(material);
  auto sphere   = make_node(sdf_type::sphere);
  sphere.radius = 0.2f;
  for (auto k = 0; k < 5; k++)
    scene.sdfunctions.push_back(emitter(sphere, {k * 0.7f - 1.4f, 1, 0}));
  auto constant     = environment_data{};
  constant.emission = {0.3f, 0.3f, 0.3f};
  scene.environments.push_back(constant);
  auto accel  = make_accel(scene, accel_type::bvh, {});
  auto lights = make_lights(scene, accel);
  REQUIRE(lights.lights.size() == 7);
  for (auto sampler : {light_sampler_type::bvh, light_sampler_type::power,
           light_sampler_type::uniform}) {
    auto context = at_point({0.3f, 0, 0.2f}, {0, 1, 0}, sampler);
    auto total   = 0.0;
    for (auto k = 0; k < 7; k++)
      total += pick_light_probability(lights, context, k);
    CHECK(total == doctest::Approx(1.0).epsilon(1e-5));
    if (sampler != light_sampler_type::uniform) {
      // One share for the textured environment, one for the shapes; the
      // constant one is left to BSDF samples and never picked.
      CHECK(pick_light_probability(lights, context, 5) ==
            doctest::Approx(1 / 2.0f));
      CHECK(pick_light_probability(lights, context, 6) == 0);
      auto rng = make_rng(9);
      for (auto s = 0; s < 2000; s++)
        CHECK(draw_light(scene, accel, lights, context, rng).light != 6);
    }
    // The mixture pdf is the sum of the lights' pdfs.
    auto rng = make_rng(4);
    for (auto s = 0; s < 200; s++) {
      auto direction = sample_sphere(rand2f(rng));
      auto sum       = 0.0f;
      for (auto k = 0; k < 7; k++)
        sum += sample_light_pdf(scene, accel, lights, context, k, direction);
      CHECK(sample_lights_pdf(scene, accel, lights, context, direction) ==
            doctest::Approx(sum).epsilon(1e-4));
    }
  }
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
  auto context = at_point({0, 0, 0});
  CHECK(integrate_pdf(scene, accel, lights, context, 1000) ==
        doctest::Approx(1.0).epsilon(0.01));
  auto rng = make_rng(8);
  for (auto k = 0; k < 10000; k++)
    REQUIRE(draw_light(scene, accel, lights, context, rng).pdf > 0);
}

// E[(L / pdf)^2] / E[L / pdf]^2 of the light samples of a one-light scene,
// from `samples` directions: 1 when the pdf follows the radiance exactly.
static double light_second_moment(
    const scene_data& scene, int samples, uint64_t seed) {
  auto accel   = make_accel(scene, accel_type::bvh, {});
  auto lights  = make_lights(scene, accel);
  auto rng     = make_rng(seed);
  auto context = at_point({0, 0, 0});
  auto sum = 0.0, squares = 0.0;
  for (auto k = 0; k < samples; k++) {
    auto sample = draw_light(scene, accel, lights, context, rng);
    auto value  = sample.pdf > 0
                      ? max(eval_environment(scene, lights, sample.direction)) /
                           sample.pdf
                      : 0.0f;
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
  auto context = at_point({0, 0, 0});
  CHECK(integrate_pdf(scene, accel, lights, context, 1000) ==
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
  CHECK(integrate_pdf(scene, accel, lights, context, 1000) ==
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
