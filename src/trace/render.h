// # implicit: the render core every front end drives
//
// A render_context owns the scene (moved in) and builds the acceleration
// structure and the lights once; afterwards nothing changes it, so threads
// share it by const reference. The fallback policies (camera by name, a
// camera added when the scene has none, eyelight for a scene without
// emitters) and the one validation of the render parameters live here: the
// CLI, the viewer, the Python module and MPI ranks only parse, display and
// write.
//
// One render loop: render_pixels() adds samples [s0, s1) of one camera to a
// rectangle of pixels held in a render_buffer. Progressive steps (viewer,
// Python), whole images, tiles and sample batches of MPI ranks and frames of
// sequences all call it, through render_samples() when in parallel.
//
// Determinism: every pixel has its own random stream (derived from its
// index) and sums its samples 0, 1, 2, ... in that order into one vec4f, then
// the sum is multiplied by 1 / samples (average_samples()). So an image
// rendered pass by pass, as a whole, or tile by tile in any order, tile size
// and sample ranges (one rank per tile) is the same to the byte, at any
// thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "../image/denoise.h"
#include "trace.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CONTEXT
// -----------------------------------------------------------------------------

// The scene and what is built from it once. Not copyable; front ends share
// one by const reference, so make_render_context() hands out a unique_ptr.
struct render_context {
  scene_data  scene        = {};
  accel_data  accel        = {};
  lights_data lights       = {};
  bool        has_emitters = false;  // lights or emissive objects

  render_context()                                 = default;
  render_context(const render_context&)            = delete;
  render_context& operator=(const render_context&) = delete;
};

// Take the scene, build accel (params.accel, `build`) and lights, and add a
// camera framing the scene when it has none. Nothing in the context depends
// on the other parameters: renders with any of them share it.
std::unique_ptr<const render_context> make_render_context(scene_data&& scene,
    const trace_params& params, const accel_params& build = {});

// Refuse parameters out of range (sizes, counts) or not finite (clamp,
// exposure, march parameters): throws io_error naming the parameter.
void validate_params(const trace_params& params);

// The parameters to render with: validated, the camera found by name (empty:
// as Yocto/GL finds it), and the eyelight shader for a lit shader in a scene
// without emitters (a warning is appended to `warnings`, never printed).
trace_params resolve_params(const render_context& context,
    const trace_params& params, const std::string& camera_name,
    std::vector<std::string>& warnings);

// Image size of the parameters' camera and resolution.
vec2i render_size(const render_context& context, const trace_params& params);

// -----------------------------------------------------------------------------
// BUFFERS
// -----------------------------------------------------------------------------

// Columns [x0, x1) and rows [y0, y1) of an image.
struct render_rect {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
};

// Pixels in a rectangle.
inline size_t rect_pixels(const render_rect& rect) {
  return (size_t)(rect.x1 - rect.x0) * (size_t)(rect.y1 - rect.y0);
}

// Which per-pixel data a buffer keeps besides sums, streams and counts: each
// costs memory and a few additions per sample, so only what a render reads.
struct buffer_layout {
  bool statistics = false;  // squares and even sums (variance, adaptive)
  bool albedo     = false;
  bool normal     = false;
  bool depth      = false;  // depth and hit counts
  bool position   = false;  // positions (and depth, for the hit counts)
  // Each pixel's random stream and evaluation count: a buffer rendered into
  // needs them, one that only gathers finished tiles (a frame's, whose
  // tiles bring their streams) does not.
  bool streams = true;
};

// The layout the parameters' AOVs need.
buffer_layout render_layout(const trace_params& params);

