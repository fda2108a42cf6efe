// # bench_large: one object of many CSG operands (issue 11)
//
// For N operands of a hard union (spheres and boxes), a smooth union
// (spheres blended with 0.6 x their spacing) and a slab minus N cylinders,
// each one sdfunction filling the same cube: the build time and memory of
// the union parts and the pruning octrees, the time per camera ray
// (implicit_normal, 1 spp) and per path sample (implicit, 1 spp: up to
// `bounces` segments), SDF evaluations per camera ray, and for N = 1,000 the
// reference mode (`--accel none`, the whole tree at every step) and its
// ratio. Single-threaded, CPU time, so that other processes sharing the
// machine count little.
//
// Usage: bench_large [--resolution N] [--counts 100,1000,...]
//                    [--reference-count N] [--models hard_union,...]

#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "scene/scene_random.h"
#include "sdf/sdf_models.h"
#include "trace/render.h"

using namespace implicit;

// One sdfunction with the model, a matte material, a sky, a camera.
static scene_data make_scene(sdf_model_type type, int count) {
  auto material  = material_data{};
  material.color = {0.7f, 0.6f, 0.5f};
  return make_model_scene(make_sdf_model(type, count, 7), material);
}

static double cpu_seconds() {
  auto now = timespec{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

struct run_result {
  double seconds     = 0;  // CPU
  double samples     = 0;
  double evaluations = 0;
};

static run_result run(const render_context& context, trace_params params) {
  auto state = make_render_state(context, params);
  auto start = cpu_seconds();
  render_step(context, state, params.samples);
  auto result    = run_result{};
  result.seconds = cpu_seconds() - start;
  result.samples = (double)state.width * state.height * params.samples;
  for (auto e : state.buffer.evaluations) result.evaluations += (double)e;
  return result;
}

// Bytes of the objects and their fields.
static double accel_mib(const accel_data& accel) {
  auto bytes = (double)(accel.objects.size() * sizeof(trace_object));
  for (auto& object : accel.objects)
    if (object.field) bytes += (double)sdf_field_bytes(*object.field);
  return bytes / (1024.0 * 1024.0);
}

static std::vector<int> parse_counts(const char* text) {
  auto counts = std::vector<int>{};
  for (auto p = text; *p;) {
    counts.push_back(std::atoi(p));
    while (*p && *p != ',') p++;
    if (*p == ',') p++;
  }
  return counts;
}

int main(int argc, char** argv) {
  auto resolution      = 48;
  auto counts          = std::vector<int>{100, 1000, 10000, 100000};
  auto reference_count = 1000;
  auto models          = std::string{"hard_union,smooth_union,perforated_slab"};
  for (auto i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--resolution")) {
      resolution = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--counts")) {
      counts = parse_counts(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--models")) {
      models = argv[i + 1];
    } else if (!std::strcmp(argv[i], "--reference-count")) {
      reference_count = std::atoi(argv[i + 1]);
    } else {
      std::fprintf(stderr, "bench_large: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  auto control =
      tbb::global_control{tbb::global_control::max_allowed_parallelism, 1};
  std::printf(
      "| model | N | build s | accel MiB | objects | camera us/ray | "
      "evals/ray | path us/sample | vs N=%d | reference us/ray | "
      "reference / bvh |\n",
      counts.front());
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (auto type : {sdf_model_type::hard_union, sdf_model_type::smooth_union,
           sdf_model_type::perforated_slab}) {
    if (models.find(sdf_model_type_names[(int)type]) == std::string::npos)
      continue;
    auto first = 0.0;
    for (auto count : counts) {
      auto scene        = make_scene(type, count);
      auto camera       = trace_params{};
      camera.resolution = resolution;
      camera.shader     = shader_type::implicit_normal;
      camera.samples    = 1;
      auto path         = camera;
      path.shader       = shader_type::implicit;
      auto build_start  = cpu_seconds();
      auto context      = make_render_context(scene_data{scene}, camera);
      auto build        = cpu_seconds() - build_start;
      auto rays         = run(*context, camera);
      auto paths        = run(*context, path);
      auto per_ray      = rays.seconds / rays.samples * 1e6;
      if (count == counts.front()) first = per_ray;
      auto reference = std::string{"-"}, ratio = std::string{"-"};
      if (count == reference_count) {
        auto none  = camera;
        none.accel = accel_type::none;
        auto slow  = make_render_context(scene_data{scene}, none);
        auto ref   = run(*slow, none);
        auto us    = ref.seconds / ref.samples * 1e6;
        char buffer[64];
        std::snprintf(buffer, sizeof(buffer), "%.1f", us);
        reference = buffer;
        std::snprintf(buffer, sizeof(buffer), "%.1fx", us / per_ray);
        ratio = buffer;
      }
      std::printf(
          "| %s | %d | %.2f | %.1f | %zu | %.1f | %.1f | %.1f | %.2fx | %s | "
          "%s |\n",
          sdf_model_type_names[(int)type].c_str(), count, build,
          accel_mib(context->accel), context->accel.objects.size(), per_ray,
          rays.evaluations / rays.samples, paths.seconds / paths.samples * 1e6,
          per_ray / first, reference.c_str(), ratio.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
