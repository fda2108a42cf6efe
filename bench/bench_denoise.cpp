// # bench_denoise: relative MSE and cost of the denoisers on rendered scenes
//
// For each scene: a reference of --reference-samples spp (cached in --out),
// a render of --samples spp that keeps the per-pixel statistics and
// features (render_buffer: half buffers, variance, albedo, normal, depth of
// the first non-specular hit), and a render of 16 x --samples spp. Printed per
// scene: the relMSE (mean over pixels and channels of (x - ref)^2 / (ref^2 +
// 0.01)) of the raw render, of each denoiser, and of the 16x render; the CPU
// time of the render and of each denoiser per megapixel (process CPU time, all
// threads: other processes on the machine count less than in wall time).
// With --images, a strip per scene in --out: noisy | each denoiser | 16x |
// reference, three per row.
//
// Usage: bench_denoise [--resolution N] [--reference-samples N]
//        [--samples N] [--out DIR]
//        [--files a.json,b.json] [--methods nlm,nfor,ttest] [--images]
//        [--radius N] [--strength K] [--adaptive 0.05,0.02] [--seeds N]
// --adaptive also compares, per noise threshold, adaptive sampling (at most
// 16 x --samples spp) with uniform sampling at equal CPU time (--seeds
// times, with the median ratio).
// --methods takes variants: a method, then :key=value settings (see
// parse_variant), e.g. --methods nlm,nlm:k=1,ttest:r=9:t=2.5.

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "image/denoise.h"
#include "image/image_io.h"
#include "scene/scene_io.h"
#include "trace/render.h"

using namespace implicit;
namespace fs = std::filesystem;

struct bench_options {
  int                      resolution        = 128;
  int                      reference_samples = 16384;
  int                      samples           = 64;
  int                      radius            = -1;  // -1: the default
  float                    strength          = -1;  // -1: the default
  std::string              out               = "denoise_bench";
  std::vector<std::string> files             = {};
  std::vector<std::string> methods           = {"nlm", "nfor", "ttest"};
  bool                     images            = false;
  std::vector<float>       adaptive          = {};  // noise thresholds
  int                      seeds             = 1;   // adaptive runs
};

