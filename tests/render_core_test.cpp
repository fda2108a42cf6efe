// Tests of the render core (trace/render.h): tiles rendered in any order and
// size, by any number of threads, give the whole image to the byte; the one
// parameter validation; the fallback policies; progress and cancel.

#include <doctest/doctest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "scene/scene_io.h"
#include "test_commands.h"
#include "trace/render.h"
#include "util/error.h"

using namespace implicit;

namespace {

std::unique_ptr<const render_context> example_context(trace_params& params,
    const std::string& name = "sdfunction/sdfunction.json") {
  auto context = make_render_context(
      load_scene(implicit_test::example_scene(name)), params);
  auto warnings = std::vector<std::string>{};
  params        = resolve_params(*context, params, "", warnings);
  return context;
}

bool same_bytes(const image_data& a, const image_data& b) {
  return a.width == b.width && a.height == b.height &&
         std::memcmp(a.pixels.data(), b.pixels.data(),
             a.pixels.size() * sizeof(vec4f)) == 0;
}

// The image assembled from tiles of random sizes, rendered in random order
// and in random sample ranges, each as an MPI rank would: render_pixels()
// into a tile's buffer, the sums copied into the image's, then the shared
// averaging.
render_buffer render_by_tiles(
    const render_context& context, const trace_params& params, uint32_t seed) {
  auto  size   = render_size(context, params);
  auto& camera = context.scene.cameras[params.camera];
  auto  rng    = std::mt19937{seed};
  auto  cut    = [&](int extent) {
    auto cuts = std::vector<int>{0};
    while (cuts.back() < extent)
      cuts.push_back(std::min(extent, cuts.back() + 1 + (int)(rng() % 13)));
    return cuts;
  };
  auto xs = cut(size.x), ys = cut(size.y);
  auto tiles = std::vector<render_rect>{};
  for (size_t j = 0; j + 1 < ys.size(); j++)
    for (size_t i = 0; i + 1 < xs.size(); i++)
      tiles.push_back({xs[i], xs[i + 1], ys[j], ys[j + 1]});
  std::shuffle(tiles.begin(), tiles.end(), rng);
  auto image = make_render_buffer(
      {0, size.x, 0, size.y}, size.x, params.seed, render_layout(params));
  for (auto& tile : tiles) {
    auto buffer =
        make_render_buffer(tile, size.x, params.seed, render_layout(params));
    for (auto s0 = 0; s0 < params.samples;) {
      auto s1 = std::min(params.samples, s0 + 1 + (int)(rng() % 2));
      render_pixels(context, params, camera, tile, s0, s1, buffer);
      s0 = s1;
    }
    copy_pixels(buffer, image);
  }
  return image;
}

// Whether two buffers' images and AOV layers are the same to the byte.
bool same_layers(const render_buffer& a, const render_buffer& b,
    const trace_params& params) {
  auto la = average_layers(a, params), lb = average_layers(b, params);
  if (la.size() != lb.size()) return false;
  for (size_t k = 0; k < la.size(); k++)
    if (la[k].values.size() != lb[k].values.size() ||
        std::memcmp(la[k].values.data(), lb[k].values.data(),
            la[k].values.size() * sizeof(float)) != 0)
      return false;
  return true;
}

}  // namespace

TEST_CASE("render core: tiles in any order and size give the whole image") {
  for (auto sampler : {sampler_type::sobol, sampler_type::random}) {
    for (auto name :
        {"sdfunction/sdfunction.json", "materials/materials.json"}) {
      INFO(name, " sampler ", sampler_type_names[(int)sampler]);
      auto params       = trace_params{};
      params.resolution = 40;
      params.samples    = 3;
      params.sampler    = sampler;
      params.aovs       = (1 << (int)aov_type_names.size()) - 1;  // all
      auto context      = example_context(params, name);

      auto whole = image_data{};
      REQUIRE(render_image(*context, params, whole));
      auto layers = make_render_state(*context, params);
      REQUIRE(render_step(*context, layers, params.samples));
      for (auto seed : {1u, 2u}) {
        auto tiled = render_by_tiles(*context, params, seed);
        CHECK(same_bytes(whole, average_samples(tiled)));
        CHECK(same_layers(layers.buffer, tiled, params));
      }

      // Progressive: one sample per step, or all at once.
      auto state = make_render_state(*context, params);
      for (auto s = 0; s < params.samples; s++)
        CHECK(render_step(*context, state));
      CHECK(same_bytes(whole, get_image(state)));
      auto batch = make_render_state(*context, params);
      CHECK(render_step(*context, batch, params.samples));
      CHECK(same_bytes(whole, get_image(batch)));

      // One thread and two threads.
      for (auto threads : {1, 2}) {
        auto control = tbb::global_control{
            tbb::global_control::max_allowed_parallelism, (size_t)threads};
        auto image = image_data{};
        REQUIRE(render_image(*context, params, image));
        CHECK(same_bytes(whole, image));
        auto threaded = make_render_state(*context, params);
        REQUIRE(render_step(*context, threaded, params.samples));
        CHECK(same_layers(layers.buffer, threaded.buffer, params));
      }
    }
  }
}

