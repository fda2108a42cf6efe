// # implicit: progressive rendering on a background thread (implementation)

#include "render_worker.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <utility>

#include "../util/progress.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PASSES
// -----------------------------------------------------------------------------

// Whether the job `job` is no longer the latest (render_callbacks.cancel).
struct cancel_check {
  const std::atomic<int64_t>* latest = nullptr;
  int64_t                     job    = 0;
};

static bool is_cancelled(void* user) {
  auto& check = *(const cancel_check*)user;
  return check.latest->load(std::memory_order_relaxed) != check.job;
}

// One sample per pixel, abandoned between tiles when a newer job arrives.
bool render_step_cancellable(const render_context& context, render_state& state,
    const std::atomic<int64_t>& latest, int64_t job) {
  auto check     = cancel_check{&latest, job};
  auto callbacks = render_callbacks{nullptr, is_cancelled, &check};
  return render_step(context, state, 1, callbacks);
}

// Resolution / pratio, one sample.
trace_params preview_params(const trace_params& params) {
  auto preview = params;
  preview.resolution =
      std::max(1, params.resolution / std::max(1, params.pratio));
  preview.samples = 1;
  return preview;
}

// -----------------------------------------------------------------------------
// WORKER
// -----------------------------------------------------------------------------

// Hand an image to the interface unless a newer job made it stale.
static void publish(render_worker& worker, render_update&& update) {
  auto lock = std::lock_guard<std::mutex>{worker.mutex};
  if (worker.latest.load() != update.job) return;
  worker.update = std::move(update);
  worker.fresh  = true;
}

// Seconds since `start`.
static double elapsed(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

trace_params viewer_params_for_views(const trace_params& params) {
  auto all = params;
  for (auto aov = 0; aov < (int)aov_type_names.size(); aov++)
    all.aovs |= aov_bit((aov_type)aov);
  return all;
}

image_data view_image(const render_state& state, const render_view& view) {
  if (view.view <= 0) {
    auto params     = state.params;
    params.denoise  = view.denoise;
    params.denoiser = view.denoiser;
    return output_image(state.buffer, params);
  }
  auto aov   = (aov_type)(view.view - 1);
  auto layer = average_layer(state.buffer, aov);
  auto image = make_image(state.width, state.height);
  auto step  = layer.channels.size();
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto v     = layer.values.data() + idx * step;
    auto color = step == 1 ? vec3f{v[0], v[0], v[0]} : vec3f{v[0], v[1], v[2]};
    if (aov == aov_type::normal) color = color * 0.5f + 0.5f;
    image.pixels[idx] = {color.x, color.y, color.z, 1};
  }
  return image;
}

// The view the interface asks for now.
static render_view asked_view(render_worker& worker) {
  auto lock = std::lock_guard<std::mutex>{worker.mutex};
  return worker.job.view;
}

// Time spent on a job's passes and on denoising them, to keep the denoiser
// under a quarter of the time while samples come in and to tell the time
// left.
struct pass_times {
  double render = 0, denoise = 0;
};

// The fraction of pixels that adaptive sampling stopped (< 0: no threshold).
static double converged_fraction(const render_state& state) {
  if (state.params.noise_threshold <= 0) return -1;
  auto& counts  = state.buffer.counts;
  auto  stopped = std::count_if(counts.begin(), counts.end(),
       [&](int count) { return count < state.samples; });
  return counts.empty() ? 0 : (double)stopped / (double)counts.size();
}

// Publish the state as `view` (timing a denoised view), unless it is a
// denoised view of an unfinished render that would take the denoiser past
// a quarter of the time.
static void publish_view(render_worker& worker, int64_t id,
    const render_state& state, const render_view& view, bool finished,
    double seconds, pass_times& times) {
  auto filtered = view.view <= 0 && view.denoise;
  if (filtered && !finished && times.denoise > times.render / 4) return;
  auto start  = std::chrono::steady_clock::now();
  auto update = render_update{id, view_image(state, view), state.samples};
  if (filtered) times.denoise += elapsed(start);
  update.seconds   = seconds;
  update.remaining = estimate_remaining(
      state.samples, state.params.samples, times.render + times.denoise);
  update.converged = converged_fraction(state);
  publish(worker, std::move(update));
}

