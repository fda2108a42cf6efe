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
// Determinism: every pixel has its own random stream (derived from its
// index) and sums its samples 0, 1, 2, ... in that order into one vec4f, then
// the sum is multiplied by 1 / samples. So an image rendered pass by pass, as
// a whole, or tile by tile in any order and tile size (render_tile(), one
// rank per tile) is the same to the byte, at any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

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
// TILES (MPI ranks)
// -----------------------------------------------------------------------------

// Columns [x0, x1) and rows [y0, y1) of the image.
struct render_tile_rect {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
};

// Render samples [0, params.samples) of every pixel of `tile`, summed in
// sample order into `accumulated` (row-major over the tile, resized to its
// pixel count). Single-threaded: callers parallelise over tiles.
void render_tile(const render_context& context, const trace_params& params,
    const render_tile_rect& tile, std::vector<vec4f>& accumulated);

// The image of `samples` accumulated samples per pixel (width * height
// sums, row-major), divided as every front end divides: average_samples().
image_data average_samples(
    const std::vector<vec4f>& accumulated, int width, int height, int samples);

// -----------------------------------------------------------------------------
// WHOLE IMAGES (CLI, Python)
// -----------------------------------------------------------------------------

// Called once per finished tile with the pixels done so far and the total,
// from any thread but never two at once.
using render_progress = void (*)(void* user, int64_t done, int64_t total);
// Asked before each tile; true stops the render.
using render_cancel = bool (*)(void* user);

struct render_callbacks {
  render_progress progress = nullptr;
  render_cancel   cancel   = nullptr;
  void*           user     = nullptr;
};

// Render the whole image, tiles in parallel (each with all its samples).
// Returns false, leaving `image` untouched, when cancelled.
bool render_image(const render_context& context, const trace_params& params,
    image_data& image, const render_callbacks& callbacks = {});

// -----------------------------------------------------------------------------
// PROGRESSIVE (CLI batches, viewer, Python)
// -----------------------------------------------------------------------------

// Samples accumulated so far, for one camera and one set of parameters
// (trace.h's trace_state: the parameters, the camera, the sums, the per-pixel
// streams and SDF evaluation counts).
using render_state = trace_state;

// A state for the parameters' camera, or for `camera` (the viewer's).
render_state make_render_state(
    const render_context& context, const trace_params& params);
render_state make_render_state(const render_context& context,
    const trace_params& params, const camera_data& camera);

// Add `samples` samples to every pixel (in parallel over tiles), asking
// callbacks.cancel before each tile. Returns false when cancelled: the
// state then holds a partial pass and must be discarded.
bool render_step(const render_context& context, render_state& state,
    int samples = 1, const render_callbacks& callbacks = {});

// The average so far (linear RGBA, alpha = coverage).
image_data get_image(const render_state& state);

}  // namespace implicit
