// # bench_grid: exact grid intersection vs sphere tracing the grid
//
//   bench_grid [GRID.sdf] [--resolution N] [--views N]
//
// Loads a grid (default: the seed's bunny), shoots camera rays from views
// around it (one thread, grid space) and prints, for the exact intersector
// and for plain sphere tracing of eval_grid (the seed's method, the
// reference), rays per second, work per ray and how often the two disagree.
// Both are measured in the same run.

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "sdf/sdf_grid.h"
#include "sdf/sdf_grid_io.h"

using namespace implicit;

namespace {

using bench_clock = std::chrono::steady_clock;

double seconds_since(bench_clock::time_point start) {
  return std::chrono::duration<double>(bench_clock::now() - start).count();
}

// Plain sphere tracing of the grid (Hart 1996): step by the value until it
// is below `epsilon` or the ray leaves [tmin, tmax]; counts evaluations.
bool sphere_trace_grid(const grid_data& grid, const ray3f& ray, float epsilon,
    int max_steps, float& t, int& steps) {
  t     = ray.tmin;
  steps = 0;
  while (t <= ray.tmax && steps < max_steps) {
    auto f = eval_grid(grid, ray_point(ray, t));
    steps++;
    if (f < epsilon) return true;
    t += f;
  }
  return false;
}

struct method_stats {
  double seconds   = 0;
  long   rays      = 0;
  long   hits      = 0;
  long   steps     = 0;
  long   box_steps = 0;  // work of the rays that cross the grid's box
};

// Camera rays from `views` cameras on a circle around the grid's box,
// looking at its centre.
std::vector<ray3f> make_view_rays(
    const bbox3f& box, int views, int resolution) {
  auto target = center(box);
  auto radius = length(size(box)) * 1.6f;
  auto rays   = std::vector<ray3f>{};
  for (auto v = 0; v < views; v++) {
    auto angle = 2 * pif * (v + 0.125f) / views;
    auto eye = target + vec3f{std::cos(angle), 0.35f, std::sin(angle)} * radius;
    auto camera = lookat_frame(eye, target, {0, 1, 0});
    auto half   = std::tan(radians(20.0f));
    for (auto j = 0; j < resolution; j++) {
      for (auto i = 0; i < resolution; i++) {
        auto u = ((i + 0.5f) / resolution * 2 - 1) * half;
        auto w = ((j + 0.5f) / resolution * 2 - 1) * half;
        auto d = normalize(camera.x * u + camera.y * w - camera.z);
        rays.push_back({eye, d, 0, radius * 4});
      }
    }
  }
  return rays;
}

// Trace every ray with `intersect(ray, t, steps)`; hit distances go to
// `hit_t` (-1: a miss).
template <class Intersect>
method_stats trace_rays(const std::vector<ray3f>& rays,
    const std::vector<bool>& in_box, std::vector<float>& hit_t,
    const Intersect& intersect) {
  auto stats = method_stats{};
  hit_t.assign(rays.size(), -1);
  auto start = bench_clock::now();
  for (auto r = size_t{0}; r < rays.size(); r++) {
    auto t     = 0.0f;
    auto steps = 0;
    if (intersect(rays[r], t, steps)) {
      stats.hits++;
      hit_t[r] = t;
    }
    stats.steps += steps;
    if (in_box[r]) stats.box_steps += steps;
  }
  stats.seconds = seconds_since(start);
  stats.rays    = (long)rays.size();
  return stats;
}

// The two methods' rates and work, relative to sphere tracing, and where
// their hits disagree.
void print_methods(const method_stats& sphere, const method_stats& exact,
    const std::vector<float>& sphere_t, const std::vector<float>& exact_t,
    float spacing, long box_rays) {
  auto mismatch = 0L;
  auto t_error  = 0.0;
  auto both     = 0L;
  for (auto r = size_t{0}; r < exact_t.size(); r++) {
    if ((exact_t[r] >= 0) != (sphere_t[r] >= 0)) mismatch++;
    if (exact_t[r] >= 0 && sphere_t[r] >= 0) {
      t_error += std::abs(exact_t[r] - sphere_t[r]) / spacing;
      both++;
    }
  }

  std::printf("%-24s %8s %8s %12s %15s %7s\n", "method", "Mrays/s", "hits",
      "work/ray", "work/box ray", "ratio");
  auto row = [&](const char* name, const method_stats& s, const char* unit) {
    auto rate = s.rays / s.seconds / 1e6;
    std::printf("%-24s %8.3f %8ld %6.2f %-5s %9.2f %-5s %6.2fx\n", name, rate,
        s.hits, (double)s.steps / s.rays, unit,
        (double)s.box_steps / std::max(box_rays, 1L), unit,
        rate / (sphere.rays / sphere.seconds / 1e6));
  };
  row("sphere tracing (seed)", sphere, "evals");
  row("exact (skip distances)", exact, "cells");
  std::printf(
      "\nhit/miss disagreements: %ld of %zu rays; mean |t_exact - "
      "t_sphere| = %.4f voxels\n",
      mismatch, exact_t.size(), both ? t_error / both : 0.0);
}

}  // namespace

