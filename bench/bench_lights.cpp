// # bench_lights: noise and cost of light sampling, per scene and strategy
//
// For each scene, a reference of many samples (two-sample MIS, the light
// tree; cached in the output folder), then per strategy `--runs` renders of
// `--samples` spp with independent seeds, alternating between strategies
// (run 1 of each, then run 2 of each, ...). Printed per strategy:
// - relMSE at equal samples: mean over pixels and channels of
//   (x - ref)^2 / (ref^2 + 0.01), averaged over the runs (it does not
//   depend on the machine's load);
// - CPU seconds per sample per pixel (median over the runs; the process's
//   user CPU time, by default on one thread (`--threads`), so that other
//   processes on a shared machine count less than in wall time);
// - relMSE at equal time: relMSE at equal samples times the CPU time of a
//   sample, i.e. the relMSE of a render of 1 CPU-second per megapixel
//   (both unbiased: relMSE falls as 1 / samples), and its ratio to the
//   first strategy's.
// Scenes: `room`, a room lit only by an emissive torus and an emissive CSG
// lamp (light sampling on vs off; before every emitter was sampled, both
// were BSDF sampling alone), and `spheres`, 1,000 small emissive spheres
// over a floor (light tree vs power vs uniform picking). With
// `--baseline PATH`, also scene files rendered by two ypathtrace programs
// through their command line (this build's and PATH, e.g. an older build),
// timed by the children's CPU time minus that of a 1-spp render (loading
// and building excluded): `--files` (default: examples/sdfunction and the
// seed's two scenes when ../shared has them).
//
// Usage: bench_lights [--scenes room,spheres] [--resolution N]
//        [--reference-samples N] [--samples N] [--runs N] [--bounces N]
//        [--out DIR] [--baseline PATH] [--files a.json,b.json]
//        [--images]   (also equal-time PNGs of every strategy, in --out)
//        [--strategies 0,2]   (only these strategies of each scene)
//        [--threads N]   (render threads of the timed runs; default 1, the
//                         reference uses every core)

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <tbb/global_control.h>

#include "image/image_io.h"
#include "math/random.h"
#include "scene/scene_io.h"
#include "trace/render.h"

using namespace implicit;
namespace fs = std::filesystem;

// -----------------------------------------------------------------------------
// SCENES
// -----------------------------------------------------------------------------

static sdf_node make_node(sdf_type type) {
  auto node = sdf_node{};
  node.type = type;
  return node;
}

static sdf_function_data make_function(
    const sdf_program& program, vec3f origin, int material) {
  auto function             = sdf_function_data{};
  function.program          = program;
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -origin};
  function.material         = material;
  return function;
}

static sdf_function_data make_box(vec3f min, vec3f max, int material) {
  auto box = make_node(sdf_type::box);
  box.size = max - min;
  return make_function(make_primitive_program(box), min, material);
}

static material_data matte(vec3f color) {
  auto material  = material_data{};
  material.color = color;
  return material;
}

static material_data emissive(vec3f emission) {
  auto material     = material_data{};
  material.emission = emission;
  return material;
}

static camera_data look_at(vec3f from, vec3f to, float aspect) {
  auto camera   = camera_data{};
  camera.frame  = lookat_frame(from, to, {0, 1, 0});
  camera.aspect = aspect;
  camera.focus  = length(from - to);
  return camera;
}

