// # bench_trace: tracing throughput, accelerated vs the seed's reference mode
//
// Scenes: generated clouds of 1, 10, 100, 1,000 and 10,000 random primitives
// (boxes, spheres, tori, capped cones; rotated, scaled unevenly; seeded) over
// a floor plane under an area light, plus the scene files given on the command
// line. For each scene, in one run and each in its own process (so that the
// peak memory is the scene's): camera rays (implicit_normal, 1 spp) and path
// tracing (implicit) with the default BVH and with `--accel none`; Mrays/s,
// path samples/s, SDF evaluations per ray, the speed ratios, the fraction of
// implicit_normal pixels equal within 1/255, path throughput with 1 and 2
// threads, and the peak memory. Speed ratios divide CPU times measured in the
// same run (robust when other processes share the cores); throughputs are
// per wall-clock second, and per CPU-second (all threads together), which
// does not depend on what else runs on the machine.
//
// The reference is first timed at 1/8 of the resolution; when the full run
// would take longer than --reference-limit seconds it is skipped, and the
// ratios come from the low-resolution runs of both modes (marked "~").
//
// Usage: bench_trace [--resolution N] [--samples N] [--counts 1,10,...]
//                    [--seed N] [--reference-limit S] [scene.json...]

#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "scene/scene_io.h"
#include "scene/scene_random.h"
#include "trace/render.h"

using namespace implicit;

// -----------------------------------------------------------------------------
// GENERATED SCENES
// -----------------------------------------------------------------------------

// `count` random primitives in the cube [-5,5]^3, each about a third of the
// spacing between them (so every count fills the cube alike), over a floor
// plane, under a square area light, in a sky.
static scene_data make_random_scene(int count, uint64_t seed) {
  auto scene = scene_data{};
  for (auto color : {vec3f{0.7f, 0.7f, 0.7f}, vec3f{0.8f, 0.3f, 0.2f},
           vec3f{0.2f, 0.5f, 0.8f}, vec3f{0.9f, 0.8f, 0.3f}}) {
    auto material  = material_data{};
    material.color = color;
    scene.materials.push_back(material);
  }
  scene.materials[2].type      = material_type::glossy;
  scene.materials[2].roughness = 0.3f;
  scene.materials[3].type      = material_type::reflective;
  scene.materials[3].roughness = 0.4f;
  auto light                   = material_data{};
  light.emission               = {30, 30, 30};
  scene.materials.push_back(light);

  auto spacing = 10 / std::cbrt((float)count);
  auto size    = 0.35f * spacing * (count == 1 ? 2.0f : 1.0f);
  add_random_primitives(scene, count, 5, size, 4, seed);
  auto floor               = sdf_function_data{};
  auto plane               = sdf_node{};
  plane.type               = sdf_type::plane;
  floor.name               = "floor";
  floor.program            = make_primitive_program(plane);
  floor.local_from_world.o = {0, 5.5f, 0};  // y = -5.5
  floor.material           = 0;
  scene.sdfunctions.push_back(floor);
  auto lamp               = sdf_function_data{};
  auto panel              = sdf_node{};
  panel.type              = sdf_type::box;
  panel.size              = {4, 1e-5f, 4};
  lamp.name               = "light";
  lamp.program            = make_primitive_program(panel);
  lamp.local_from_world.o = {2, -9, 2};  // corner at (-2, 9, -2)
  lamp.material           = 4;
  scene.sdfunctions.push_back(lamp);

  auto sky     = environment_data{};
  sky.emission = {0.3f, 0.35f, 0.4f};
  scene.environments.push_back(sky);
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({0, 9, 20}, {0, -1, 0}, {0, 1, 0});
  camera.focus  = 22.4f;
  camera.aspect = 1.5f;
  scene.cameras.push_back(camera);
  return scene;
}

// -----------------------------------------------------------------------------
// MEASUREMENT
// -----------------------------------------------------------------------------

struct run_result {
  double     seconds     = 0;  // wall clock
  double     cpu         = 0;  // process CPU time, all threads
  double     samples     = 0;  // pixel samples traced
  double     evaluations = 0;
  image_data image       = {};
};