// Preview, then passes until all samples are done or a newer job arrives;
// `state` keeps the render for new views.
static void render_job_passes(render_worker& worker, const render_job& job,
    int64_t id, render_state& state) {
  auto& context = *worker.context;
  auto& params  = job.params;
  if (params.pratio > 1) {
    auto preview =
        make_render_state(context, preview_params(params), job.camera);
    auto start = std::chrono::steady_clock::now();
    if (!render_step_cancellable(context, preview, worker.latest, id)) return;
    auto view    = asked_view(worker);
    view.denoise = false;  // one sample at a fraction of the resolution
    publish(worker,
        {id, view_image(preview, view), preview.samples, true, elapsed(start)});
  }
  state      = make_render_state(context, params, job.camera);
  auto times = pass_times{};
  while (state.samples < params.samples) {
    auto start = std::chrono::steady_clock::now();
    if (!render_step_cancellable(context, state, worker.latest, id)) return;
    auto seconds = elapsed(start);
    times.render += seconds;
    publish_view(worker, id, state, asked_view(worker),
        state.samples == params.samples, seconds, times);
  }
}

// The thread: wait for a job or a new view, render or re-show, repeat until
// told to quit.
static void run_worker(render_worker& worker) {
  auto state = render_state{};  // the last job's render
  auto done  = int64_t{-1};     // the job whose render it is, once finished
  while (true) {
    auto job       = render_job{};
    auto id        = int64_t{0};
    auto fresh_job = false;
    {
      auto lock = std::unique_lock<std::mutex>{worker.mutex};
      worker.wake.wait(lock,
          [&] { return worker.posted || worker.reviewed || worker.quit; });
      if (worker.quit) return;
      job             = worker.job;
      id              = worker.latest.load();
      fresh_job       = worker.posted;
      worker.posted   = false;
      worker.reviewed = false;
    }
    // The viewer posts only validated parameters; should a job still be
    // refused, it is dropped rather than ending the program.
    try {
      if (fresh_job) {
        done = -1;
        render_job_passes(worker, job, id, state);
        if (state.samples == job.params.samples) done = id;
      } else if (done == id) {
        auto times = pass_times{};
        publish_view(worker, id, state, job.view, true, 0, times);
      }
    } catch (const std::exception&) { continue; }
  }
}

render_worker::~render_worker() { stop_worker(*this); }

// Keep the context, start the thread.
void start_worker(render_worker& worker, const render_context& context) {
  stop_worker(worker);
  worker.context = &context;
  worker.quit    = false;
  worker.thread  = std::thread{run_worker, std::ref(worker)};
}

// Post a job; the worker drops what it was doing between tiles.
int64_t restart_render(render_worker& worker, const render_job& job) {
  auto id = int64_t{0};
  {
    auto lock     = std::lock_guard<std::mutex>{worker.mutex};
    worker.job    = job;
    worker.posted = true;
    id            = worker.latest.fetch_add(1) + 1;
  }
  worker.wake.notify_one();
  return id;
}

// Change the view of the current job; the worker re-shows its render.
void show_render(render_worker& worker, const render_view& view) {
  {
    auto lock       = std::lock_guard<std::mutex>{worker.mutex};
    worker.job.view = view;
    worker.reviewed = true;
  }
  worker.wake.notify_one();
}

// Swap out the latest image.
bool take_update(render_worker& worker, render_update& update) {
  auto lock = std::lock_guard<std::mutex>{worker.mutex};
  if (!worker.fresh) return false;
  std::swap(update, worker.update);
  worker.fresh = false;
  return true;
}

// Cancel, wake and join.
void stop_worker(render_worker& worker) {
  {
    auto lock   = std::lock_guard<std::mutex>{worker.mutex};
    worker.quit = true;
    worker.latest.fetch_add(1);
  }
  worker.wake.notify_all();
  if (worker.thread.joinable()) worker.thread.join();
}

}  // namespace implicit