TEST_CASE("render core: adaptive sampling stops the same pixels anyhow") {
  // Whatever the passes, tiles and threads, a pixel stops at the same check
  // from its own data: the same image and counts to the byte.
  auto params            = trace_params{};
  params.resolution      = 40;
  params.samples         = 24;
  params.noise_threshold = 0.2f;
  params.min_samples     = 4;
  auto context           = example_context(params);
  auto whole             = make_render_state(*context, params);
  REQUIRE(render_step(*context, whole, params.samples));
  auto  image   = get_image(whole);
  auto& counts  = whole.buffer.counts;
  auto  stopped = std::count_if(counts.begin(), counts.end(),
       [&](int count) { return count < params.samples; });
  CHECK(stopped > (int)counts.size() / 10);  // not vacuous either way
  CHECK(stopped < (int)counts.size());
  for (auto seed : {1u, 2u}) {
    auto tiled = render_by_tiles(*context, params, seed);
    CHECK(same_bytes(image, average_samples(tiled)));
    CHECK(tiled.counts == counts);
  }
  for (auto threads : {1, 2}) {
    auto control = tbb::global_control{
        tbb::global_control::max_allowed_parallelism, (size_t)threads};
    auto state = make_render_state(*context, params);
    for (auto s = 0; s < params.samples; s += 5)
      REQUIRE(render_step(*context, state, std::min(5, params.samples - s)));
    CHECK(same_bytes(image, get_image(state)));
  }
  // A stopped pixel stopped at a check, with its estimate below the
  // threshold; the others took every sample.
  auto first = adaptive_min_samples(params), step = adaptive_step(params);
  for (size_t idx = 0; idx < counts.size(); idx++) {
    if (counts[idx] == params.samples) continue;
    INFO("pixel ", idx, " stopped at ", counts[idx]);
    CHECK(counts[idx] >= first);
    CHECK((counts[idx] - first) % step == 0);
    CHECK(pixel_error(whole.buffer, idx) < params.noise_threshold);
  }
}

TEST_CASE("render core: a pixel's error is its relative standard error") {
  // Samples 0.1, 0.3, 0.5, 0.7 in red, 2 in green and 0 in blue: sample
  // variances 1/15, 0, 0 (n - 1 = 3), variances of the mean 1/60, 0, 0;
  // relative to mean^2 + 0.01: (1/60) / 0.17, 0, 0 (blue's mean 0 counts
  // as 0.1, and its zero variance as zero error).
  auto buffer = make_render_buffer({0, 1, 0, 1}, 1, 1, {true});
  for (auto value : {0.1f, 0.3f, 0.5f, 0.7f}) {
    auto rgb = vec3f{value, 2, 0};
    buffer.sums[0] += vec4f{rgb.x, rgb.y, rgb.z, 1};
    buffer.squares[0] += rgb * rgb;
    buffer.counts[0]++;
  }
  auto expected = std::sqrt((1.0 / 60) / (0.16 + 0.01) / 3);
  CHECK(pixel_error(buffer, 0) == doctest::Approx(expected).epsilon(1e-5));
  // One sample tells nothing.
  buffer.counts[0] = 1;
  CHECK(pixel_error(buffer, 0) == std::numeric_limits<float>::max());
}

TEST_CASE("render core: pixel streams never collide") {
  // Stream ids are the pixel indices: distinct streams give distinct
  // sequences even for pixels 2^30 apart (the old ids repeated there).
  auto a = make_pixel_rng(7, 5), b = make_pixel_rng(7, 5 + (1ull << 30));
  CHECK(rand1f(a) != rand1f(b));
  auto c = make_pixel_rng(7, 5);
  auto d = make_pixel_rng(7, 5);
  CHECK(rand1f(c) == rand1f(d));
}

