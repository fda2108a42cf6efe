// # implicit: progressive rendering on a background thread (implementation)

#include "render_worker.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <utility>

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
static void publish(render_worker& worker, int64_t job, image_data&& image,
    int samples, bool preview, double seconds) {
  auto lock = std::lock_guard<std::mutex>{worker.mutex};
  if (worker.latest.load() != job) return;
  worker.update = {job, std::move(image), samples, preview, seconds};
  worker.fresh  = true;
}

// Seconds since `start`.
static double elapsed(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

image_data view_image(const render_state& state, int view) {
  if (view <= 0) return output_image(state.buffer, state.params);
  auto aov   = (aov_type)(view - 1);
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

// Preview, then passes until all samples are done or a newer job arrives.
static void render_job_passes(
    render_worker& worker, const render_job& job, int64_t id) {
  auto& context = *worker.context;
  auto& params  = job.params;
  if (params.pratio > 1) {
    auto preview = preview_params(params);
    auto state   = make_render_state(context, preview, job.camera);
    auto start   = std::chrono::steady_clock::now();
    if (!render_step_cancellable(context, state, worker.latest, id)) return;
    publish(worker, id, view_image(state, job.view), state.samples, true,
        elapsed(start));
  }
  auto state = make_render_state(context, params, job.camera);
  while (state.samples < params.samples) {
    auto start = std::chrono::steady_clock::now();
    if (!render_step_cancellable(context, state, worker.latest, id)) return;
    publish(worker, id, view_image(state, job.view), state.samples, false,
        elapsed(start));
  }
}

// The thread: wait for a job, render it, repeat until told to quit.
static void run_worker(render_worker& worker) {
  while (true) {
    auto job = render_job{};
    auto id  = int64_t{0};
    {
      auto lock = std::unique_lock<std::mutex>{worker.mutex};
      worker.wake.wait(lock, [&] { return worker.posted || worker.quit; });
      if (worker.quit) return;
      job           = worker.job;
      id            = worker.latest.load();
      worker.posted = false;
    }
    // The viewer posts only validated parameters; should a job still be
    // refused, it is dropped rather than ending the program.
    try {
      render_job_passes(worker, job, id);
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