// What a render keeps per pixel for the pixels of `rect` (a whole image or
// a tile), each array row-major over the rectangle. render_pixels() is the
// one writer: per-pixel data a render adds is one more array here, filled
// there. Arrays of the layout's data not kept are empty. Every sum adds the
// pixel's samples in sample order, so it is the same however the samples
// were cut into passes, blocks, tiles and ranks.
struct render_buffer {
  render_rect            rect        = {};
  std::vector<vec4f>     sums        = {};  // summed samples (RGB, coverage)
  std::vector<rng_state> rngs        = {};  // each pixel's random stream
  std::vector<int64_t>   evaluations = {};  // SDF evaluations spent
  std::vector<int>       counts      = {};  // samples summed
  // Statistics: summed squared RGB, and summed RGB of the even-numbered
  // samples (0, 2, 4, ...: half buffer A; the odd ones are sums - evens).
  std::vector<vec3f> squares = {};
  std::vector<vec3f> evens   = {};
  // Summed features of the samples (pixel_sample); depths holds the summed
  // depth and the samples that hit a surface, which positions share.
  std::vector<vec3f> albedos   = {};
  std::vector<vec3f> normals   = {};
  std::vector<vec2f> depths    = {};
  std::vector<vec3f> positions = {};
};

// Call `visit(a, b)` with each pair of per-pixel arrays of two buffers that
// travel with a buffer's pixels (all but evaluations, which only count), in
// one fixed order: pack, unpack and copy visit them through this one list.
template <typename A, typename B, typename Visit>
inline void visit_pixel_arrays(A& a, B& b, const Visit& visit) {
  visit(a.sums, b.sums);
  visit(a.rngs, b.rngs);
  visit(a.counts, b.counts);
  visit(a.squares, b.squares);
  visit(a.evens, b.evens);
  visit(a.albedos, b.albedos);
  visit(a.normals, b.normals);
  visit(a.depths, b.depths);
  visit(a.positions, b.positions);
}

// Copy the pixels that both rectangles hold from `from` into `to`, for each
// array `from` keeps (`to` gets the array if it lacks it; zero elsewhere).
void copy_pixels(const render_buffer& from, render_buffer& to);

// The random stream of pixel `index` (row-major in the image): the stream id
// is the index, so no two pixels of any image share a stream.
rng_state make_pixel_rng(uint64_t seed, size_t index);

// A buffer for `rect` of an image `width` pixels wide: zero sums and counts,
// each pixel's own stream, and the arrays of `layout`.
render_buffer make_render_buffer(const render_rect& rect, int width,
    uint64_t seed, const buffer_layout& layout = {});

// ADAPTIVE SAMPLING. A pixel's error estimate is the standard error of its
// mean relative to the mean, as relative MSE weighs it: the square root of
// the mean over RGB of variance / (mean^2 + 0.01), so that values below 0.1
// count as 0.1 (Cycles divides by the square root of the mean instead, which
// stops dark pixels early and bright ones late: on the seed's grid scene it
// lost to uniform sampling at equal time); from the sample variance, which
// stays stable where the half-buffer difference of one pixel is itself
// noisy. A pixel is tested before samples
// adaptive_min_samples(), then every adaptive_step() samples, from its own
// data only, and stops once its estimate is below params.noise_threshold:
// where a render cuts its samples into passes, tiles or ranks never changes
// which pixels stop where.
float pixel_error(const render_buffer& buffer, size_t idx);
int   adaptive_min_samples(const trace_params& params);
int   adaptive_step(const trace_params& params);
// Whether pixel `idx` stops before sample `sample`.
bool is_converged(const render_buffer& buffer, size_t idx,
    const trace_params& params, int sample);

// The one render loop: add samples [s0, s1) of `camera` to every pixel of
// `rect` (within buffer.rect), each pixel's samples in order. A pixel that
// holds fewer than s0 samples stopped earlier (adaptive sampling) and is
// left alone; one that converges stops. The image size is the camera's at
// params.resolution.
// Single-threaded; parameters are not validated (render_samples() and the
// functions below do that).
void render_pixels(const render_context& context, const trace_params& params,
    const camera_data& camera, const render_rect& rect, int s0, int s1,
    render_buffer& buffer);

