// # implicit: path tracing and shaders
//
// The render parameters and one sample of one pixel: a camera ray, then the
// path tracer (`implicit`) or a debug shader. Nothing here loops over pixels
// or samples: the render core (render.h) does, in one place, for every front
// end. The data flow is: scene_data -> make_accel() + make_lights() (in a
// render_context) -> trace_sample() per pixel and sample.
#pragma once

#include <string>
#include <vector>

#include "../image/denoise.h"
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

// Per-pixel layers a render writes besides the image (AOVs, arbitrary output
// variables): the averaged features of pixel_sample and the variance of the
// pixel's mean. trace_params::aovs holds one bit per type (aov_bit()).
enum class aov_type { albedo, normal, depth, position, variance };
inline const std::vector<std::string> aov_type_names = {
    "albedo", "normal", "depth", "position", "variance"};
inline constexpr int aov_bit(aov_type aov) { return 1 << (int)aov; }

struct trace_params {
  int                camera       = 0;
  int                resolution   = 720;
  shader_type        shader       = shader_type::implicit;
  int                samples      = 512;
  int                bounces      = 4;
  float              clamp        = 10;
  uint64_t           seed         = 961748941;
  bool               envhidden    = false;
  bool               implicit_mis = true;            // false: --noimplicitmis
  mis_type           mis = mis_type::two_sample;     // less noise at equal time
  sampler_type       sampler = sampler_type::sobol;  // less noise per sample
  light_sampler_type light_sampler = light_sampler_type::bvh;  // many lights
  bool               tentfilter    = false;
  accel_type         accel         = accel_type::bvh;
  march_params       march         = {};
  int                pratio        = 8;  // viewer preview downscale
  float              exposure      = 0;  // output tone mapping, in stops (LDR)
  bool               filmic        = false;
  int                aovs          = 0;  // aov_bit()s of the layers to write
  // Adaptive sampling: a pixel stops once its relative error estimate is
  // below the threshold (0: off), checked from min_samples on (0: automatic).
  float noise_threshold = 0;
  int   min_samples     = 0;
  float time            = 0;  // budget in seconds per image (0: none)
  // Camera rays start where their block of pixels may first meet a surface
  // (camera_blocks.h); false: at the camera.
  bool           first_pass = true;
  bool           denoise    = false;  // images filtered by denoise_image()
  denoise_method denoiser   = denoise_method::nlm;  // with this method
};

// Whether the parameters ask for an AOV.
inline bool has_aov(const trace_params& params, aov_type aov) {
  return (params.aovs & aov_bit(aov)) != 0;
}

// -----------------------------------------------------------------------------
// SAMPLES
// -----------------------------------------------------------------------------

// What one sample of a pixel gives: its colour, and the features of its
// path that AOVs and the denoiser average over the pixel's samples. Albedo
// and normal are the first non-specular hit's (the path follows mirrors,
// glass and pass-through surfaces to it, as Open Image Denoise expects;
// in a medium, the first scattering event: its albedo, no normal); position
// and depth are the first surface the camera sees (the one that covers the
// pixel). Zero where there is none.
struct pixel_sample {
  vec4f color    = {0, 0, 0, 0};  // linear RGB (clamped, finite), coverage
  vec3f albedo   = {0, 0, 0};
  vec3f normal   = {0, 0, 0};  // world space, unit or zero
  vec3f position = {0, 0, 0};
  float depth    = 0;  // distance from the camera; 0: the camera sees nothing
};

// Sample `sample` of pixel `ij` of an image of `size` pixels seen by
// `camera`. `rng` is the pixel's random stream (the random sampler draws
// from it; the Sobol sampler derives its points from the seed, the pixel and
// `sample`); `evaluations` counts the SDF evaluations spent. The camera ray
// starts at `start` (camera_block_start(): no surface lies before it). The
// features cost a few copies per path: they are always computed. Thread-safe;
// allocates nothing. The render core (render.h) sums these over pixels and
// samples.
pixel_sample trace_sample(const scene_data& scene, const accel_data& accel,
    const lights_data& lights, const camera_data& camera,
    const trace_params& params, vec2i ij, vec2i size, int sample,
    rng_state& rng, int64_t& evaluations, float start = 0);

// Whether the shader needs lights (and falls back to eyelight without).
bool is_lit_shader(shader_type shader);

}  // namespace implicit
