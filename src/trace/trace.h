// # implicit: rendering
//
// Render parameters, the progressive render state and the shaders. The data
// flow is: scene_data -> make_accel() + make_lights() -> make_state() ->
// trace_samples() (one sample per pixel per call) -> get_render(). The CLI
// and the viewer drive the same functions.
#pragma once

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <string>
#include <vector>

#include "../image/image.h"
#include "../math/random.h"
#include "accel.h"
#include "lights.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

// Shaders: the seed's two, then the debug views Yocto/GL users expect.
enum class shader_type {
  // clang-format off
  implicit, implicit_normal, eyelight, normal, position, color, frontfacing,
  material, steps
  // clang-format on
};
inline const std::vector<std::string> shader_type_names = {"implicit",
    "implicit_normal", "eyelight", "normal", "position", "color", "frontfacing",
    "material", "steps"};

// How `implicit` combines light and BSDF sampling: the seed's one-sample
// mixture (balance heuristic), or two samples with the power heuristic.
enum class mis_type { one_sample, two_sample };
inline const std::vector<std::string> mis_type_names = {"one", "two"};

// Where the random numbers of a path come from: scrambled Sobol points
// (stratified per pixel, less noise) or independent PCG32 numbers (Yocto's).
enum class sampler_type { sobol, random };
inline const std::vector<std::string> sampler_type_names = {"sobol", "random"};

struct trace_params {
  int          camera       = 0;
  int          resolution   = 720;
  shader_type  shader       = shader_type::implicit;
  int          samples      = 512;
  int          bounces      = 4;
  float        clamp        = 10;
  uint64_t     seed         = 961748941;
  bool         envhidden    = false;
  bool         implicit_mis = true;                  // false: --noimplicitmis
  mis_type     mis          = mis_type::two_sample;  // less noise at equal time
  sampler_type sampler      = sampler_type::sobol;   // less noise per sample
  bool         tentfilter   = false;
  accel_type   accel        = accel_type::bvh;
  march_params march        = {};
  int          pratio       = 8;  // viewer preview downscale
  float        exposure     = 0;  // output tone mapping, in stops (LDR)
  bool         filmic       = false;
};

// -----------------------------------------------------------------------------
// STATE
// -----------------------------------------------------------------------------

// Accumulated samples and per-pixel random streams, for one camera.
struct trace_state {
  trace_params           params      = {};
  camera_data            camera      = {};
  int                    width       = 0;
  int                    height      = 0;
  int                    samples     = 0;
  std::vector<vec4f>     accumulated = {};
  std::vector<rng_state> rngs        = {};
  std::vector<int64_t>   evaluations = {};  // SDF evaluations per pixel
};

// Size the state for the camera and resolution and seed the generators.
trace_state make_state(const scene_data& scene, const trace_params& params);
trace_state make_state(const camera_data& camera, const trace_params& params);

// The random stream of pixel `index` (row-major): the stream id is the index,
// so no two pixels of any image share a stream.
rng_state make_pixel_rng(uint64_t seed, size_t index);

// Add one sample to the pixels of columns [i0, i1) and rows [j0, j1).
void trace_tile(trace_state& state, const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const trace_params& params, int i0, int i1, int j0, int j1);

// Add one sample to every pixel (parallel over tiles; the result does not
// depend on the thread count).
void trace_samples(trace_state& state, const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const trace_params& params);

// The same, asking `cancelled()` before each 16x16 tile (the viewer restarts
// renders this way). Returns false when it stopped early: the state then
// holds a partial pass and must be discarded.
template <typename Cancelled>
inline bool trace_samples_until(trace_state& state, const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const trace_params& params, const Cancelled& cancelled) {
  auto stopped = std::atomic<bool>{false};
  auto range =
      tbb::blocked_range2d<int>(0, state.height, 16, 0, state.width, 16);
  tbb::parallel_for(range, [&](const tbb::blocked_range2d<int>& tile) {
    if (stopped.load(std::memory_order_relaxed) || cancelled()) {
      stopped.store(true, std::memory_order_relaxed);
      return;
    }
    trace_tile(state, scene, accel, lights, params, tile.cols().begin(),
        tile.cols().end(), tile.rows().begin(), tile.rows().end());
  });
  if (stopped.load()) return false;
  state.samples += 1;
  return true;
}

// Average of the samples so far (linear RGBA, alpha = coverage).
image_data get_render(const trace_state& state);

// Render a whole image in one call: accel, lights, state, params.samples
// passes (for tests, benchmarks and programs that need no progress).
image_data trace_image(const scene_data& scene, const trace_params& params);

// Add samples [first, first + count) of pixel (i, j), in sample order, to
// `accumulated`; `rng` is the pixel's stream for the random sampler. The one
// pixel loop of every render path (so they agree to the byte).
void trace_pixel_samples(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const camera_data& camera,
    const trace_params& params, int i, int j, int width, int height, int first,
    int count, vec4f& accumulated, rng_state& rng, int64_t& evaluations);

// The average of `samples` summed samples (sum * (1 / samples)): the one
// division of every render path.
vec4f average_samples(vec4f accumulated, int samples);

// Whether the shader needs lights (and falls back to eyelight without).
bool is_lit_shader(shader_type shader);

}  // namespace implicit