int main(int argc, const char** argv) {
  auto filename = std::string(IMPLICIT_SHARED_DIR) +
                  "/seed_scenes/tests/06_gridsdf/sdfs/bunny.sdf";
  auto resolution = 512;
  auto views      = 4;
  for (auto i = 1; i < argc; i++) {
    auto arg = std::string(argv[i]);
    if (arg == "--resolution" && i + 1 < argc)
      resolution = std::stoi(argv[++i]);
    else if (arg == "--views" && i + 1 < argc)
      views = std::stoi(argv[++i]);
    else
      filename = arg;
  }

  // Load (best of 3) and memory.
  auto grid      = grid_data{};
  auto load_time = 1e30;
  for (auto r = 0; r < 3; r++) {
    auto start = bench_clock::now();
    grid       = load_grid(filename, grid_format_from_uri(filename, false));
    load_time  = std::min(load_time, seconds_since(start));
  }
  auto accel_start = bench_clock::now();
  update_grid_accel(grid);
  auto accel_time = seconds_since(accel_start);
  auto stats      = compute_grid_stats(grid);

  auto box  = grid_bounds(grid);
  auto rays = make_view_rays(box, views, resolution);

  // Which rays cross the grid's box (work is also reported for those).
  auto in_box   = std::vector<bool>(rays.size());
  auto box_rays = 0L;
  for (auto r = size_t{0}; r < rays.size(); r++) {
    auto t0 = 0.0f, t1 = 0.0f;
    in_box[r] = intersect_bbox(rays[r], box, t0, t1);
    box_rays += in_box[r];
  }

  // Exact intersection; sphere tracing, hit threshold 1e-3 voxel, at most
  // 1000 steps.
  auto exact_t = std::vector<float>{}, sphere_t = std::vector<float>{};
  auto exact = trace_rays(
      rays, in_box, exact_t, [&](const ray3f& ray, float& t, int& steps) {
        return intersect_grid(grid, ray, t, steps);
      });
  auto epsilon = 1e-3f * grid.spacing;
  auto sphere  = trace_rays(
       rays, in_box, sphere_t, [&](const ray3f& ray, float& t, int& steps) {
        return sphere_trace_grid(grid, ray, epsilon, 1000, t, steps);
      });
  std::printf("grid      %s\n", filename.c_str());
  std::printf("dims      %d x %d x %d, spacing %g, %lld surface voxels\n",
      grid.dims.x, grid.dims.y, grid.dims.z, grid.spacing,
      (long long)stats.surface_voxels);
  std::printf("load      %.1f ms (best of 3), accel build %.2f ms\n",
      load_time * 1e3, accel_time * 1e3);
  std::printf(
      "memory    %.2f MiB per grid (%.2f MiB samples + %.3f MiB skip "
      "distances and voxel bits)\n",
      grid_memory(grid) / 1048576.0,
      grid.values.size() * sizeof(float) / 1048576.0,
      (grid.block_skips.size() + grid.voxel_masks.size() * 2) / 1048576.0);
  std::printf(
      "rays      %d views x %d^2 = %zu camera rays (%ld cross the box), "
      "1 thread, grid space\n\n",
      views, resolution, rays.size(), box_rays);
  print_methods(sphere, exact, sphere_t, exact_t, grid.spacing, box_rays);
  return 0;
}
