// # implicit: the render core every front end drives (implementation)

#include "render.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>

#include "../util/error.h"
#include "../util/memory.h"
#include "camera_blocks.h"
#include "render_options.h"

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
  // The options' ranges: the table's (render_options.h).
  auto settings   = render_settings{};
  settings.params = params;
  for (auto& option : render_option_table()) {
    auto problem = check_render_option(settings, option);
    if (!problem.empty())
      throw io_error("render parameter " + option.name + ": " + problem);
  }
  // Settings that are no user's option.
  check_int("camera", params.camera, 0, 1 << 30);
  auto& march = params.march;
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
// BUFFERS
// -----------------------------------------------------------------------------

rng_state make_pixel_rng(uint64_t seed, size_t index) {
  return make_rng(seed, (uint64_t)index);
}

buffer_layout render_layout(const trace_params& params) {
  auto layout       = buffer_layout{};
  layout.statistics = has_aov(params, aov_type::variance) ||
                      params.noise_threshold > 0 || params.denoise;
  layout.albedo   = has_aov(params, aov_type::albedo) || params.denoise;
  layout.normal   = has_aov(params, aov_type::normal) || params.denoise;
  layout.position = has_aov(params, aov_type::position);
  layout.depth =
      has_aov(params, aov_type::depth) || layout.position || params.denoise;
  return layout;
}

render_buffer make_render_buffer(const render_rect& rect, int width,
    uint64_t seed, const buffer_layout& layout) {
  auto buffer = render_buffer{};
  buffer.rect = rect;
  auto count  = rect_pixels(rect);
  auto zero3  = vec3f{0, 0, 0};
  // Huge pages where the kernel has them: page faults here were a third of
  // the fixed cost of a 1024 x 1024 preview (0.37 -> 0.26 s for one whose
  // every ray misses).
  assign_huge(buffer.sums, count, vec4f{0, 0, 0, 0});
  assign_huge(buffer.counts, count, 0);
  if (layout.statistics) {
    assign_huge(buffer.squares, count, zero3);
    assign_huge(buffer.evens, count, zero3);
  }
  if (layout.albedo) assign_huge(buffer.albedos, count, zero3);
  if (layout.normal) assign_huge(buffer.normals, count, zero3);
  if (layout.depth || layout.position)
    assign_huge(buffer.depths, count, vec2f{0, 0});
  if (layout.position) assign_huge(buffer.positions, count, zero3);
  if (!layout.streams) return buffer;
  assign_huge(buffer.evaluations, count, int64_t{0});
  assign_huge(buffer.rngs, count, rng_state{});
  auto idx = size_t{0};
  for (auto j = rect.y0; j < rect.y1; j++)
    for (auto i = rect.x0; i < rect.x1; i++)
      buffer.rngs[idx++] = make_pixel_rng(seed, (size_t)j * width + i);
  return buffer;
}

void copy_pixels(const render_buffer& from, render_buffer& to) {
  auto& a  = from.rect;
  auto& b  = to.rect;
  auto  x0 = std::max(a.x0, b.x0), x1 = std::min(a.x1, b.x1);
  auto  y0 = std::max(a.y0, b.y0), y1 = std::min(a.y1, b.y1);
  auto  sa = (size_t)(a.x1 - a.x0), sb = (size_t)(b.x1 - b.x0);
  visit_pixel_arrays(from, to, [&](const auto& source, auto& target) {
    if (source.empty()) return;
    if (target.size() != rect_pixels(b)) {
      target.clear();
      target.resize(rect_pixels(b), {});
    }
    for (auto j = y0; j < y1; j++)
      for (auto i = x0; i < x1; i++)
        target[(size_t)(j - b.y0) * sb + (i - b.x0)] =
            source[(size_t)(j - a.y0) * sa + (i - a.x0)];
  });
}

