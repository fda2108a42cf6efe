// # implicit: rendering
//
// Render parameters, the progressive render state and the shaders. The data
// flow is: scene_data -> make_accel() + make_lights() -> make_state() ->
// trace_samples() (one sample per pixel per call) -> get_render(). The CLI
// and the viewer drive the same functions.
#pragma once

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
    "implicit_normal", "eyelight", "normal", "position", "color",
    "frontfacing", "material", "steps"};

// How `implicit` combines light and BSDF sampling: the seed's one-sample
// mixture (balance heuristic), or two samples with the power heuristic.
enum class mis_type { one_sample, two_sample };
inline const std::vector<std::string> mis_type_names = {"one", "two"};

struct trace_params {
  int         camera       = 0;
  int         resolution   = 720;
  shader_type shader       = shader_type::implicit;
  int         samples      = 512;
  int         bounces      = 4;
  float       clamp        = 10;
  uint64_t    seed         = 961748941;
  bool        envhidden    = false;
  bool        implicit_mis = true;  // false: --noimplicitmis
  mis_type    mis          = mis_type::one_sample;
  bool        tentfilter   = false;
  accel_type  accel        = accel_type::bvh;
  march_params march       = {};
  int         pratio       = 8;  // viewer preview downscale
};

// -----------------------------------------------------------------------------
// STATE
// -----------------------------------------------------------------------------

// Accumulated samples and per-pixel random streams.
struct trace_state {
  int                    width       = 0;
  int                    height      = 0;
  int                    samples     = 0;
  std::vector<vec4f>     accumulated = {};
  std::vector<rng_state> rngs        = {};
  std::vector<int64_t>   evaluations = {};  // SDF evaluations per pixel
};

// Size the state for the camera and resolution and seed the generators.
trace_state make_state(const scene_data& scene, const trace_params& params);

// Add one sample to every pixel (parallel over tiles; the result does not
// depend on the thread count).
void trace_samples(trace_state& state, const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const trace_params& params);

// Average of the samples so far (linear RGBA, alpha = coverage).
image_data get_render(const trace_state& state);

// One sample of pixel (i, j); exposed for tests and the viewer's preview.
vec4f trace_pixel(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const trace_params& params, int i, int j,
    int width, int height, rng_state& rng, int64_t& evaluations);

// Whether the shader needs lights (and falls back to eyelight without).
bool is_lit_shader(shader_type shader);

}  // namespace implicit