// A room 4 x 2.5 x 4 open toward the camera, a matte ball and a glossy box,
// lit by a ring (torus) under the ceiling and a lava lamp (a smooth union of
// three spheres, one CSG object) in a corner.
static scene_data room_scene() {
  auto scene       = scene_data{};
  auto glossy      = matte({0.2f, 0.3f, 0.6f});
  glossy.type      = material_type::glossy;
  glossy.roughness = 0.3f;
  scene.materials  = {matte({0.7f, 0.7f, 0.7f}), matte({0.7f, 0.3f, 0.2f}),
       glossy, emissive({12, 10, 8}), emissive({4, 12, 6})};
  scene.sdfunctions.push_back(make_box({-2, -0.1f, -2}, {2, 0, 2}, 0));
  scene.sdfunctions.push_back(make_box({-2, 2.5f, -2}, {2, 2.6f, 2}, 0));
  scene.sdfunctions.push_back(make_box({-2, 0, -2.1f}, {2, 2.5f, -2}, 0));
  scene.sdfunctions.push_back(make_box({-2.1f, 0, -2}, {-2, 2.5f, 2}, 1));
  scene.sdfunctions.push_back(make_box({2, 0, -2}, {2.1f, 2.5f, 2}, 0));
  auto ball   = make_node(sdf_type::sphere);
  ball.radius = 0.45f;
  scene.sdfunctions.push_back(
      make_function(make_primitive_program(ball), {-0.7f, 0.45f, -0.4f}, 0));
  scene.sdfunctions.push_back(make_box({0.3f, 0, -0.9f}, {1, 0.7f, -0.2f}, 2));
  auto ring    = make_node(sdf_type::torus);
  ring.radius  = 0.4f;
  ring.radius2 = 0.03f;
  scene.sdfunctions.push_back(
      make_function(make_primitive_program(ring), {0, 2.1f, -0.6f}, 3));
  auto lamp  = sdf_program{};
  auto blob  = make_node(sdf_type::sphere);
  auto parts = std::vector<int>{};
  for (auto k = 0; k < 3; k++) {
    blob.radius = 0.09f - 0.02f * k;
    auto sphere = add_node(lamp, blob);
    auto lift =
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.03f * k, -0.16f * k, 0}};
    parts.push_back(add_transform(lamp, sphere, lift));
  }
  auto smooth  = make_node(sdf_type::op_smooth_union);
  smooth.blend = 0.08f;
  fold_sdf_operands(lamp, parts, smooth);
  scene.sdfunctions.push_back(make_function(lamp, {1.5f, 0.15f, -1.5f}, 4));
  scene.cameras.push_back(look_at({0, 1.4f, 5.5f}, {0, 1.1f, 0}, 4.0f / 3));
  return scene;
}

// 1,000 small emissive spheres of assorted colours and strengths hovering
// over a floor of 10 x 10, with two matte balls among them.
static scene_data spheres_scene() {
  auto scene      = scene_data{};
  scene.materials = {matte({0.6f, 0.6f, 0.6f}), matte({0.8f, 0.8f, 0.8f})};
  scene.sdfunctions.push_back(make_box({-5, -0.1f, -5}, {5, 0, 5}, 0));
  auto ball   = make_node(sdf_type::sphere);
  ball.radius = 0.5f;
  scene.sdfunctions.push_back(
      make_function(make_primitive_program(ball), {-0.8f, 0.5f, 0}, 1));
  scene.sdfunctions.push_back(
      make_function(make_primitive_program(ball), {1.2f, 0.5f, -1.5f}, 1));
  auto rng = make_rng(2018);
  for (auto k = 0; k < 1000; k++) {
    auto hue      = rand1f(rng);
    auto strength = std::pow(10.0f, rand1f(rng));
    auto color    = vec3f{0.5f + 0.5f * std::cos(2 * pif * hue),
        0.5f + 0.5f * std::cos(2 * pif * (hue - 0.33f)),
        0.5f + 0.5f * std::cos(2 * pif * (hue - 0.67f))};
    scene.materials.push_back(emissive(color * strength));
    ball.radius = 0.01f + 0.03f * rand1f(rng);
    auto x      = 9 * rand1f(rng) - 4.5f;
    auto y      = 0.05f + 0.6f * rand1f(rng);
    auto z      = 9 * rand1f(rng) - 4.5f;
    scene.sdfunctions.push_back(make_function(make_primitive_program(ball),
        {x, y, z}, (int)scene.materials.size() - 1));
  }
  scene.cameras.push_back(look_at({0, 3.5f, 6}, {0, 0, -0.8f}, 4.0f / 3));
  return scene;
}

// -----------------------------------------------------------------------------
// MEASURES
// -----------------------------------------------------------------------------