// Add sample `sample` of pixel `idx` to every array the buffer keeps.
static void add_sample(
    render_buffer& buffer, size_t idx, int sample, const pixel_sample& result) {
  auto& color = result.color;
  auto  rgb   = xyz(color);
  buffer.sums[idx] += color;
  buffer.counts[idx] = sample + 1;
  if (!buffer.squares.empty()) {
    buffer.squares[idx] += rgb * rgb;
    if (sample % 2 == 0) buffer.evens[idx] += rgb;
  }
  if (!buffer.albedos.empty()) buffer.albedos[idx] += result.albedo;
  if (!buffer.normals.empty()) buffer.normals[idx] += result.normal;
  if (!buffer.depths.empty() && result.depth > 0) {
    auto& depth = buffer.depths[idx];
    depth       = {depth.x + result.depth, depth.y + 1};
    if (!buffer.positions.empty()) buffer.positions[idx] += result.position;
  }
}

// The variance of a pixel's mean per channel: the sample variance (n - 1
// degrees of freedom) over n; 0 below 2 samples.
static vec3f mean_variance(vec3f sum, vec3f squares, int count) {
  if (count < 2) return {0, 0, 0};
  auto n        = (float)count;
  auto variance = (squares - sum * sum * (1 / n)) * (1 / (n - 1));
  return max(variance, vec3f{0, 0, 0}) * (1 / n);
}

float pixel_error(const render_buffer& buffer, size_t idx) {
  auto count = buffer.counts[idx];
  if (count < 2 || buffer.squares.empty()) return flt_max;
  auto sum      = xyz(buffer.sums[idx]);
  auto variance = mean_variance(sum, buffer.squares[idx], count);
  auto mean     = sum * (1.0f / (float)count);
  auto rel      = variance / (mean * mean + 0.01f);
  return std::sqrt((rel.x + rel.y + rel.z) / 3);
}

int adaptive_min_samples(const trace_params& params) {
  if (params.min_samples > 0) return params.min_samples;
  return std::max(16, params.samples / 16);
}

int adaptive_step(const trace_params& params) {
  return std::clamp(adaptive_min_samples(params), 1, max_pass_samples);
}

bool is_converged(const render_buffer& buffer, size_t idx,
    const trace_params& params, int sample) {
  if (params.noise_threshold <= 0) return false;
  auto first = adaptive_min_samples(params);
  if (sample < first || (sample - first) % adaptive_step(params) != 0)
    return false;
  return pixel_error(buffer, idx) < params.noise_threshold;
}

// The pixels of both rectangles.
static render_rect clip_rect(const render_rect& a, const render_rect& b) {
  return {std::max(a.x0, b.x0), std::min(a.x1, b.x1), std::max(a.y0, b.y0),
      std::min(a.y1, b.y1)};
}

// Samples s0 to s1 of `pixels`, which lie inside one block of the camera's
// first pass (blocks of camera_block_size pixels from the image's corner).
static void render_block(const render_context& context,
    const trace_params& params, const camera_data& camera, vec2i size,
    const render_rect& block, const render_rect& pixels, int s0, int s1,
    render_buffer& buffer) {
  auto& held   = buffer.rect;
  auto  stride = (size_t)(held.x1 - held.x0);
  auto  start  = -1.0f;  // computed for the first pixel that takes a sample
  for (auto j = pixels.y0; j < pixels.y1; j++) {
    for (auto i = pixels.x0; i < pixels.x1; i++) {
      auto idx = (size_t)(j - held.y0) * stride + (i - held.x0);
      if (buffer.counts[idx] < s0) continue;  // stopped (adaptive sampling)
      auto& rng         = buffer.rngs[idx];
      auto& evaluations = buffer.evaluations[idx];
      for (auto sample = s0; sample < s1; sample++) {
        if (is_converged(buffer, idx, params, sample)) break;
        if (start < 0)
          start = params.first_pass
                      ? camera_block_start(context.accel, params.march, camera,
                            size, {block.x0, block.y0}, {block.x1, block.y1},
                            params.tentfilter)
                      : 0;
        auto result = trace_sample(context.scene, context.accel, context.lights,
            camera, params, {i, j}, size, sample, rng, evaluations, start);
        add_sample(buffer, idx, sample, result);
      }
    }
  }
}

