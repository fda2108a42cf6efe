// # implicit: progressive rendering on a background thread
//
// The viewer's renderer, free of any window system: a worker thread that
// renders a low-resolution preview (resolution / pratio, one sample) and then
// adds one sample per pixel per pass to a render_state, publishing the average
// after each pass (denoised, or one AOV layer, as the job's view asks). The
// interface thread never waits for a pass: it posts jobs
// and takes the latest finished image under a mutex held only for a swap. A
// new job cancels the current one between tiles, so a restart costs at most
// one 16x16 tile per thread, whatever the resolution.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include <memory>

#include "../trace/render.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PASSES
// -----------------------------------------------------------------------------

// Add one sample to every pixel as render_step() does (same pixels, same
// random streams, so the same image), but stop between tiles once `latest`
// no longer equals `job`. Returns false, leaving the state unusable, when it
// stopped early.
bool render_step_cancellable(const render_context& context, render_state& state,
    const std::atomic<int64_t>& latest, int64_t job);

// The parameters of the preview: the resolution divided by pratio (at least
// one pixel), one sample.
trace_params preview_params(const trace_params& params);

// -----------------------------------------------------------------------------
// WORKER
// -----------------------------------------------------------------------------

// How the worker shows its render: the image (denoised when `denoise`, by
// `denoiser`; the job's params.denoise and params.denoiser are not used) or
// one AOV layer. Changing it re-shows the render the worker has instead of
// starting over.
struct render_view {
  int            view     = 0;  // 0: the image; k: the layer of aov_type k - 1
  bool           denoise  = false;
  denoise_method denoiser = denoise_method::nlm;
};

// What to render: the parameters and the camera (the viewer's own copy; the
// context's cameras are not changed), and how to show it. The params must
// keep what every view it may show reads (viewer_params_for_views()).
struct render_job {
  trace_params params = {};
  camera_data  camera = {};
  render_view  view   = {};
};

// The parameters with every AOV layer and the statistics kept, so that any
// view, denoised or not, shows from the same samples (about 3% more time
// per sample).
trace_params viewer_params_for_views(const trace_params& params);

// What a view shows of a render: its image (denoised when asked), or one
// AOV layer as colours (one channel as grey, normals mapped from [-1, 1] to
// [0, 1]; alpha 1). The state's params must keep the data.
image_data view_image(const render_state& state, const render_view& view);

// An image finished by the worker.
struct render_update {
  int64_t    job     = 0;      // id returned by restart_render()
  image_data image   = {};     // linear RGBA, the average so far
  int        samples = 0;      // samples per pixel in image
  bool       preview = false;  // rendered at resolution / pratio
  double     seconds = 0;      // time spent on the last pass
  // Seconds left at the mean pass time so far (< 0: unknown), and the
  // fraction of pixels adaptive sampling stopped (< 0: no threshold).
  double remaining = -1;
  double converged = -1;
};

// The worker and what it shares with the interface thread. The thread only
// reads the context given to start_worker(); every job renders with it,
// whatever its parameters (the iteration cap too: march settings are passed
// when tracing, so nothing is rebuilt).
struct render_worker {
  render_worker()                                = default;
  render_worker(const render_worker&)            = delete;
  render_worker& operator=(const render_worker&) = delete;
  ~render_worker();  // stops and joins the thread

  const render_context* context = nullptr;

  std::thread             thread = {};
  std::mutex              mutex  = {};
  std::condition_variable wake   = {};
  // Guarded by mutex.
  render_job    job      = {};
  bool          posted   = false;  // job not yet picked up by the worker
  bool          reviewed = false;  // job.view changed, not yet shown
  bool          quit     = false;
  render_update update   = {};
  bool          fresh    = false;  // update not yet taken
  // Id of the newest job; the worker abandons a pass when it changes.
  std::atomic<int64_t> latest = 0;
};

// Start the thread. The context must outlive the worker.
void start_worker(render_worker& worker, const render_context& context);

// Cancel the current render and start `job`; returns its id at once.
int64_t restart_render(render_worker& worker, const render_job& job);

// Show the current job's render as `view`: at once when it has all its
// samples, else from its next pass on. Denoised views of a running render
// are shown at most as often as keeps the denoiser under a quarter of the
// time (and always at the last sample).
void show_render(render_worker& worker, const render_view& view);

// Move out the latest finished image if there is one not yet taken; never
// waits for a pass.
bool take_update(render_worker& worker, render_update& update);

// Stop the thread; waits at most for the tiles being rendered.
void stop_worker(render_worker& worker);

}  // namespace implicit
