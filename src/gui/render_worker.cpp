// # implicit: progressive rendering on a background thread (implementation)

#include "render_worker.h"

#include <algorithm>
#include <chrono>
#include <utility>

namespace implicit {

// -----------------------------------------------------------------------------
// PASSES
// -----------------------------------------------------------------------------

// One sample per pixel, abandoned between tiles when a newer job arrives.
bool trace_samples_cancellable(trace_state& state, const scene_data& scene,
    const accel_data& accel, const lights_data& lights,
    const trace_params& params, const std::atomic<int64_t>& latest,
    int64_t job) {
  return trace_samples_until(state, scene, accel, lights, params,
      [&] { return latest.load(std::memory_order_relaxed) != job; });
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

// Preview, then passes until all samples are done or a newer job arrives.
static void render_job_passes(
    render_worker& worker, const render_job& job, int64_t id) {
  auto& scene                  = *worker.scene;
  auto& params                 = job.params;
  scene.cameras[params.camera] = job.camera;
  // The only march parameter the viewer edits: the others set hit_min in
  // make_accel() and must stay as they were.
  worker.accel->march.max_iterations = params.march.max_iterations;
  if (params.pratio > 1) {
    auto preview = preview_params(params);
    auto state   = make_state(scene, preview);
    auto start   = std::chrono::steady_clock::now();
    if (!trace_samples_cancellable(state, scene, *worker.accel, *worker.lights,
            preview, worker.latest, id))
      return;
    publish(worker, id, get_render(state), state.samples, true, elapsed(start));
  }
  auto state = make_state(scene, params);
  while (state.samples < params.samples) {
    auto start = std::chrono::steady_clock::now();
    if (!trace_samples_cancellable(state, scene, *worker.accel, *worker.lights,
            params, worker.latest, id))
      return;
    publish(
        worker, id, get_render(state), state.samples, false, elapsed(start));
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
    render_job_passes(worker, job, id);
  }
}

render_worker::~render_worker() { stop_worker(*this); }

// Keep the scene, accel and lights, start the thread.
void start_worker(render_worker& worker, scene_data& scene, accel_data& accel,
    const lights_data& lights) {
  stop_worker(worker);
  worker.scene  = &scene;
  worker.accel  = &accel;
  worker.lights = &lights;
  worker.quit   = false;
  worker.thread = std::thread{run_worker, std::ref(worker)};
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
