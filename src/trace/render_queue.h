// # implicit: work items of distributed renders and sequences
//
// A render job (one image, or the frames of a turntable sequence) is cut into
// work items: one tile of one frame and one batch of samples [s0, s1) (one
// batch, or one per --savebatch samples). A render_queue hands the items out
// in order (frame, then tile, each tile's batches one after another) to any
// number of workers, threads of this process or remote ranks, and gathers
// them back in any order: it keeps each frame's sums and random streams,
// makes a tile's next batch ready when its previous one returns, and gives
// back each image (batch images, then the frame) when its last tile arrives.
//
// Items travel as bytes (pack_item(), unpack_item()): a first batch carries
// only its header (its sums start at zero, its streams are the pixels' own),
// a later one also its tile's sums and streams, so that it may run on any
// worker and still continue each pixel's sum and stream exactly where a
// single process would. Nothing here knows the transport: ypathtrace's MPI
// ranks move the bytes and call these functions.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "render.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SEQUENCES
// -----------------------------------------------------------------------------

// Camera `frame` of `frames` orbiting `camera` about its focus point (at
// camera.focus along its view direction), around the world's vertical (y)
// axis; frame 0 is the camera itself.
camera_data turntable_camera(const camera_data& camera, int frame, int frames);

// Output name of a sequence frame: out.png -> out-0003.png.
std::string frame_filename(const std::string& output, int frame);

// Name of a batch image (--savebatch): out.png -> out-s0016.png.
std::string batch_filename(const std::string& output, int samples);

// Frames of a `turntable`-frame sequence whose files do not exist yet, in
// order (an interrupted sequence resumes); {0} for a single image
// (turntable 0).
std::vector<int> frames_to_render(const std::string& output, int turntable);

// -----------------------------------------------------------------------------
// PLAN
// -----------------------------------------------------------------------------

// How a job is cut into items.
struct render_plan {
  int                      width     = 0;  // of every frame
  int                      height    = 0;
  int                      samples   = 0;   // per pixel
  int                      turntable = 0;   // frames of the orbit; 0: one image
  std::vector<int>         frames    = {};  // to render, in order
  std::vector<render_rect> tiles     = {};  // of every frame, row-major
  std::vector<vec2i>       batches   = {};  // [s0, s1) of each batch
  int                      savebatch = 0;   // an image every N samples too
  float                    time      = 0;   // budget per frame, seconds
  int active_frames = 2;  // frames held at once (each worker one, if whole)
};

// The plan of a job for `workers` workers (processes that take items):
// one worker takes whole frames (parallel inside); several take tiles of
// `tile_size` pixels (the last row and column may be smaller), except for a
// sequence of at least as many frames as workers, which they take whole
// (when a frame's sums and streams fit one message). Batches: one, or one
// per `savebatch` samples; with a `time` budget (seconds per frame) also
// passes that end at 1, 2, 4, ... 64 samples, then every 64: a frame whose
// budget has run out when all its tiles finish a batch ends there (its
// final image has the samples of that batch; pixels that adaptive sampling
// stopped, fewer).
render_plan make_render_plan(vec2i size, int samples, int savebatch,
    int turntable, const std::vector<int>& frames, int tile_size, int workers,
    float time = 0);

// -----------------------------------------------------------------------------
// WORK ITEMS
// -----------------------------------------------------------------------------

// Samples [s0, s1) of one tile of one frame, with the tile's per-pixel data
// (`data`: the tile's rectangle and the arrays of visit_pixel_arrays(),
// row-major over the tile): none for a first batch on the way out, then what
// the item's render left. After the last batch the streams are dropped.
struct render_item {
  int           frame = 0, tile = 0, batch = 0;
  int           s0 = 0, s1 = 0;
  render_buffer data = {};  // data.rect: the tile
};

// Item <-> bytes: a header of ints, then the arrays it holds.
// unpack_item() throws io_error for bytes that are not an item.
std::string pack_item(const render_item& item);
render_item unpack_item(const std::string& bytes);

// Render an item (render_samples(), all threads) with the camera of its frame
// (item_camera()): its data starts as described above, with the arrays of the
// parameters' layout (render_layout()). Returns
// false when cancelled (the item must then be dropped).
bool render_item_samples(const render_context& context,
    const trace_params& params, const camera_data& camera,
    const render_plan& plan, render_item& item,
    const render_callbacks& callbacks = {});