void render_pixels(const render_context& context, const trace_params& params,
    const camera_data& camera, const render_rect& rect, int s0, int s1,
    render_buffer& buffer) {
  auto size = camera_resolution(camera, params.resolution);
  auto b    = camera_block_size;
  // Whole blocks of the image, whatever part of them `rect` holds, so that
  // a block's start does not depend on how the image is cut into tiles.
  for (auto y = rect.y0 / b * b; y < rect.y1; y += b) {
    for (auto x = rect.x0 / b * b; x < rect.x1; x += b) {
      auto block =
          render_rect{x, std::min(x + b, size.x), y, std::min(y + b, size.y)};
      render_block(context, params, camera, size, block, clip_rect(block, rect),
          s0, s1, buffer);
    }
  }
}

image_data average_samples(const render_buffer& buffer) {
  auto& rect  = buffer.rect;
  auto  image = make_image(rect.x1 - rect.x0, rect.y1 - rect.y0);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto count = buffer.counts[idx];
    image.pixels[idx] =
        count > 0 ? buffer.sums[idx] * (1.0f / count) : vec4f{0, 0, 0, 0};
  }
  return image;
}

// One pixel's value of an AOV.
static void eval_layer(
    const render_buffer& buffer, aov_type aov, size_t idx, float* values) {
  auto count = buffer.counts[idx];
  auto value = vec3f{0, 0, 0};
  auto hits  = buffer.depths.empty() ? 0.0f : buffer.depths[idx].y;
  switch (aov) {
    case aov_type::albedo: value = buffer.albedos[idx]; break;
    case aov_type::normal: value = buffer.normals[idx]; break;
    case aov_type::position: value = buffer.positions[idx]; break;
    case aov_type::depth: value = vec3f{buffer.depths[idx].x, 0, 0}; break;
    case aov_type::variance:
      value = mean_variance(xyz(buffer.sums[idx]), buffer.squares[idx], count);
      break;
  }
  auto depth_like = aov == aov_type::depth || aov == aov_type::position;
  if (aov != aov_type::variance) {
    auto divisor = depth_like ? hits : (float)count;
    value        = divisor > 0 ? value * (1 / divisor) : vec3f{0, 0, 0};
  }
  auto channels = aov == aov_type::depth ? 1 : 3;
  for (auto c = 0; c < channels; c++) values[c] = (&value.x)[c];
}

denoise_buffers make_denoise_buffers(const render_buffer& buffer) {
  auto& rect     = buffer.rect;
  auto  pixels   = rect_pixels(rect);
  auto  result   = denoise_buffers{};
  result.width   = rect.x1 - rect.x0;
  result.height  = rect.y1 - rect.y0;
  result.samples = buffer.counts;
  auto plane     = [&](aov_type aov) {
    auto values = std::vector<vec3f>(pixels);
    auto layer  = average_layer(buffer, aov);
    for (size_t idx = 0; idx < pixels; idx++) {
      auto v      = layer.values.data() + idx * 3;
      values[idx] = {v[0], v[1], v[2]};
    }
    return values;
  };
  if (!buffer.squares.empty()) {
    result.variance = plane(aov_type::variance);
    result.color_a.resize(pixels);
    result.color_b.resize(pixels);
  }
  if (!buffer.albedos.empty()) result.albedo = plane(aov_type::albedo);
  if (!buffer.normals.empty()) result.normal = plane(aov_type::normal);
  if (!buffer.depths.empty())
    result.depth = average_layer(buffer, aov_type::depth).values;
  result.color.resize(pixels);
  for (size_t idx = 0; idx < pixels; idx++) {
    auto count        = buffer.counts[idx];
    auto sum          = xyz(buffer.sums[idx]);
    result.color[idx] = count > 0 ? sum * (1.0f / count) : vec3f{0, 0, 0};
    if (buffer.evens.empty()) continue;
    // Samples 0, 2, 4, ... and 1, 3, 5, ...: (count + 1) / 2 and count / 2.
    auto na = (count + 1) / 2, nb = count / 2;
    auto even           = buffer.evens[idx];
    result.color_a[idx] = na > 0 ? even * (1.0f / na) : vec3f{0, 0, 0};
    result.color_b[idx] = nb > 0 ? (sum - even) * (1.0f / nb) : vec3f{0, 0, 0};
  }
  return result;
}