// CPU time of the whole process (all threads).
static double cpu_seconds() {
  auto now = timespec{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

// Render `params.samples` passes and time them (the context is built
// outside).
static run_result run(const render_context& context, const trace_params& params,
    int threads = 0) {
  auto control = std::unique_ptr<tbb::global_control>{};
  if (threads > 0)
    control = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, (size_t)threads);
  auto state     = make_render_state(context, params);
  auto start     = std::chrono::steady_clock::now();
  auto cpu_start = cpu_seconds();
  for (auto s = 0; s < params.samples; s++) render_step(context, state);
  auto result = run_result{};
  result.cpu  = cpu_seconds() - cpu_start;
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  result.samples = (double)state.width * state.height * params.samples;
  for (auto e : state.buffer.evaluations) result.evaluations += (double)e;
  result.image = get_image(state);
  return result;
}

// Fraction of pixels whose RGBA differ by at most `tolerance` per channel.
static double equal_fraction(
    const image_data& a, const image_data& b, float tolerance) {
  auto equal = 0;
  for (size_t i = 0; i < a.pixels.size(); i++) {
    auto pa = a.pixels[i], pb = b.pixels[i];
    if (std::abs(pa.x - pb.x) <= tolerance &&
        std::abs(pa.y - pb.y) <= tolerance &&
        std::abs(pa.z - pb.z) <= tolerance &&
        std::abs(pa.w - pb.w) <= tolerance)
      equal++;
  }
  return a.pixels.empty() ? 1 : (double)equal / a.pixels.size();
}

static double peak_memory_mib() {
  auto usage = rusage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

static double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

struct bench_options {
  int    resolution      = 256;
  int    samples         = 4;
  double reference_limit = 60;
};

// Format helpers for the table.
static std::string fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

// What bench_scene() measured of one scene.
struct scene_runs {
  run_result fast_camera = {}, fast_path = {}, one_thread = {},
             two_threads = {};
  run_result  ref_camera = {}, ref_path = {};  // scaled when skipped
  double      estimate = 0;                    // seconds of the reference
  bool        skipped  = false;
  std::string equal    = "-";  // camera pixels equal to the reference's
};

// The reference mode's runs: timed at 1/8 of the resolution first, then at
// full resolution unless that would take longer than the limit; else the
// low-resolution runs scaled by the BVH's own low-to-full ratio (like with
// like).
static void run_reference(const render_context& fast,
    const render_context& slow, const trace_params& camera,
    const trace_params& path, const bench_options& options, scene_runs& runs) {
  auto low_camera       = camera;
  auto low_path         = path;
  low_camera.resolution = std::max(8, options.resolution / 8);
  low_path.resolution   = low_camera.resolution;
  low_path.samples      = 1;
  auto low_ref_camera   = run(slow, low_camera);
  auto low_ref_path     = run(slow, low_path);
  runs.estimate =
      low_ref_camera.seconds / low_ref_camera.samples *
          runs.fast_camera.samples +
      low_ref_path.seconds / low_ref_path.samples * runs.fast_path.samples;
  runs.skipped = runs.estimate > options.reference_limit;
  if (!runs.skipped) {
    runs.ref_camera = run(slow, camera);
    runs.ref_path   = run(slow, path);
    runs.equal      = fixed(100 * equal_fraction(runs.fast_camera.image,
                                      runs.ref_camera.image, 1 / 255.0f),
                          2) +
                 "%";
    return;
  }
  auto low_fast_camera = run(fast, low_camera);
  auto low_fast_path   = run(fast, low_path);
  auto scale_to        = [](run_result ref, const run_result& low_fast,
                      const run_result& fast_run) {
    ref.seconds = ref.seconds / low_fast.seconds * fast_run.seconds;
    ref.cpu     = ref.cpu / low_fast.cpu * fast_run.cpu;
    ref.evaluations *= fast_run.samples / ref.samples;
    ref.samples = fast_run.samples;
    return ref;
  };
  runs.ref_camera = scale_to(low_ref_camera, low_fast_camera, runs.fast_camera);
  runs.ref_path   = scale_to(low_ref_path, low_fast_path, runs.fast_path);
}

// One table row (see main's header).
static void print_scene_row(const std::string& name, int objects,
    double build_ms, const scene_runs& runs) {
  auto mrays = [](const run_result& r) { return r.samples / r.seconds / 1e6; };
  auto evals = [](const run_result& r) { return r.evaluations / r.samples; };
  auto per_cpu = [](const run_result& r) { return r.samples / r.cpu / 1e6; };
  auto mark    = runs.skipped ? std::string{"~"} : std::string{""};
  auto note    = runs.skipped ? " (reference est. " + fixed(runs.estimate, 0) +
                                 " s: skipped)"
                              : std::string{""};
  // Two threads against one: wall clock, and CPU time per sample (what two
  // free cores would give; the wall ratio suffers when the cores are shared).
  auto& one = runs.one_thread;
  auto& two = runs.two_threads;
  std::printf(
      "| %s%s | %d | %.1f | %.3f | %.3f | %.1f | %.4f | %.4f | %.1f "
      "| %s%.1f | %s%.1f | %s%.0fx | %s%.0fx | %s | %.4f | %.4f | %.2f "
      "| %.2f | %.0f |\n",
      name.c_str(), note.c_str(), objects, build_ms, mrays(runs.fast_camera),
      per_cpu(runs.fast_camera), evals(runs.fast_camera), mrays(runs.fast_path),
      per_cpu(runs.fast_path), evals(runs.fast_path), mark.c_str(),
      evals(runs.ref_camera), mark.c_str(), evals(runs.ref_path), mark.c_str(),
      runs.ref_camera.cpu / runs.fast_camera.cpu, mark.c_str(),
      runs.ref_path.cpu / runs.fast_path.cpu, runs.equal.c_str(), mrays(one),
      mrays(two), one.seconds / two.seconds, 2 * one.cpu / two.cpu,
      peak_memory_mib());
  std::fflush(stdout);
}

// Measure one scene and print its table row. Speed ratios divide CPU times
// (robust on a shared machine); throughputs are per wall-clock second and
// per CPU-second.
static void bench_scene(const std::string& name, const scene_data& scene,
    const bench_options& options) {
  auto base       = trace_params{};
  base.resolution = options.resolution;
  base.camera     = find_camera(scene, "");
  auto camera     = base;
  camera.shader   = shader_type::implicit_normal;
  camera.samples  = 1;
  auto path       = base;
  path.samples    = options.samples;

  auto build_start  = std::chrono::steady_clock::now();
  auto fast_ptr     = make_render_context(scene_data{scene}, base);
  auto build_ms     = seconds_since(build_start) * 1000;
  auto slow_params  = base;
  slow_params.accel = accel_type::none;
  auto  slow_ptr    = make_render_context(scene_data{scene}, slow_params);
  auto& fast        = *fast_ptr;

  // Warm up the thread pool and the caches.
  auto warm       = path;
  warm.resolution = std::max(8, options.resolution / 8);
  warm.samples    = 1;
  run(fast, warm);

  auto runs        = scene_runs{};
  runs.fast_camera = run(fast, camera);
  runs.fast_path   = run(fast, path);
  runs.one_thread  = run(fast, path, 1);
  runs.two_threads = run(fast, path, 2);
  run_reference(fast, *slow_ptr, camera, path, options, runs);
  print_scene_row(name, (int)fast.accel.objects.size(), build_ms, runs);
}

// Run `work` in a child process, so that its peak memory is its own.
template <typename Work>
static bool in_child(const Work& work) {
  std::fflush(stdout);
  auto pid = fork();
  if (pid == 0) {
    auto code = 0;
    try {
      work();
    } catch (const std::exception& error) {
      std::fprintf(stderr, "bench_trace: %s\n", error.what());
      code = 1;
    }
    std::fflush(stdout);
    _exit(code);
  }
  auto status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

static std::string load_average() {
  auto file = std::ifstream{"/proc/loadavg"};
  auto a = std::string{}, b = std::string{}, c = std::string{};
  file >> a >> b >> c;
  return a + " " + b + " " + c;
}

int main(int argc, char** argv) {
  auto options = bench_options{};
  auto counts  = std::vector<int>{1, 10, 100, 1000, 10000};
  auto seed    = (uint64_t)7;
  auto scenes  = std::vector<std::string>{};
  for (auto i = 1; i < argc; i++) {
    auto arg  = std::string{argv[i]};
    auto next = [&]() { return i + 1 < argc ? std::string{argv[++i]} : ""; };
    if (arg == "--resolution") {
      options.resolution = std::atoi(next().c_str());
    } else if (arg == "--samples") {
      options.samples = std::atoi(next().c_str());
    } else if (arg == "--reference-limit") {
      options.reference_limit = std::atof(next().c_str());
    } else if (arg == "--seed") {
      seed = (uint64_t)std::atoll(next().c_str());
    } else if (arg == "--counts") {
      counts.clear();
      auto list = next();
      for (size_t pos = 0; pos < list.size();) {
        auto comma = list.find(',', pos);
        if (comma == std::string::npos) comma = list.size();
        if (comma > pos)
          counts.push_back(std::atoi(list.substr(pos, comma - pos).c_str()));
        pos = comma + 1;
      }
    } else if (arg.rfind("--", 0) == 0) {
      std::fprintf(stderr,
          "usage: bench_trace [--resolution N] [--samples N] [--counts "
          "1,10,...] "
          "[--seed N] [--reference-limit S] [scene.json...]\n");
      return 1;
    } else {
      scenes.push_back(arg);
    }
  }
  std::printf(
      "resolution %d, path tracing %d spp (4 bounces), camera rays 1 spp "
      "implicit_normal; %d hardware threads; load average %s\n\n",
      options.resolution, options.samples,
      (int)tbb::global_control::active_value(
          tbb::global_control::max_allowed_parallelism),
      load_average().c_str());
  std::printf(
      "| scene | objects | BVH build ms | camera Mrays/s | camera Mrays/CPU-s "
      "| evals/camera ray | path Msamples/s | path Msamples/CPU-s "
      "| evals/path sample | ref evals/camera ray "
      "| ref evals/path sample | camera vs ref | path vs ref | normals equal "
      "| path Msamples/s, 1 thread | 2 threads | 2 threads / 1 (wall) "
      "| 2 threads / 1 (CPU) | peak MiB |\n");
  std::printf(
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---"
      "|---|---|\n");
  auto ok = true;
  for (auto count : counts) {
    ok &= in_child([&]() {
      auto scene = make_random_scene(count, seed);
      bench_scene("random " + std::to_string(count), scene, options);
    });
  }
  for (auto& filename : scenes) {
    ok &= in_child([&]() {
      auto scene = load_scene(filename);
      add_missing_camera(scene, make_accel(scene, accel_type::none, {}).bounds);
      bench_scene(filename, scene, options);
    });
  }
  std::printf("\nload average after: %s\n", load_average().c_str());
  return ok ? 0 : 1;
}