// Relative MSE of an image against a reference, over the pixels where
// `mask` is true (all when it is empty).
static double rel_mse(const image_data& image, const image_data& reference,
    const std::vector<bool>& mask = {}) {
  auto sum   = 0.0;
  auto count = 0;
  for (size_t i = 0; i < image.pixels.size(); i++) {
    if (!mask.empty() && !mask[i]) continue;
    for (auto c = 0; c < 3; c++) {
      auto x = (double)(&image.pixels[i].x)[c];
      auto r = (double)(&reference.pixels[i].x)[c];
      sum += (x - r) * (x - r) / (r * r + 0.01);
    }
    count += 3;
  }
  return count ? sum / count : 0;
}

// Pixels that see no emitter directly (their centre and four corners hit
// something that emits nothing, or nothing): the noise of the others is
// mostly the pixel filter's over an emitter's edge, the same for every
// light strategy.
static std::vector<bool> unlit_pixel_mask(
    const render_context& context, const trace_params& params) {
  auto size   = render_size(context, params);
  auto mask   = std::vector<bool>((size_t)size.x * size.y, true);
  auto camera = context.scene.cameras.at(params.camera);
  for (auto j = 0; j < size.y; j++) {
    for (auto i = 0; i < size.x; i++) {
      for (auto corner : {vec2f{0.5f, 0.5f}, vec2f{0, 0}, vec2f{1, 0},
               vec2f{0, 1}, vec2f{1, 1}}) {
        auto uv   = vec2f{(i + corner.x) / size.x, (j + corner.y) / size.y};
        auto isec = intersect_scene(
            context.accel, params.march, eval_camera(camera, uv, {0, 0}));
        if (!isec.hit) continue;
        auto material = context.accel.objects[isec.object].material;
        if (material >= 0 &&
            max(context.scene.materials[material].emission) > 0)
          mask[(size_t)j * size.x + i] = false;
      }
    }
  }
  return mask;
}

// User CPU time: the kernel's share (page faults, scheduling) grows with
// the machine's load, not with the work of a sample.
static double process_cpu_seconds() {
  auto usage = rusage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec;
}

static double children_cpu_seconds() {
  auto usage = rusage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec;
}

static double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  auto n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// One strategy's results.
struct strategy_result {
  std::string         name    = "";
  std::vector<double> errors  = {};  // relMSE per run
  std::vector<double> unlit   = {};  // the same, no emitter in view
  std::vector<double> seconds = {};  // CPU seconds per run
  int                 samples = 0;
  int                 pixels  = 0;
  // CPU seconds per sample per megapixel.
  double cost() const { return median(seconds) / samples / (pixels * 1e-6); }
};

static double mean(const std::vector<double>& values) {
  auto sum = 0.0;
  for (auto value : values) sum += value;
  return values.empty() ? 0 : sum / values.size();
}

static void print_table(
    const std::string& title, const std::vector<strategy_result>& results) {
  std::printf("\n%s\n\n", title.c_str());
  std::printf(
      "| strategy | relMSE at %d spp: all pixels, no emitter in view | CPU s / "
      "spp / Mpixel | relMSE at 1 CPU-s / Mpixel: all, no emitter in view | "
      "less than the first: all, no emitter in view |\n"
      "|---|---|---|---|---|\n",
      results.empty() ? 0 : results[0].samples);
  auto first = 0.0, first_unlit = 0.0;
  for (auto& r : results) {
    auto error = mean(r.errors), unlit = mean(r.unlit);
    auto time = r.samples * r.cost();
    if (first == 0) {
      first       = error * time;
      first_unlit = unlit * time;
    }
    std::printf("| %s | %.4g, %.4g | %.3g | %.4g, %.4g | %.2fx, %.2fx |\n",
        r.name.c_str(), error, unlit, r.cost(), error * time, unlit * time,
        first / (error * time), first_unlit / (unlit * time));
  }
  std::fflush(stdout);
}

// -----------------------------------------------------------------------------
// IN-PROCESS STRATEGIES
// -----------------------------------------------------------------------------

