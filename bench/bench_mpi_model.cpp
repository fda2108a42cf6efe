// # bench_mpi_model: predicted scaling of distributed rendering
//
// Measures what each tile of a frame costs (all samples of its pixels on one
// thread, CPU time, so the numbers do not depend on what else runs) and the
// per-rank setup (load, acceleration structure, lights), then simulates
// ypathtrace's distributed render on P ranks: rank 0 hands out tiles on
// demand in row order and renders too; every tile crosses rank 0's network
// link twice (out as a 44-byte header, back with its sums, 16 bytes a pixel:
// one batch, no --savebatch), and the link carries one message at a time.
// Prints the predicted time and efficiency (serial time / (P x time)) at 16, 64
// and 256 ranks.
//
// Usage: bench_mpi_model [--resolution N] [--samples N] [--tilesize N]
//                        [--spp N] [--gbits X] [--latency-us X] [scene.json...]
// The tiles are timed at --samples and scaled to --spp samples per pixel.

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <queue>
#include <string>
#include <tuple>
#include <vector>

#include "scene/scene_io.h"
#include "trace/render.h"

using namespace implicit;

namespace {

// CPU seconds of the calling thread.
double thread_seconds() {
  auto now = timespec{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

struct model_options {
  int                      resolution = 640;
  int                      samples    = 4;
  int                      tile_size  = 64;
  int                      spp        = 256;
  double                   gbits      = 10;
  double                   latency    = 50e-6;
  std::vector<std::string> scenes     = {};
};

struct tile_cost {
  double seconds = 0;  // all samples of the tile, one thread
  double bytes   = 0;  // out and back
};

// Per-tile costs of one frame and the setup time of one rank.
std::vector<tile_cost> measure_tiles(const std::string& filename,
    const model_options& options, double& setup_seconds) {
  auto start        = thread_seconds();
  auto params       = trace_params{};
  params.resolution = options.resolution;
  params.samples    = options.samples;
  auto context      = make_render_context(load_scene(filename), params);
  auto warnings     = std::vector<std::string>{};
  params            = resolve_params(*context, params, "", warnings);
  setup_seconds     = thread_seconds() - start;
  auto  size        = render_size(*context, params);
  auto  scale       = (double)options.spp / options.samples;
  auto  costs       = std::vector<tile_cost>{};
  auto& camera      = context->scene.cameras[params.camera];
  for (auto y = 0; y < size.y; y += options.tile_size) {
    for (auto x = 0; x < size.x; x += options.tile_size) {
      auto tile   = render_rect{x, std::min(x + options.tile_size, size.x), y,
          std::min(y + options.tile_size, size.y)};
      auto t0     = thread_seconds();
      auto buffer = make_render_buffer(tile, size.x, params.seed);
      render_pixels(*context, params, camera, tile, 0, params.samples, buffer);
      auto pixels = (double)(tile.x1 - tile.x0) * (tile.y1 - tile.y0);
      costs.push_back({(thread_seconds() - t0) * scale, 2 * 44 + 16 * pixels});
    }
  }
  return costs;
}

// Seconds of a frame on `ranks` ranks: events in time order, each rank
// asking for its next tile when it is free; a request from another rank
// costs the link its result and the next tile, one message at a time.
double simulate(const std::vector<tile_cost>& tiles, int ranks,
    double setup_seconds, const model_options& options) {
  auto bandwidth = options.gbits * 1e9 / 8;  // bytes per second
  // (time, rank, tile it finished or -1); rank 0 loads first, the others
  // load the broadcast copy after it.
  using event = std::tuple<double, int, int>;
  auto queue = std::priority_queue<event, std::vector<event>, std::greater<>>{};
  queue.push({setup_seconds, 0, -1});
  for (auto rank = 1; rank < ranks; rank++)
    queue.push({2 * setup_seconds, rank, -1});
  auto link_free = 0.0, end = 0.0;
  auto next     = size_t{0};
  auto transfer = [&](int tile) {
    return tile < 0 ? 0 : options.latency + tiles[tile].bytes / 2 / bandwidth;
  };
  while (!queue.empty()) {
    auto [time, rank, finished] = queue.top();
    queue.pop();
    auto tile  = next < tiles.size() ? (int)next++ : -1;
    auto start = time;
    if (rank > 0) {
      link_free =
          std::max(time, link_free) + transfer(finished) + transfer(tile);
      start = link_free;
    }
    end = std::max(end, start);
    if (tile >= 0) queue.push({start + tiles[tile].seconds, rank, tile});
  }
  return end;
}

}  // namespace

int main(int argc, char** argv) {
  auto options = model_options{};
  for (auto i = 1; i < argc; i++) {
    auto arg  = std::string{argv[i]};
    auto next = [&]() { return i + 1 < argc ? argv[++i] : "0"; };
    if (arg == "--resolution")
      options.resolution = std::atoi(next());
    else if (arg == "--samples")
      options.samples = std::atoi(next());
    else if (arg == "--tilesize")
      options.tile_size = std::atoi(next());
    else if (arg == "--spp")
      options.spp = std::atoi(next());
    else if (arg == "--gbits")
      options.gbits = std::atof(next());
    else if (arg == "--latency-us")
      options.latency = std::atof(next()) * 1e-6;
    else
      options.scenes.push_back(arg);
  }
  if (options.scenes.empty())
    options.scenes = {"examples/sdfunction/sdfunction.json",
        "examples/materials/materials.json", "examples/csg/csg.json"};
  auto control =
      tbb::global_control(tbb::global_control::max_allowed_parallelism, 1);
  std::printf(
      "%d px wide, %d spp (timed at %d), %d px tiles, %.0f Gb/s, %.0f us "
      "latency\n\n",
      options.resolution, options.spp, options.samples, options.tile_size,
      options.gbits, options.latency * 1e6);
  std::printf(
      "| scene | tiles | tile cost min/mean/max (s) | setup (s) | 1 rank (s) "
      "| MB sent/frame | 16 ranks | 64 ranks | 256 ranks |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (auto& filename : options.scenes) {
    try {
      auto setup = 0.0;
      auto tiles = measure_tiles(filename, options, setup);
      auto total = setup, low = 1e30, high = 0.0, bytes = 0.0;
      for (auto& tile : tiles) {
        total += tile.seconds;
        low  = std::min(low, tile.seconds);
        high = std::max(high, tile.seconds);
        bytes += tile.bytes;
      }
      std::printf("| %s | %d | %.3f / %.3f / %.3f | %.3f | %.1f | %.1f |",
          filename.c_str(), (int)tiles.size(), low,
          (total - setup) / tiles.size(), high, setup, total, bytes / 1e6);
      for (auto ranks : {16, 64, 256}) {
        auto seconds = simulate(tiles, ranks, setup, options);
        std::printf(
            " %.2f s, %.0f%% |", seconds, 100 * total / (ranks * seconds));
      }
      std::printf("\n");
    } catch (const std::exception& error) {
      std::fprintf(stderr, "bench_mpi_model: %s\n", error.what());
      return 1;
    }
  }
  return 0;
}