image_data output_image(
    const render_buffer& buffer, const trace_params& params) {
  auto image = average_samples(buffer);
  if (!params.denoise) return image;
  auto denoise_settings   = denoise_params{};
  denoise_settings.method = params.denoiser;
  auto denoised = denoise_image(make_denoise_buffers(buffer), denoise_settings);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto& rgb         = denoised[idx];
    image.pixels[idx] = {rgb.x, rgb.y, rgb.z, image.pixels[idx].w};
  }
  return image;
}

image_layer average_layer(const render_buffer& buffer, aov_type aov) {
  auto kept = true;
  switch (aov) {
    case aov_type::albedo: kept = !buffer.albedos.empty(); break;
    case aov_type::normal: kept = !buffer.normals.empty(); break;
    case aov_type::depth: kept = !buffer.depths.empty(); break;
    case aov_type::position: kept = !buffer.positions.empty(); break;
    case aov_type::variance: kept = !buffer.squares.empty(); break;
  }
  auto& name = aov_type_names[(int)aov];
  if (!kept)
    throw io_error("render buffer: the " + name + " layer was not rendered");
  auto layer = image_layer{};
  layer.name = name;
  switch (aov) {
    case aov_type::albedo:
    case aov_type::variance: layer.channels = {"R", "G", "B"}; break;
    case aov_type::normal:
    case aov_type::position: layer.channels = {"X", "Y", "Z"}; break;
    case aov_type::depth: layer.channels = {"Z"}; break;
  }
  auto channels = layer.channels.size();
  auto pixels   = rect_pixels(buffer.rect);
  layer.values.assign(pixels * channels, 0);
  for (size_t idx = 0; idx < pixels; idx++)
    eval_layer(buffer, aov, idx, layer.values.data() + idx * channels);
  return layer;
}

std::vector<image_layer> average_layers(
    const render_buffer& buffer, const trace_params& params) {
  auto layers = std::vector<image_layer>{};
  for (auto aov = 0; aov < (int)aov_type_names.size(); aov++)
    if (has_aov(params, (aov_type)aov))
      layers.push_back(average_layer(buffer, (aov_type)aov));
  return layers;
}

// -----------------------------------------------------------------------------
// PARALLEL RENDERS
// -----------------------------------------------------------------------------

// Blocks of the camera's first pass per side of a task of the parallel
// loops: 2 (16 pixels) for whole images (scheduling costs nothing, a cancel
// takes effect soon), 1 for tiles, so that a 64-pixel tile keeps 64 threads
// of one rank busy. Tasks hold whole blocks, each block's start computed
// once.
static int task_blocks(const render_rect& rect) {
  return rect_pixels(rect) >= 128 * 128 ? 2 : 1;
}

// Refuse a buffer that does not fit the image or its own rectangle, and a
// sample range that runs backwards.
static void check_buffer(
    const render_buffer& buffer, vec2i size, int s0, int s1) {
  auto& rect  = buffer.rect;
  auto  count = rect_pixels(rect);
  if (rect.x0 < 0 || rect.y0 < 0 || rect.x1 > size.x || rect.y1 > size.y ||
      rect.x0 > rect.x1 || rect.y0 > rect.y1)
    throw io_error("render rectangle [" + std::to_string(rect.x0) + ", " +
                   std::to_string(rect.x1) + ") x [" + std::to_string(rect.y0) +
                   ", " + std::to_string(rect.y1) + ") is outside the " +
                   std::to_string(size.x) + "x" + std::to_string(size.y) +
                   " image");
  auto kept = [&](size_t length) { return length == 0 || length == count; };
  if (buffer.sums.size() != count || buffer.rngs.size() != count ||
      buffer.evaluations.size() != count || buffer.counts.size() != count ||
      !kept(buffer.squares.size()) ||
      buffer.evens.size() != buffer.squares.size() ||
      !kept(buffer.albedos.size()) || !kept(buffer.normals.size()) ||
      !kept(buffer.depths.size()) || !kept(buffer.positions.size()) ||
      (!buffer.positions.empty() && buffer.depths.empty()))
    throw io_error("render buffer: arrays do not match its rectangle");
  if (s0 < 0 || s1 < s0)
    throw io_error("render samples [" + std::to_string(s0) + ", " +
                   std::to_string(s1) + "): not a sample range");
}