// The image of a buffer: each pixel's sum * (1 / its count), the one
// division of every render path (0 for a pixel without samples).
image_data average_samples(const render_buffer& buffer);

// The denoiser's buffers (image/denoise.h) of a whole-image buffer that
// keeps the statistics and features (render_layout() with params.denoise):
// means, half-buffer means, variance of the mean, albedo, normal, depth and
// counts per pixel.
denoise_buffers make_denoise_buffers(const render_buffer& buffer);

// The image of a buffer, denoised when params.denoise (alpha stays the
// average coverage): what every front end shows or writes.
image_data output_image(
    const render_buffer& buffer, const trace_params& params);

// The layer of one AOV of a buffer, averaged like the image and named as
// OpenEXR multi-layer files and Blender name them: albedo (R, G, B) and
// normal (X, Y, Z) average every sample (misses add zero); depth (Z) and
// position (X, Y, Z) the samples that hit (0 where none did); variance
// (R, G, B) is the variance of the pixel's mean per channel (sample
// variance / count; 0 below 2 samples). Throws io_error when the buffer does
// not keep the data.
image_layer average_layer(const render_buffer& buffer, aov_type aov);

// The layers of the parameters' AOVs, in the order of aov_type.
std::vector<image_layer> average_layers(
    const render_buffer& buffer, const trace_params& params);

// -----------------------------------------------------------------------------
// PARALLEL RENDERS
// -----------------------------------------------------------------------------

// Called once per finished block of pixels with the pixel samples done so
// far and the total, from any thread but never two at once.
using render_progress = void (*)(void* user, int64_t done, int64_t total);
// Asked before each block; true stops the render.
using render_cancel = bool (*)(void* user);

struct render_callbacks {
  render_progress progress = nullptr;
  render_cancel   cancel   = nullptr;
  void*           user     = nullptr;
};

// Most samples per pixel in one pass of render_samples(): a block must stay
// short for a cancel to take effect soon, and a pixel's samples in a row find
// in cache what the previous one read.
inline constexpr int max_pass_samples = 64;

// Add samples [s0, s1) to every pixel of the buffer with all threads: passes
// of at most max_pass_samples, each render_pixels() over blocks of pixels in
// parallel, asking callbacks.cancel before each block. Returns false when
// cancelled: the buffer then holds part of a pass and must be discarded.
// Throws io_error for invalid parameters.
bool render_samples(const render_context& context, const trace_params& params,
    const camera_data& camera, int s0, int s1, render_buffer& buffer,
    const render_callbacks& callbacks = {});

// -----------------------------------------------------------------------------
// PROGRESSIVE (viewer, Python) AND WHOLE IMAGES
// -----------------------------------------------------------------------------

// Samples accumulated so far in every pixel of an image, for one camera and
// one set of parameters.
struct render_state {
  trace_params  params  = {};
  camera_data   camera  = {};
  int           width   = 0;
  int           height  = 0;
  int           samples = 0;   // in every pixel
  render_buffer buffer  = {};  // the whole image
};

// A state for the parameters' camera, or for `camera` (the viewer's).
render_state make_render_state(
    const render_context& context, const trace_params& params);
render_state make_render_state(const render_context& context,
    const trace_params& params, const camera_data& camera);

// Add `samples` samples to every pixel (render_samples()). Returns false
// when cancelled: the state then holds a partial pass and must be discarded.
bool render_step(const render_context& context, render_state& state,
    int samples = 1, const render_callbacks& callbacks = {});

// The average so far (linear RGBA, alpha = coverage).
image_data get_image(const render_state& state);

// Render the whole image: params.samples samples per pixel in one
// render_step(). Returns false, leaving `image` untouched, when cancelled.
bool render_image(const render_context& context, const trace_params& params,
    image_data& image, const render_callbacks& callbacks = {});

}  // namespace implicit