// -----------------------------------------------------------------------------
// QUEUE
// -----------------------------------------------------------------------------

// An image a job finished: a batch image (--savebatch) or a frame, with the
// frame's per-pixel data at that point (its AOVs and statistics).
struct render_output {
  int           frame   = 0;
  int           samples = 0;  // in every pixel (most, with adaptive sampling)
  bool          final   = false;
  image_data    image   = {};
  render_buffer data    = {};  // the whole frame, without streams
};

// The file of an output: `output`, its frame's file in a sequence, or a
// batch image of either.
std::string output_filename(const std::string& output, const render_plan& plan,
    const render_output& out);

// A frame being rendered: its per-pixel data as the items come back.
struct render_frame {
  render_buffer    buffer     = {};
  std::vector<int> tiles_done = {};  // per batch
  // The data at the end of each unfinished batch, for batch images and
  // the time budget: a tile may run its next batch before the other tiles
  // finish this one.
  std::map<int, render_buffer>          batch_data = {};
  std::chrono::steady_clock::time_point start      = {};  // for the time budget
  int                  end_batch  = -1;  // the batch the time budget ended at
  int                  pending    = 0;   // items made and not returned
  std::vector<int>     tile_batch = {};  // each tile's latest item's batch
  std::vector<int64_t> tile_converged = {};  // pixels stopped per tile
  int64_t              converged      = 0;   // their sum
};

// The queue of a job. Every function below locks it, so the workers of a
// process share one; `camera` is the job's (frame 0's) camera.
// callbacks.progress sees the pixel samples of the whole job: items returned
// (finish_item()) and the blocks of the item this process renders
// (render_queue_items()); callbacks.cancel is asked between blocks.
struct render_queue {
  render_plan      plan      = {};
  trace_params     params    = {};
  camera_data      camera    = {};
  render_callbacks callbacks = {};

  std::mutex              mutex   = {};
  std::condition_variable changed = {};
  // Guarded by mutex.
  size_t                      next_frame = 0;  // index into plan.frames
  std::map<int, render_frame> active     = {};
  std::deque<render_item>     ready      = {};  // without their data yet
  int64_t                     unassigned = 0;   // items not handed out
  int64_t                     unfinished = 0;   // items not returned
  int64_t                     done       = 0;   // pixel samples returned
  double converged = -1;  // stopped pixels of the last frame updated (< 0:
                          // no adaptive sampling)
  int64_t           rendering = 0;  // of this process's item
  int64_t           total     = 0;
  std::string       error     = "";     // stops every worker
  std::atomic<bool> stopped   = false;  // error is set
};

// Set up the queue for a plan (the queue is not movable: it holds a mutex).
void start_render_queue(render_queue& queue, const render_plan& plan,
    const trace_params& params, const camera_data& camera,
    const render_callbacks& callbacks = {});

// The camera of a frame of a plan: the job's `camera`, or its place on the
// orbit.
camera_data item_camera(
    const render_plan& plan, const camera_data& camera, int frame);

// The next item, with its tile's data, if one is ready now.
std::optional<render_item> take_item(render_queue& queue);

// Wait until an item is ready and take it; none once every item is handed
// out or the queue stopped.
std::optional<render_item> wait_item(render_queue& queue);

// Store a rendered item; returns the images it completed, in order.
std::vector<render_output> finish_item(
    render_queue& queue, const render_item& item);

// Items not handed out yet, and not returned yet.
int64_t unassigned_items(render_queue& queue);
int64_t unfinished_items(render_queue& queue);

// Stop every worker with an error (the first one is kept).
void stop_render_queue(render_queue& queue, const std::string& error);

// The queue's error ("" while none).
std::string render_queue_error(render_queue& queue);

// Called with each finished image, from the thread that finished it.
using render_save = void (*)(void* user, const render_output& output);

// Render items on this process until every item is handed out, waiting while
// items rendered elsewhere hold back later batches, and hand each finished
// image to `save` (with `user`). Returns false when cancelled (the queue is
// then stopped) or when the queue stopped. Exceptions from rendering or
// `save` propagate.
bool render_queue_items(render_queue& queue, const render_context& context,
    render_save save, void* user);

}  // namespace implicit