bool render_samples(const render_context& context, const trace_params& params,
    const camera_data& camera, int s0, int s1, render_buffer& buffer,
    const render_callbacks& callbacks) {
  validate_params(params);
  auto& rect = buffer.rect;
  check_buffer(buffer, camera_resolution(camera, params.resolution), s0, s1);
  auto stopped = std::atomic<bool>{false};
  auto mutex   = std::mutex{};
  auto done    = int64_t{0};
  auto total   = (int64_t)rect_pixels(rect) * (s1 - s0);
  auto grain   = task_blocks(rect);
  auto b       = camera_block_size;
  auto range   = tbb::blocked_range2d<int>(rect.y0 / b, (rect.y1 + b - 1) / b,
      grain, rect.x0 / b, (rect.x1 + b - 1) / b, grain);
  for (auto p0 = s0; p0 < s1 && !stopped.load(); p0 += max_pass_samples) {
    auto p1 = std::min(s1, p0 + max_pass_samples);
    tbb::parallel_for(range, [&](const tbb::blocked_range2d<int>& block) {
      if (stopped.load(std::memory_order_relaxed)) return;
      if (callbacks.cancel && callbacks.cancel(callbacks.user)) {
        stopped.store(true, std::memory_order_relaxed);
        return;
      }
      auto pixels = clip_rect(
          rect, {block.cols().begin() * b, block.cols().end() * b,
                    block.rows().begin() * b, block.rows().end() * b});
      render_pixels(context, params, camera, pixels, p0, p1, buffer);
      if (callbacks.progress) {
        auto lock = std::lock_guard<std::mutex>{mutex};
        done += (int64_t)rect_pixels(pixels) * (p1 - p0);
        callbacks.progress(callbacks.user, done, total);
      }
    });
  }
  return !stopped.load();
}

// -----------------------------------------------------------------------------
// PROGRESSIVE AND WHOLE IMAGES
// -----------------------------------------------------------------------------

render_state make_render_state(
    const render_context& context, const trace_params& params) {
  validate_params(params);
  return make_render_state(context, params, params_camera(context, params));
}

render_state make_render_state(const render_context& context,
    const trace_params& params, const camera_data& camera) {
  (void)context;
  validate_params(params);
  auto state   = render_state{};
  state.params = params;
  state.camera = camera;
  auto size    = camera_resolution(camera, params.resolution);
  state.width  = size.x;
  state.height = size.y;
  state.buffer = make_render_buffer(
      {0, size.x, 0, size.y}, size.x, params.seed, render_layout(params));
  return state;
}

bool render_step(const render_context& context, render_state& state,
    int samples, const render_callbacks& callbacks) {
  auto count = std::max(0, samples);
  if (!render_samples(context, state.params, state.camera, state.samples,
          state.samples + count, state.buffer, callbacks))
    return false;
  state.samples += count;
  return true;
}

image_data get_image(const render_state& state) {
  return average_samples(state.buffer);
}

bool render_image(const render_context& context, const trace_params& params,
    image_data& image, const render_callbacks& callbacks) {
  auto state = make_render_state(context, params);
  if (!render_step(context, state, params.samples, callbacks)) return false;
  image = get_image(state);
  return true;
}

}  // namespace implicit
