// # bench_trace: tracing throughput, accelerated vs the seed's reference mode
//
// For each scene: camera rays (implicit_normal, 1 spp) and path tracing
// (implicit) with the default intersection and with `--accel none`, measured
// in the same run. Prints Mrays/s, SDF evaluations per ray, the speed ratio,
// the fraction of implicit_normal pixels equal within 1/255, and peak memory.
//
// Usage: bench_trace [--resolution N] [--samples N] [--skip-reference S] scene.json...

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "scene/scene_io.h"
#include "trace/trace.h"

using namespace implicit;

struct run_result {
  double     seconds     = 0;
  double     rays        = 0;  // pixel samples traced
  double     evaluations = 0;
  image_data image       = {};
};

// Render `samples` passes and measure them.
static run_result run(const scene_data& scene, trace_params params) {
  auto accel  = make_accel(scene, params.accel, params.march);
  auto lights = make_lights(scene, accel);
  auto state  = make_state(scene, params);
  auto start  = std::chrono::steady_clock::now();
  for (auto s = 0; s < params.samples; s++)
    trace_samples(state, scene, accel, lights, params);
  auto result    = run_result{};
  result.seconds = std::chrono::duration<double>(
      std::chrono::steady_clock::now() - start).count();
  result.rays = (double)state.width * state.height * params.samples;
  for (auto e : state.evaluations) result.evaluations += (double)e;
  result.image = get_render(state);
  return result;
}

// Fraction of pixels whose RGBA differ by at most `tolerance` per channel.
static double equal_fraction(const image_data& a, const image_data& b, float tolerance) {
  auto equal = 0;
  for (size_t i = 0; i < a.pixels.size(); i++) {
    auto pa = a.pixels[i], pb = b.pixels[i];
    if (std::abs(pa.x - pb.x) <= tolerance && std::abs(pa.y - pb.y) <= tolerance &&
        std::abs(pa.z - pb.z) <= tolerance && std::abs(pa.w - pb.w) <= tolerance)
      equal++;
  }
  return (double)equal / a.pixels.size();
}

static double peak_memory_mib() {
  auto usage = rusage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

int main(int argc, char** argv) {
  auto resolution = 360;
  auto samples    = 8;
  auto scenes     = std::vector<std::string>{};
  for (auto i = 1; i < argc; i++) {
    auto arg = std::string{argv[i]};
    if (arg == "--resolution" && i + 1 < argc) resolution = std::atoi(argv[++i]);
    else if (arg == "--samples" && i + 1 < argc) samples = std::atoi(argv[++i]);
    else scenes.push_back(arg);
  }
  if (scenes.empty()) {
    std::fprintf(stderr, "usage: bench_trace [--resolution N] [--samples N] scene.json...\n");
    return 1;
  }
  std::printf("| scene | mode | camera Mrays/s | evals/camera ray | path samples/s | evals/path sample | speedup camera | speedup path | normal image equal |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (auto& filename : scenes) {
    auto scene = scene_data{};
    try {
      scene = load_scene(filename);
    } catch (const std::exception& error) {
      std::fprintf(stderr, "bench_trace: %s\n", error.what());
      return 1;
    }
    auto base       = trace_params{};
    base.resolution = resolution;
    base.camera     = find_camera(scene, "");
    auto results    = std::vector<std::pair<run_result, run_result>>{};
    for (auto accel : {accel_type::bvh, accel_type::none}) {
      auto camera    = base;
      camera.accel   = accel;
      camera.shader  = shader_type::implicit_normal;
      camera.samples = 1;
      auto path      = base;
      path.accel     = accel;
      path.samples   = samples;
      results.push_back({run(scene, camera), run(scene, path)});
    }
    auto& fast = results[0];
    auto& slow = results[1];
    auto  same = equal_fraction(fast.first.image, slow.first.image, 1 / 255.0f);
    for (auto m = 0; m < 2; m++) {
      auto& r = results[m];
      std::printf("| %s | %s | %.3f | %.1f | %.0f | %.1f | %s | %s | %s |\n",
          filename.c_str(), m == 0 ? "bvh" : "none (seed)",
          r.first.rays / r.first.seconds / 1e6,
          r.first.evaluations / r.first.rays, r.second.rays / r.second.seconds,
          r.second.evaluations / r.second.rays,
          m == 0 ? std::to_string((slow.first.seconds / fast.first.seconds)).substr(0, 5).c_str() : "1",
          m == 0 ? std::to_string((slow.second.seconds / fast.second.seconds)).substr(0, 5).c_str() : "1",
          m == 0 ? (std::to_string(same * 100).substr(0, 6) + "%").c_str() : "-");
    }
  }
  std::printf("\npeak memory: %.1f MiB\n", peak_memory_mib());
  return 0;
}
