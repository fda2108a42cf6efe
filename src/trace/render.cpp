// # implicit: the render core every front end drives (implementation)

#include "render.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <mutex>

#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CONTEXT
// -----------------------------------------------------------------------------

// Whether anything in the scene emits: sampled lights or emissive objects
// (which BSDF rays still find).
static bool scene_has_emitters(const render_context& context) {
  if (!context.lights.lights.empty()) return true;
  auto& scene = context.scene;
  for (auto& object : context.accel.objects)
    if (object.material >= 0 &&
        max(scene.materials[object.material].emission) > 0)
      return true;
  return false;
}

std::unique_ptr<const render_context> make_render_context(
    scene_data&& scene, const trace_params& params, const accel_params& build) {
  validate_params(params);
  auto context   = std::make_unique<render_context>();
  context->scene = std::move(scene);
  context->accel = make_accel(context->scene, params.accel, build);
  // Appending a camera moves no object the accel points to.
  add_missing_camera(context->scene, context->accel.bounds);
  context->lights       = make_lights(context->scene, context->accel);
  context->has_emitters = scene_has_emitters(*context);
  return context;
}

// An integer parameter in [min, max].
static void check_int(
    const char* name, int64_t value, int64_t min, int64_t max) {
  if (value < min || value > max)
    throw io_error("render parameter " + std::string{name} + ": " +
                   std::to_string(value) + " is out of range [" +
                   std::to_string(min) + ", " + std::to_string(max) + "]");
}

// A float parameter: finite, and in [min, max].
static void check_float(const char* name, float value, float min, float max) {
  if (!std::isfinite(value))
    throw io_error("render parameter " + std::string{name} +
                   ": must be a finite number, not " + std::to_string(value));
  if (value < min || value > max)
    throw io_error("render parameter " + std::string{name} + ": " +
                   std::to_string(value) + " is out of range [" +
                   std::to_string(min) + ", " + std::to_string(max) + "]");
}

void validate_params(const trace_params& params) {
  check_int("resolution", params.resolution, 1, 16384);
  check_int("samples", params.samples, 1, 1 << 20);
  check_int("bounces", params.bounces, 1, 1024);
  check_float("clamp", params.clamp, 1e-6f, flt_max);
  check_float("exposure", params.exposure, -100.0f, 100.0f);
  check_int("camera", params.camera, 0, 1 << 30);
  auto& march = params.march;
  check_int("stmaxiter", march.max_iterations, 1, 1000000);
  check_float("march.hit_relative", march.hit_relative, 0.0f, 1.0f);
  check_float("march.scene_epsilon", march.scene_epsilon, 0.0f, 1.0f);
  check_float("march.overrelax", march.overrelax, 1.0f, 2.0f);
  check_float("march.planar", march.planar, 0.0f, 1.0f);
  check_float("march.fallback", march.fallback, 0.0f, 1e6f);
}

trace_params resolve_params(const render_context& context,
    const trace_params& params, const std::string& camera_name,
    std::vector<std::string>& warnings) {
  validate_params(params);
  auto resolved   = params;
  resolved.camera = find_camera(context.scene, camera_name);
  if (is_lit_shader(resolved.shader) && !context.has_emitters) {
    warnings.push_back(
        "the scene has no lights; rendering with the eyelight shader");
    resolved.shader = shader_type::eyelight;
  }
  return resolved;
}

// The parameters' camera, checked.
static const camera_data& params_camera(
    const render_context& context, const trace_params& params) {
  if (params.camera < 0 || params.camera >= (int)context.scene.cameras.size())
    throw io_error("render parameter camera: " + std::to_string(params.camera) +
                   " is not a camera index");
  return context.scene.cameras[params.camera];
}

vec2i render_size(const render_context& context, const trace_params& params) {
  return camera_resolution(params_camera(context, params), params.resolution);
}

// -----------------------------------------------------------------------------
// TILES
// -----------------------------------------------------------------------------

// Every sample of a tile of an image of the given size.
static void render_tile_samples(const render_context& context,
    const camera_data& camera, const trace_params& params, vec2i size,
    const render_tile_rect& tile, std::vector<vec4f>& accumulated) {
  auto tile_width = tile.x1 - tile.x0;
  accumulated.assign((size_t)tile_width * (tile.y1 - tile.y0), {0, 0, 0, 0});
  auto evaluations = int64_t{0};
  for (auto j = tile.y0; j < tile.y1; j++) {
    for (auto i = tile.x0; i < tile.x1; i++) {
      auto rng = make_pixel_rng(params.seed, (size_t)j * size.x + i);
      auto idx = (size_t)(j - tile.y0) * tile_width + (i - tile.x0);
      trace_pixel_samples(context.scene, context.accel, context.lights, camera,
          params, i, j, size.x, size.y, 0, params.samples, accumulated[idx],
          rng, evaluations);
    }
  }
}