struct options {
  std::vector<std::string> scenes            = {"room", "spheres"};
  std::vector<std::string> files             = {};
  std::string              out               = "bench_lights_out";
  std::string              baseline          = "";
  int                      resolution        = 160;
  int                      reference_samples = 4096;
  int                      samples           = 16;
  int                      runs              = 8;
  int                      bounces           = 4;
  int                      threads           = 1;
  bool                     images            = false;
  std::vector<int>         only              = {};  // strategy indices
};

struct strategy {
  std::string  name   = "";
  trace_params params = {};
};

static image_data render_timed(const render_context& context,
    const trace_params& params, double& seconds) {
  auto image = image_data{};
  auto start = process_cpu_seconds();
  render_image(context, params, image);
  seconds = process_cpu_seconds() - start;
  return image;
}

// The reference of a scene: loaded from `path` if there, else rendered.
static image_data reference_image(const render_context& context,
    trace_params params, int samples, const std::string& path) {
  if (fs::exists(path)) {
    auto image = load_image(path);
    if (image.width == render_size(context, params).x) return image;
  }
  params.samples = samples;
  params.seed    = 99991;
  auto seconds   = 0.0;
  auto image     = render_timed(context, params, seconds);
  save_image(path, image);
  save_image(fs::path(path).replace_extension(".png").string(), image);
  std::printf(
      "(reference %s: %d spp, %.0f CPU s)\n", path.c_str(), samples, seconds);
  return image;
}

// Equal-time images: each strategy gets the samples the first one renders
// in its time, from the costs measured; saved one by one and as a strip
// (the strategies left to right, then the reference).
static void save_equal_time_images(const render_context& context,
    const std::vector<strategy>&                         strategies,
    const std::vector<strategy_result>& results, const image_data& reference,
    const std::string& prefix) {
  auto images = std::vector<image_data>{};
  for (size_t k = 0; k < strategies.size(); k++) {
    auto params = strategies[k].params;
    params.samples =
        std::max(1, (int)std::lround(results[0].samples * results[0].cost() /
                                     results[k].cost()));
    auto seconds = 0.0;
    images.push_back(render_timed(context, params, seconds));
    auto name = prefix + "_" + std::to_string(k) + ".png";
    save_image(name, images.back());
    std::printf("(%s: %s, %d spp)\n", name.c_str(), strategies[k].name.c_str(),
        params.samples);
  }
  images.push_back(reference);
  auto gap   = 4;
  auto strip = make_image(
      (int)images.size() * (reference.width + gap) - gap, reference.height);
  for (size_t k = 0; k < images.size(); k++)
    for (auto j = 0; j < reference.height; j++)
      for (auto i = 0; i < reference.width; i++)
        pixel(strip, (int)k * (reference.width + gap) + i, j) =
            pixel(images[k], i, j);
  save_image(prefix + "_strip.png", strip);
}

static void bench_scene(const std::string& name, scene_data scene,
    const std::vector<strategy>& strategies, const options& opts) {
  auto base                      = strategies[0].params;
  auto context                   = make_render_context(std::move(scene), base);
  auto reference_params          = base;
  reference_params.mis           = mis_type::two_sample;
  reference_params.light_sampler = light_sampler_type::bvh;
  reference_params.implicit_mis  = true;
  auto reference =
      reference_image(*context, reference_params, opts.reference_samples,
          opts.out + "/" + name + "_reference_" +
              std::to_string(opts.resolution) + ".exr");
  auto mask    = unlit_pixel_mask(*context, base);
  auto results = std::vector<strategy_result>(strategies.size());
  auto threads = tbb::global_control(
      tbb::global_control::max_allowed_parallelism,
      opts.threads > 0 ? opts.threads : std::thread::hardware_concurrency());
  for (size_t k = 0; k < strategies.size(); k++) {
    results[k].name    = strategies[k].name;
    results[k].samples = opts.samples;
    results[k].pixels  = reference.width * reference.height;
  }
  for (auto run = 0; run < opts.runs; run++) {
    for (size_t k = 0; k < strategies.size(); k++) {
      auto params    = strategies[k].params;
      params.samples = opts.samples;
      params.seed    = 7919 * (uint64_t)(run + 1);
      auto seconds   = 0.0;
      auto image     = render_timed(*context, params, seconds);
      results[k].errors.push_back(rel_mse(image, reference));
      results[k].unlit.push_back(rel_mse(image, reference, mask));
      results[k].seconds.push_back(seconds);
    }
  }
  print_table("Scene `" + name + "`, " + std::to_string(reference.width) + "x" +
                  std::to_string(reference.height) + ", " +
                  std::to_string(base.bounces) + " bounces, reference " +
                  std::to_string(opts.reference_samples) + " spp, " +
                  std::to_string(opts.runs) + " runs",
      results);
  if (opts.images)
    save_equal_time_images(
        *context, strategies, results, reference, opts.out + "/" + name);
}