TEST_CASE("render core: one validation refuses bad parameters") {
  auto nan = std::numeric_limits<float>::quiet_NaN();
  auto inf = std::numeric_limits<float>::infinity();
  auto bad = [](auto change, const char* name) {
    auto params = trace_params{};
    change(params);
    auto message = std::string{};
    try {
      validate_params(params);
    } catch (const io_error& error) { message = error.what(); }
    INFO(name, ": ", message);
    CHECK(message.find(name) != std::string::npos);
  };
  bad([&](trace_params& p) { p.clamp = nan; }, "clamp");
  bad([&](trace_params& p) { p.clamp = inf; }, "clamp");
  bad([&](trace_params& p) { p.clamp = -1; }, "clamp");
  bad([&](trace_params& p) { p.exposure = inf; }, "exposure");
  bad([&](trace_params& p) { p.exposure = nan; }, "exposure");
  bad([&](trace_params& p) { p.resolution = 0; }, "resolution");
  bad([&](trace_params& p) { p.samples = 0; }, "samples");
  bad([&](trace_params& p) { p.bounces = 0; }, "bounces");
  bad([&](trace_params& p) { p.march.max_iterations = 0; }, "stmaxiter");
  bad([&](trace_params& p) { p.march.overrelax = nan; }, "overrelax");
  CHECK_NOTHROW(validate_params(trace_params{}));

  // Every entry point validates.
  auto params       = trace_params{};
  params.resolution = 16;
  auto context      = example_context(params);
  params.clamp      = nan;
  auto image        = image_data{};
  CHECK_THROWS_AS(render_image(*context, params, image), io_error);
  CHECK_THROWS_AS(make_render_state(*context, params), io_error);
  auto& camera = context->scene.cameras[params.camera];
  auto  tile   = make_render_buffer({0, 1, 0, 1}, 1, params.seed);
  CHECK_THROWS_AS(
      render_samples(*context, params, camera, 0, 1, tile), io_error);
  params.clamp = 10;
  auto outside = make_render_buffer({0, 100, 0, 1}, 100, params.seed);
  CHECK_THROWS_AS(
      render_samples(*context, params, camera, 0, 1, outside), io_error);
  CHECK_THROWS_AS(
      render_samples(*context, params, camera, 2, 1, tile), io_error);
  // A buffer that only gathers finished tiles has no streams to render with.
  auto layout    = buffer_layout{};
  layout.streams = false;
  auto gather    = make_render_buffer({0, 1, 0, 1}, 1, params.seed, layout);
  CHECK(gather.sums.size() == 1);
  CHECK(gather.rngs.empty());
  CHECK(gather.evaluations.empty());
  CHECK_THROWS_AS(
      render_samples(*context, params, camera, 0, 1, gather), io_error);
}

TEST_CASE("render core: fallbacks for cameras and lights") {
  auto dir  = implicit_test::test_dir("render_core_fallbacks");
  auto path = (dir / "dark.json").string();
  std::ofstream(path) << R"({
    "asset": {"version": "4.2"},
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [{"name": "ball", "type": "sphere", "radius": 1, "material": 0,
                     "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,0]}]
  })";
  auto params       = trace_params{};
  params.resolution = 24;
  params.samples    = 1;
  auto context      = make_render_context(load_scene(path), params);
  // A camera framing the scene was added.
  REQUIRE(context->scene.cameras.size() == 1);
  auto warnings = std::vector<std::string>{};
  auto resolved = resolve_params(*context, params, "", warnings);
  CHECK(resolved.shader == shader_type::eyelight);
  REQUIRE(warnings.size() == 1);
  CHECK(warnings[0].find("no lights") != std::string::npos);
  auto image = image_data{};
  REQUIRE(render_image(*context, resolved, image));
  CHECK(pixel(image, image.width / 2, image.height / 2).x > 0.3f);  // eye light
  // Debug shaders need no lights: no warning.
  params.shader = shader_type::normal;
  warnings.clear();
  CHECK(resolve_params(*context, params, "", warnings).shader ==
        shader_type::normal);
  CHECK(warnings.empty());
  // An unknown camera name is an error.
  CHECK_THROWS_AS(resolve_params(*context, params, "nope", warnings), io_error);
}

namespace {

struct progress_record {
  int64_t done = 0, total = 0, calls = 0, cancel_after = -1;
};

void on_progress(void* user, int64_t done, int64_t total) {
  auto& record = *(progress_record*)user;
  record.done  = done;
  record.total = total;
  record.calls++;
}

bool on_cancel(void* user) {
  auto& record = *(progress_record*)user;
  return record.cancel_after >= 0 && record.calls >= record.cancel_after;
}

}  // namespace

TEST_CASE("render core: progress per tile and cancel between tiles") {
  auto params       = trace_params{};
  params.resolution = 64;
  params.samples    = 1;
  params.shader     = shader_type::normal;
  auto context      = example_context(params);
  auto record       = progress_record{};
  auto callbacks    = render_callbacks{on_progress, on_cancel, &record};
  auto image        = image_data{};
  REQUIRE(render_image(*context, params, image, callbacks));
  auto size = render_size(*context, params);
  CHECK(record.total == (int64_t)size.x * size.y);
  CHECK(record.done == record.total);
  CHECK(record.calls > 1);

  record              = {};
  record.cancel_after = 0;
  auto untouched      = image_data{};
  CHECK_FALSE(render_image(*context, params, untouched, callbacks));
  CHECK(untouched.pixels.empty());
  auto state = make_render_state(*context, params);
  CHECK_FALSE(render_step(*context, state, 1, callbacks));
  CHECK(state.samples == 0);
}