void render_tile(const render_context& context, const trace_params& params,
    const render_tile_rect& tile, std::vector<vec4f>& accumulated) {
  validate_params(params);
  auto& camera = params_camera(context, params);
  auto  size   = camera_resolution(camera, params.resolution);
  if (tile.x0 < 0 || tile.y0 < 0 || tile.x1 > size.x || tile.y1 > size.y ||
      tile.x0 > tile.x1 || tile.y0 > tile.y1)
    throw io_error("render tile [" + std::to_string(tile.x0) + ", " +
                   std::to_string(tile.x1) + ") x [" + std::to_string(tile.y0) +
                   ", " + std::to_string(tile.y1) + ") is outside the " +
                   std::to_string(size.x) + "x" + std::to_string(size.y) +
                   " image");
  render_tile_samples(context, camera, params, size, tile, accumulated);
}

image_data average_samples(
    const std::vector<vec4f>& accumulated, int width, int height, int samples) {
  auto image = make_image(width, height);
  for (size_t idx = 0; idx < image.pixels.size(); idx++)
    image.pixels[idx] = average_samples(accumulated[idx], samples);
  return image;
}

// -----------------------------------------------------------------------------
// WHOLE IMAGES
// -----------------------------------------------------------------------------

// Tile size of the parallel loops: small enough that a cancel takes effect
// quickly, large enough that scheduling costs nothing.
inline constexpr int render_tile_size = 16;

// Run `render(tile)` over the tiles of a width x height image in parallel,
// asking the cancel callback before each tile and reporting each finished
// one. Returns false when cancelled.
template <typename Render>
static bool for_each_tile(int width, int height,
    const render_callbacks& callbacks, const Render& render) {
  auto stopped = std::atomic<bool>{false};
  auto mutex   = std::mutex{};
  auto done    = int64_t{0};
  auto total   = (int64_t)width * height;
  auto range   = tbb::blocked_range2d<int>(
      0, height, render_tile_size, 0, width, render_tile_size);
  tbb::parallel_for(range, [&](const tbb::blocked_range2d<int>& block) {
    if (stopped.load(std::memory_order_relaxed)) return;
    if (callbacks.cancel && callbacks.cancel(callbacks.user)) {
      stopped.store(true, std::memory_order_relaxed);
      return;
    }
    auto tile = render_tile_rect{block.cols().begin(), block.cols().end(),
        block.rows().begin(), block.rows().end()};
    render(tile);
    if (callbacks.progress) {
      auto lock = std::lock_guard<std::mutex>{mutex};
      done += (int64_t)(tile.x1 - tile.x0) * (tile.y1 - tile.y0);
      callbacks.progress(callbacks.user, done, total);
    }
  });
  return !stopped.load();
}

bool render_image(const render_context& context, const trace_params& params,
    image_data& image, const render_callbacks& callbacks) {
  validate_params(params);
  auto& camera      = params_camera(context, params);
  auto  size        = camera_resolution(camera, params.resolution);
  auto  accumulated = std::vector<vec4f>((size_t)size.x * size.y);
  auto  finished    = for_each_tile(
          size.x, size.y, callbacks, [&](const render_tile_rect& tile) {
        auto sums = std::vector<vec4f>{};
        render_tile_samples(context, camera, params, size, tile, sums);
        auto tile_width = tile.x1 - tile.x0;
        for (auto j = tile.y0; j < tile.y1; j++)
          for (auto i = tile.x0; i < tile.x1; i++)
            accumulated[(size_t)j * size.x + i] =
                sums[(size_t)(j - tile.y0) * tile_width + (i - tile.x0)];
      });
  if (!finished) return false;
  image = average_samples(accumulated, size.x, size.y, params.samples);
  return true;
}

// -----------------------------------------------------------------------------
// PROGRESSIVE
// -----------------------------------------------------------------------------

render_state make_render_state(
    const render_context& context, const trace_params& params) {
  validate_params(params);
  return make_state(params_camera(context, params), params);
}

render_state make_render_state(const render_context& context,
    const trace_params& params, const camera_data& camera) {
  (void)context;
  validate_params(params);
  return make_state(camera, params);
}

bool render_step(const render_context& context, render_state& state,
    int samples, const render_callbacks& callbacks) {
  auto& params   = state.params;
  auto  first    = state.samples;
  auto  counted  = std::max(0, samples);
  auto  finished = for_each_tile(
       state.width, state.height, callbacks, [&](const render_tile_rect& tile) {
        for (auto j = tile.y0; j < tile.y1; j++) {
          for (auto i = tile.x0; i < tile.x1; i++) {
            auto idx = (size_t)j * state.width + i;
            trace_pixel_samples(context.scene, context.accel, context.lights,
                 state.camera, params, i, j, state.width, state.height, first,
                 counted, state.accumulated[idx], state.rngs[idx],
                 state.evaluations[idx]);
          }
        }
      });
  if (!finished) return false;
  state.samples += counted;
  return true;
}

image_data get_image(const render_state& state) {
  return average_samples(
      state.accumulated, state.width, state.height, state.samples);
}

}  // namespace implicit
