// Tests of the per-pixel data of the render core (render_buffer): AOV
// values against closed forms (the albedo of a matte wall is its colour, the
// normal of a sphere points from its centre, depth is the distance along the
// camera ray), albedo and normal through glass, and the variance layer
// against the variance of the samples computed apart.

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "scene/scene_io.h"
#include "test_commands.h"
#include "trace/render.h"
#include "util/error.h"

using namespace implicit;

namespace {

// A unit sphere at the origin (matte 0.2, 0.4, 0.6) before a matte wall
// (0.7, 0.1, 0.3) whose front face is at z = -2 (the seed's frames place a
// box at [0, whd] - origin), seen by a camera at z = 4 looking down -z, under a
// sky; `glass`: a thin transparent slab whose front face is at z = 2.01, in
// front of the sphere's centre.
std::string aov_scene(bool glass) {
  auto text = std::string{R"({
    "asset": {"version": "4.2"},
    "cameras": [{"name": "c", "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,4], "aspect": 1,
                 "focus": 4}],
    "environments": [{"name": "sky", "emission": [0.5, 0.5, 0.5]}],
    "materials": [{"name": "ball", "color": [0.2, 0.4, 0.6]},
                  {"name": "wall", "color": [0.7, 0.1, 0.3]},
                  {"name": "glass", "type": "transparent", "color": [1, 1, 1]}],
    "sdfunctions": [
      {"name": "ball", "type": "sphere", "radius": 1, "material": 0,
       "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,0]},
      {"name": "wall", "type": "box", "whd": [12, 12, 0.01], "material": 1,
       "frame": [1,0,0, 0,1,0, 0,0,1, 6,6,2.01]})"};
  if (glass)
    text += R"(,
      {"name": "glass", "type": "box", "whd": [0.3, 0.3, 0.02], "material": 2,
       "frame": [1,0,0, 0,1,0, 0,0,1, 0.15,0.15,-1.99]})";
  return text + "]}";
}

struct aov_render {
  std::unique_ptr<const render_context> context = {};
  trace_params                          params  = {};
  render_state                          state   = {};
};

aov_render render_aovs(const std::string& name, bool glass, int samples) {
  auto dir  = implicit_test::test_dir("aov_" + name);
  auto path = (dir / "scene.json").string();
  std::ofstream(path) << aov_scene(glass);
  auto result              = aov_render{};
  result.params.resolution = 33;  // odd: a pixel on the axis
  result.params.samples    = samples;
  result.params.aovs       = (1 << (int)aov_type_names.size()) - 1;
  result.context = make_render_context(load_scene(path), result.params);
  auto warnings  = std::vector<std::string>{};
  result.params = resolve_params(*result.context, result.params, "c", warnings);
  result.state  = make_render_state(*result.context, result.params);
  REQUIRE(render_step(*result.context, result.state, samples));
  return result;
}

vec3f layer_at(const image_layer& layer, int width, int i, int j) {
  auto  channels = layer.channels.size();
  auto* v        = layer.values.data() + ((size_t)j * width + i) * channels;
  return channels == 1 ? vec3f{v[0], 0, 0} : vec3f{v[0], v[1], v[2]};
}

}  // namespace

TEST_CASE("aov: albedo, normal, depth and position against closed forms") {
  // One sample per pixel: each pixel's values are one path's, so the normal
  // is exactly the sphere's at the position.
  auto  render  = render_aovs("closed", false, 1);
  auto& buffer  = render.state.buffer;
  auto  width   = render.state.width;
  auto  albedo  = average_layer(buffer, aov_type::albedo);
  auto  normal  = average_layer(buffer, aov_type::normal);
  auto  depth   = average_layer(buffer, aov_type::depth);
  auto  where   = average_layer(buffer, aov_type::position);
  auto  camera  = vec3f{0, 0, 4};
  auto  spheres = 0, walls = 0;
  CHECK(albedo.channels == std::vector<std::string>{"R", "G", "B"});
  CHECK(normal.channels == std::vector<std::string>{"X", "Y", "Z"});
  CHECK(depth.channels == std::vector<std::string>{"Z"});
  for (auto j = 0; j < render.state.height; j++) {
    for (auto i = 0; i < width; i++) {
      INFO("pixel ", i, " ", j);
      auto p = layer_at(where, width, i, j);
      auto d = layer_at(depth, width, i, j).x;
      auto n = layer_at(normal, width, i, j);
      auto a = layer_at(albedo, width, i, j);
      REQUIRE(d > 0);  // the wall fills the view
      CHECK(d == doctest::Approx(length(p - camera)).epsilon(1e-5));
      if (std::abs(length(p) - 1) < 2e-3f) {
        spheres++;
        CHECK(length(n - p) < 2e-3f);
        CHECK(a.x == doctest::Approx(0.2f));
        CHECK(a.y == doctest::Approx(0.4f));
        CHECK(a.z == doctest::Approx(0.6f));
      } else {
        walls++;
        CHECK(p.z == doctest::Approx(-2).epsilon(1e-4));
        CHECK(length(n - vec3f{0, 0, 1}) < 1e-3f);
        CHECK(a.x == doctest::Approx(0.7f));
        CHECK(a.y == doctest::Approx(0.1f));
        CHECK(a.z == doctest::Approx(0.3f));
      }
    }
  }
  CHECK(spheres > 200);
  CHECK(walls > 200);
  // On the axis, averaged over samples: depth 3 to the sphere's front.
  auto averaged = render_aovs("axis", false, 16);
  auto axis     = average_layer(averaged.state.buffer, aov_type::depth);
  CHECK(layer_at(axis, width, 16, 16).x == doctest::Approx(3).epsilon(1e-3));
}

TEST_CASE("aov: albedo and normal through glass, position and depth at it") {
  auto  render = render_aovs("glass", true, 64);
  auto& buffer = render.state.buffer;
  auto  width  = render.state.width;
  auto  a = layer_at(average_layer(buffer, aov_type::albedo), width, 16, 16);
  auto  n = layer_at(average_layer(buffer, aov_type::normal), width, 16, 16);
  auto  d = layer_at(average_layer(buffer, aov_type::depth), width, 16, 16).x;
  // The slab reflects a few percent of the paths to the sky (albedo 0
  // there); the rest reach the sphere.
  CHECK(a.x > 0.8f * 0.2f);
  CHECK(a.x <= 0.2f + 1e-6f);
  CHECK(a.y / a.x == doctest::Approx(2).epsilon(1e-4));
  CHECK(a.z / a.x == doctest::Approx(3).epsilon(1e-4));
  CHECK(length(normalize(n) - vec3f{0, 0, 1}) < 0.02f);
  CHECK(d == doctest::Approx(4 - 2.01f).epsilon(1e-3));
}

TEST_CASE("aov: variance of the mean and half sums from the samples") {
  auto  render  = render_aovs("variance", false, 9);
  auto& state   = render.state;
  auto& context = *render.context;
  auto  size    = vec2i{state.width, state.height};
  auto  layer   = average_layer(state.buffer, aov_type::variance);
  for (auto [i, j] : {vec2i{16, 16}, vec2i{3, 5}, vec2i{30, 20}}) {
    INFO("pixel ", i, " ", j);
    auto   idx    = (size_t)j * size.x + i;
    auto   rng    = make_pixel_rng(render.params.seed, idx);
    auto   evals  = int64_t{0};
    double sum[3] = {}, squares[3] = {}, evens[3] = {};
    auto   n = render.params.samples;
    for (auto s = 0; s < n; s++) {
      auto c = trace_sample(context.scene, context.accel, context.lights,
          state.camera, render.params, {i, j}, size, s, rng, evals)
                   .color;
      for (auto k = 0; k < 3; k++) {
        auto v = (double)(&c.x)[k];
        sum[k] += v, squares[k] += v * v;
        if (s % 2 == 0) evens[k] += v;
      }
    }
    auto v = layer_at(layer, size.x, i, j);
    for (auto k = 0; k < 3; k++) {
      auto expected = (squares[k] - sum[k] * sum[k] / n) / (n - 1) / n;
      CHECK(std::abs((&v.x)[k] - expected) <= 1e-3 * expected + 1e-9);
      CHECK((&state.buffer.evens[idx].x)[k] ==
            doctest::Approx(evens[k]).epsilon(1e-5));
    }
    CHECK(state.buffer.counts[idx] == n);
  }
  // A layer the buffer does not keep is an error.
  auto bare = make_render_buffer({0, 2, 0, 2}, 2, 1);
  CHECK_THROWS_AS(average_layer(bare, aov_type::albedo), io_error);
}