// -----------------------------------------------------------------------------
// COMMAND-LINE STRATEGIES (two programs)
// -----------------------------------------------------------------------------

// Run `program` on a scene file; returns its CPU time (-1 on failure).
static double run_cli(const std::string& program, const std::string& scene,
    const std::string& output, int resolution, int samples, int bounces,
    uint64_t seed, int threads) {
  auto command = "'" + program + "' --scene '" + scene + "' --output '" +
                 output + "' --resolution " + std::to_string(resolution) +
                 " --samples " + std::to_string(samples) + " --bounces " +
                 std::to_string(bounces) + " --seed " + std::to_string(seed) +
                 " --threads " + std::to_string(threads) +
                 " --clamp 1e30 --quiet";
  auto start  = children_cpu_seconds();
  auto status = std::system(command.c_str());
  if (status != 0) return -1;
  return children_cpu_seconds() - start;
}

static void bench_file(
    const std::string& file, const options& opts, const std::string& current) {
  auto programs = std::vector<std::string>{current, opts.baseline};
  auto names =
      std::vector<std::string>{"this build", "baseline " + opts.baseline};
  auto stem      = fs::path(file).stem().string();
  auto reference = opts.out + "/" + stem + "_reference_" +
                   std::to_string(opts.resolution) + ".exr";
  if (!fs::exists(reference))
    run_cli(current, file, reference, opts.resolution, opts.reference_samples,
        opts.bounces, 99991, 0);
  auto ref          = load_image(reference);
  auto params       = trace_params{};
  params.resolution = opts.resolution;
  auto context      = make_render_context(load_scene(file), params);
  auto warnings     = std::vector<std::string>{};
  params            = resolve_params(*context, params, "", warnings);
  auto mask         = unlit_pixel_mask(*context, params);
  auto results      = std::vector<strategy_result>(2);
  auto output       = opts.out + "/" + stem + "_run.exr";
  // The CPU time of loading and building: a 1-spp render.
  auto setup = std::vector<double>(2, 0.0);
  for (auto k = 0; k < 2; k++) {
    auto times = std::vector<double>{};
    for (auto r = 0; r < 3; r++)
      times.push_back(run_cli(programs[k], file, output, opts.resolution, 1,
          opts.bounces, 1, opts.threads));
    setup[k]           = median(times);
    results[k].name    = names[k];
    results[k].samples = opts.samples;
    results[k].pixels  = ref.width * ref.height;
  }
  for (auto run = 0; run < opts.runs; run++) {
    for (auto k = 0; k < 2; k++) {
      auto seconds = run_cli(programs[k], file, output, opts.resolution,
          opts.samples, opts.bounces, 7919 * (uint64_t)(run + 1), opts.threads);
      results[k].seconds.push_back(seconds - setup[k]);
      auto image = load_image(output);
      results[k].errors.push_back(rel_mse(image, ref));
      results[k].unlit.push_back(rel_mse(image, ref, mask));
    }
  }
  print_table("Scene file `" + file + "` through the command line, " +
                  std::to_string(ref.width) + "x" + std::to_string(ref.height) +
                  ", " + std::to_string(opts.bounces) + " bounces, " +
                  std::to_string(opts.runs) + " runs",
      results);
}