static double process_cpu_seconds() {
  auto t = timespec{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

// Relative MSE of linear RGB pixels against a reference.
static double rel_mse(
    const std::vector<vec3f>& image, const std::vector<vec3f>& reference) {
  auto sum = 0.0;
  for (size_t i = 0; i < image.size(); i++)
    for (auto c = 0; c < 3; c++) {
      double x = at(image[i], c), r = at(reference[i], c);
      sum += (x - r) * (x - r) / (r * r + 0.01);
    }
  return image.empty() ? 0 : sum / (3.0 * image.size());
}

// Per-pixel relative squared error (mean over channels), as grey, times
// `gain`.
static std::vector<vec3f> error_map(const std::vector<vec3f>& image,
    const std::vector<vec3f>& reference, float gain) {
  auto map = std::vector<vec3f>(image.size());
  for (size_t i = 0; i < image.size(); i++) {
    auto e = 0.0f;
    for (auto c = 0; c < 3; c++) {
      auto d = at(image[i], c) - at(reference[i], c);
      e += d * d / (at(reference[i], c) * at(reference[i], c) + 0.01f) / 3;
    }
    map[i] = vec3f{1, 1, 1} * (e * gain);
  }
  return map;
}

// Linear RGB pixels as an image (alpha 1).
static image_data to_image(
    int width, int height, const std::vector<vec3f>& pixels) {
  auto image = make_image(width, height);
  for (size_t i = 0; i < pixels.size(); i++)
    image.pixels[i] = {pixels[i].x, pixels[i].y, pixels[i].z, 1};
  return image;
}

static std::vector<vec3f> rgb(const image_data& image) {
  auto pixels = std::vector<vec3f>(image.pixels.size());
  for (size_t i = 0; i < pixels.size(); i++) pixels[i] = xyz(image.pixels[i]);
  return pixels;
}

// A render of `samples` spp with `seed`, its CPU seconds added to `seconds`.
static image_data render(const render_context& context, trace_params params,
    int samples, uint64_t seed, double& seconds) {
  params.samples = samples;
  params.seed    = seed;
  auto image     = image_data{};
  auto start     = process_cpu_seconds();
  render_image(context, params, image);
  seconds += process_cpu_seconds() - start;
  return image;
}

// The reference: loaded from `path` if there, else rendered and saved.
static std::vector<vec3f> reference_image(const render_context& context,
    const trace_params& params, int samples, const std::string& path) {
  if (fs::exists(path)) return rgb(load_image(path));
  auto seconds = 0.0;
  auto image   = render(context, params, samples, 1234567, seconds);
  save_image(path, image);
  std::printf(
      "(reference %s: %d spp, %.0f CPU s)\n", path.c_str(), samples, seconds);
  return rgb(image);
}

// A render of samples [0, samples) that keeps the per-pixel statistics and
// features (render_buffer: half buffers, variance, albedo, normal, depth of
// the first non-specular hit), adaptive when params.noise_threshold > 0; its
// CPU seconds added to `seconds`.
static render_buffer buffer_render(const render_context& context,
    const trace_params& params, int samples, double& seconds) {
  auto size   = render_size(context, params);
  auto layout = buffer_layout{true, true, true, true, false};
  auto buffer =
      make_render_buffer({0, size.x, 0, size.y}, size.x, params.seed, layout);
  auto start = process_cpu_seconds();
  render_samples(context, params, context.scene.cameras.at(params.camera), 0,
      samples, buffer);
  seconds += process_cpu_seconds() - start;
  return buffer;
}

// Adaptive against uniform sampling at equal CPU time: an adaptive render
// with `threshold` (at most 16 x --samples spp), then a uniform one of the
// samples its CPU time buys at the rate of the uniform --samples render
// (`seconds_per_sample`), compared by relMSE x CPU time; with --seeds N, N
// pairs of renders with other seeds (a render's relMSE at these sample counts
// swings with its rare bright paths) and the median ratio.
static void bench_adaptive(const render_context& context, trace_params params,
    float threshold, double seconds_per_sample, const bench_options& opts,
    const std::vector<vec3f>& reference) {
  auto ratios = std::vector<double>{};
  auto seed   = params.seed;
  for (auto run = 0; run < opts.seeds; run++) {
    params.seed            = seed + 1000 * run;
    params.noise_threshold = threshold;
    auto adaptive_seconds  = 0.0;
    auto adaptive =
        buffer_render(context, params, opts.samples * 16, adaptive_seconds);
    auto total = 0.0, capped = 0.0;
    for (auto count : adaptive.counts) {
      total += count;
      capped += count == opts.samples * 16 ? 1 : 0;
    }
    params.noise_threshold = 0;
    auto samples =
        std::max(1, (int)std::lround(adaptive_seconds / seconds_per_sample));
    auto uniform_seconds = 0.0;
    auto uniform = buffer_render(context, params, samples, uniform_seconds);
    auto a       = rel_mse(rgb(average_samples(adaptive)), reference);
    auto u       = rel_mse(rgb(average_samples(uniform)), reference);
    // relMSE x CPU time: the relMSE at equal time, for unbiased renders,
    // even when the uniform render's time missed the adaptive one's.
    auto ratio = (u * uniform_seconds) / (a * adaptive_seconds);
    std::printf(
        "  adaptive %.3f: relMSE %.5f (%.1f spp on average, %.0f%% of the "
        "pixels at the cap, %.2f CPU s); uniform %d spp: %.5f (%.2f CPU s); "
        "relMSE x time %.2fx lower\n",
        threshold, a, total / adaptive.counts.size(),
        100 * capped / adaptive.counts.size(), adaptive_seconds, samples, u,
        uniform_seconds, ratio);
    ratios.push_back(ratio);
  }
  if (ratios.size() < 2) return;
  std::sort(ratios.begin(), ratios.end());
  std::printf("  adaptive %.3f: median of %zu seeds %.2fx lower\n", threshold,
      ratios.size(), ratios[ratios.size() / 2]);
}

// Save images in a grid of three columns as one PNG, each pixel `zoom`
// pixels wide.
static void save_strip(const std::string& path, int width, int height,
    const std::vector<std::vector<vec3f>>& images, int zoom = 3) {
  auto columns = 3, rows = ((int)images.size() + 2) / 3;
  auto strip = make_image(width * columns * zoom, height * rows * zoom);
  for (size_t k = 0; k < images.size(); k++)
    for (auto y = 0; y < height * zoom; y++)
      for (auto x = 0; x < width * zoom; x++) {
        auto c               = images[k][(size_t)(y / zoom) * width + x / zoom];
        auto px              = ((int)k % columns) * width * zoom + x;
        auto py              = ((int)k / columns) * height * zoom + y;
        pixel(strip, px, py) = {c.x, c.y, c.z, 1};
      }
  save_image(path, strip);
}

// A denoiser variant: a method name, then ":key=value" settings: r radius,
// p patch radius, k strength, o low strength, x outlier ratio, d demodulation
// floor, b blend radius, t t-test threshold, a/n/z albedo, normal and depth
// sigmas, l ridge, s selection radius, v=0 the halves' difference instead of
// the variance buffer (e.g. "ttest:r=9:t=2.5", "nlm:d=0:x=0" without
// demodulation and outliers).
static denoise_params parse_variant(const std::string& text) {
  auto   parts = std::vector<std::string>{};
  size_t start = 0;
  while (start <= text.size()) {
    auto end = text.find(':', start);
    if (end == std::string::npos) end = text.size();
    parts.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  auto params   = denoise_params{};
  params.method = parse_denoise_method(parts[0]);
  for (size_t i = 1; i < parts.size(); i++) {
    auto key   = parts[i].substr(0, 1);
    auto value = std::atof(
        parts[i].substr(std::min(parts[i].size(), (size_t)2)).c_str());
    if (key == "r")
      params.radius = (int)value;
    else if (key == "p")
      params.patch_radius = (int)value;
    else if (key == "k")
      params.strength = (float)value;
    else if (key == "o")
      params.low_strength = (float)value;
    else if (key == "b")
      params.blend_radius = (int)value;
    else if (key == "x")
      params.outlier_ratio = (float)value;
    else if (key == "d")
      params.demodulate = (float)value;
    else if (key == "t")
      params.ttest_threshold = (float)value;
    else if (key == "a")
      params.albedo_sigma = (float)value;
    else if (key == "n")
      params.normal_sigma = (float)value;
    else if (key == "z")
      params.depth_sigma = (float)value;
    else if (key == "l")
      params.ridge = (float)value;
    else if (key == "s")
      params.select_radius = (int)value;
    else if (key == "v")
      continue;  // v=0: the halves' difference instead of the variance

    else
      throw std::runtime_error("unknown variant setting " + parts[i]);
  }
  return params;
}

static void bench_file(const std::string& file, const bench_options& opts) {
  auto name         = fs::path(file).stem().string();
  auto params       = trace_params{};
  params.resolution = opts.resolution;
  auto context      = make_render_context(load_scene(file), params);
  auto warnings     = std::vector<std::string>{};
  params            = resolve_params(*context, params, "", warnings);
  auto reference    = reference_image(*context, params, opts.reference_samples,
         opts.out + "/" + name + "_reference_" + std::to_string(opts.resolution) +
             "_" + std::to_string(opts.reference_samples) + ".exr");
  auto render_seconds = 0.0;
  auto buffers        = make_denoise_buffers(
             buffer_render(*context, params, opts.samples, render_seconds));
  auto high_seconds = 0.0;
  auto high =
      rgb(render(*context, params, opts.samples * 16, 99, high_seconds));
  auto megapixels = buffers.width * buffers.height * 1e-6;
  std::printf(
      "%-12s %dx%d  raw %d spp: relMSE %.5f (%.1f CPU s/MP)  raw %d spp: "
      "%.5f\n",
      name.c_str(), buffers.width, buffers.height, opts.samples,
      rel_mse(buffers.color, reference), render_seconds / megapixels,
      opts.samples * 16, rel_mse(high, reference));
  auto strip = std::vector<std::vector<vec3f>>{buffers.color};
  for (auto& method : opts.methods) {
    auto dparams = parse_variant(method);
    if (opts.radius >= 0) dparams.radius = opts.radius;
    if (opts.strength > 0) dparams.strength = opts.strength;
    auto input = buffers;
    if (method.find(":v=0") != std::string::npos) input.variance = {};
    auto start    = process_cpu_seconds();
    auto denoised = denoise_image(input, dparams);
    auto seconds  = process_cpu_seconds() - start;
    auto plain    = buffers;
    plain.albedo = {}, plain.normal = {}, plain.depth = {};
    auto no_features = denoise_image(plain, dparams);
    std::printf(
        "  %-16s relMSE %.5f (no features %.5f)  %.0f CPU ms/MP (%.1f%% of the "
        "render)\n",
        method.c_str(), rel_mse(denoised, reference),
        rel_mse(no_features, reference), 1000 * seconds / megapixels,
        100 * seconds / render_seconds);
    strip.push_back(denoised);
    if (opts.images)
      save_image(opts.out + "/" + name + "_" + method + ".exr",
          to_image(buffers.width, buffers.height, denoised));
  }
  for (auto threshold : opts.adaptive)
    bench_adaptive(*context, params, threshold, render_seconds / opts.samples,
        opts, reference);
  strip.push_back(high);
  strip.push_back(reference);
  // Error maps of the raw render and the first two denoisers.
  auto gain = (float)(0.25 / rel_mse(buffers.color, reference));
  for (size_t k = 0; k < std::min(strip.size() - 2, (size_t)3); k++)
    strip.push_back(error_map(strip[k], reference, gain));
  if (opts.images) {
    save_image(opts.out + "/" + name + "_raw.exr",
        to_image(buffers.width, buffers.height, buffers.color));
    save_image(opts.out + "/" + name + "_high.exr",
        to_image(buffers.width, buffers.height, high));
  }
  if (opts.images)
    save_strip(opts.out + "/" + name + "_strip.png", buffers.width,
        buffers.height, strip);
}

static std::vector<std::string> split(const std::string& text) {
  auto   parts = std::vector<std::string>{};
  size_t start = 0;
  while (start <= text.size()) {
    auto end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) parts.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return parts;
}

int main(int argc, const char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress when redirected
  try {
    auto opts = bench_options{};
    for (auto i = 1; i < argc; i++) {
      auto arg  = std::string{argv[i]};
      auto next = [&]() {
        if (i + 1 >= argc) throw std::runtime_error(arg + " needs a value");
        return std::string{argv[++i]};
      };
      if (arg == "--resolution")
        opts.resolution = std::atoi(next().c_str());
      else if (arg == "--reference-samples")
        opts.reference_samples = std::atoi(next().c_str());
      else if (arg == "--samples")
        opts.samples = std::atoi(next().c_str());
      else if (arg == "--radius")
        opts.radius = std::atoi(next().c_str());
      else if (arg == "--strength")
        opts.strength = std::atof(next().c_str());
      else if (arg == "--out")
        opts.out = next();
      else if (arg == "--files")
        opts.files = split(next());
      else if (arg == "--methods")
        opts.methods = split(next());
      else if (arg == "--images")
        opts.images = true;
      else if (arg == "--seeds")
        opts.seeds = std::max(1, std::atoi(next().c_str()));
      else if (arg == "--adaptive")
        for (auto& value : split(next()))
          opts.adaptive.push_back(std::stof(value));
      else
        throw std::runtime_error("unknown option " + arg);
    }
    if (opts.samples < 2) throw std::runtime_error("--samples must be >= 2");
    fs::create_directories(opts.out);
    auto files = opts.files;
    if (files.empty()) {
      for (auto example : {"materials/materials.json", "csg/csg.json"})
        files.push_back(
            std::string{IMPLICIT_SOURCE_DIR} + "/examples/" + example);
      for (auto seed :
          {"06_gridsdf/gridsdf.json", "07_sdfunction/sdfunction.json"}) {
        auto path =
            std::string{IMPLICIT_SHARED_DIR} + "/seed_scenes/tests/" + seed;
        if (fs::exists(path)) files.push_back(path);
      }
    }
    for (auto& file : files) bench_file(file, opts);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_denoise: %s\n", error.what());
    return 1;
  }
  return 0;
}