// -----------------------------------------------------------------------------
// MAIN
// -----------------------------------------------------------------------------

static std::vector<std::string> split_commas(const std::string& text) {
  auto items = std::vector<std::string>{};
  auto start = size_t{0};
  while (start <= text.size()) {
    auto end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) items.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return items;
}

static options parse_options(int argc, char** argv) {
  auto opts = options{};
  for (auto i = 1; i < argc; i++) {
    auto arg  = std::string{argv[i]};
    auto next = [&] { return i + 1 < argc ? std::string{argv[++i]} : ""; };
    if (arg == "--scenes") opts.scenes = split_commas(next());
    if (arg == "--files") opts.files = split_commas(next());
    if (arg == "--out") opts.out = next();
    if (arg == "--baseline") opts.baseline = next();
    if (arg == "--resolution") opts.resolution = std::atoi(next().c_str());
    if (arg == "--reference-samples")
      opts.reference_samples = std::atoi(next().c_str());
    if (arg == "--samples") opts.samples = std::atoi(next().c_str());
    if (arg == "--runs") opts.runs = std::max(1, std::atoi(next().c_str()));
    if (arg == "--bounces") opts.bounces = std::atoi(next().c_str());
    if (arg == "--images") opts.images = true;
    if (arg == "--threads") opts.threads = std::atoi(next().c_str());
    if (arg == "--strategies")
      for (auto& k : split_commas(next()))
        opts.only.push_back(std::atoi(k.c_str()));
  }
  return opts;
}

// Strategies of a generated scene.
static std::vector<strategy> scene_strategies(
    const std::string& name, const trace_params& params) {
  auto with = [&](const std::string& label, auto edit) {
    auto p = params;
    edit(p);
    return strategy{label, p};
  };
  if (name == "room")
    return {with("light sampling off (BSDF only; before: every emitter here)",
                [](trace_params& p) { p.implicit_mis = false; }),
        with("light sampling on (two-sample MIS, light tree)",
            [](trace_params&) {}),
        with("light sampling on (one-sample MIS, light tree)",
            [](trace_params& p) { p.mis = mis_type::one_sample; })};
  return {with("uniform picking (the seed's)",
              [](trace_params& p) {
                p.light_sampler = light_sampler_type::uniform;
              }),
      with("power picking",
          [](trace_params& p) { p.light_sampler = light_sampler_type::power; }),
      with("light tree", [](trace_params&) {})};
}

int main(int argc, char** argv) {
  auto opts = parse_options(argc, argv);
  fs::create_directories(opts.out);
  auto params       = trace_params{};
  params.resolution = opts.resolution;
  params.bounces    = opts.bounces;
  params.clamp      = 1e30f;
  try {
    for (auto& name : opts.scenes) {
      auto scene      = name == "room" ? room_scene() : spheres_scene();
      auto strategies = scene_strategies(name, params);
      if (!opts.only.empty()) {
        auto chosen = std::vector<strategy>{};
        for (auto k : opts.only)
          if (k >= 0 && k < (int)strategies.size())
            chosen.push_back(strategies[k]);
        strategies = chosen;
      }
      bench_scene(name, std::move(scene), strategies, opts);
    }
    if (opts.baseline.empty()) return 0;
    auto current =
        (fs::path(argv[0]).parent_path().parent_path() / "ypathtrace").string();
    auto files = opts.files;
    if (files.empty()) {
      files.push_back(std::string{IMPLICIT_SOURCE_DIR} +
                      "/examples/sdfunction/sdfunction.json");
      for (auto seed :
          {"06_gridsdf/gridsdf.json", "07_sdfunction/sdfunction.json"}) {
        auto path =
            std::string{IMPLICIT_SHARED_DIR} + "/seed_scenes/tests/" + seed;
        if (fs::exists(path)) files.push_back(path);
      }
    }
    for (auto& file : files) bench_file(file, opts, current);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_lights: %s\n", error.what());
    return 1;
  }
  return 0;
}
