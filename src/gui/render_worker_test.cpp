// Tests for the viewer's background renderer: its passes are render_step's
// passes, a new job cancels the old one at once, and what it publishes is
// what the command line would render.

#include "render_worker.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <utility>

#include "navigation.h"
#include "scene/scene_io.h"

using namespace implicit;

namespace {

// The example scene, made ready for tracing as ypathtrace does.
std::unique_ptr<const render_context> load_example(trace_params& params) {
  auto context =
      make_render_context(load_scene(std::string{IMPLICIT_SOURCE_DIR} +
                                     "/examples/sdfunction/sdfunction.json"),
          params);
  params.camera = find_camera(context->scene, "");
  return context;
}

// What `ypathtrace` renders for these parameters and this camera.
image_data render_cli(const render_context& context, const trace_params& params,
    const camera_data& camera) {
  auto state = make_render_state(context, params, camera);
  CHECK(render_step(context, state, params.samples, {}));
  return get_image(state);
}

bool same_pixels(const image_data& a, const image_data& b) {
  if (a.width != b.width || a.height != b.height) return false;
  for (size_t idx = 0; idx < a.pixels.size(); idx++) {
    auto p = a.pixels[idx], q = b.pixels[idx];
    if (p.x != q.x || p.y != q.y || p.z != q.z || p.w != q.w) return false;
  }
  return true;
}

// Take updates until the job has all its samples (or give up after 30 s);
// returns the last one and counts what was seen on the way.
render_update wait_finished(render_worker& worker, int64_t job, int samples,
    int& previews, int& backwards) {
  auto last    = render_update{};
  auto update  = render_update{};
  auto seen    = 0;
  auto timeout = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  previews = backwards = 0;
  while (std::chrono::steady_clock::now() < timeout) {
    if (take_update(worker, update)) {
      if (update.job == job) {
        if (update.preview) previews++;
        if (!update.preview && update.samples < seen) backwards++;
        if (!update.preview) seen = update.samples;
        last = update;
        if (!update.preview && update.samples == samples) return last;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  FAIL("the worker did not finish in 30 s");
  return last;
}

// Start `worker` on a job of `params` with every layer kept (as the viewer
// posts them) and wait for its last sample; returns the job and its last
// update.
std::pair<int64_t, render_update> run_viewer_job(render_worker& worker,
    const render_context& context, const trace_params& params,
    const camera_data& camera) {
  start_worker(worker, context);
  auto job =
      restart_render(worker, {viewer_params_for_views(params), camera, {}});
  auto previews = 0, backwards = 0;
  return {job, wait_finished(worker, job, params.samples, previews, backwards)};
}

}  // namespace

TEST_CASE("render_worker: a cancellable pass is a render_step pass") {
  auto params       = trace_params{};
  params.resolution = 40;
  auto context      = load_example(params);
  auto reference    = make_render_state(*context, params);
  auto state        = make_render_state(*context, params);
  auto latest       = std::atomic<int64_t>{7};
  for (auto pass = 0; pass < 2; pass++) {
    CHECK(render_step(*context, reference));
    CHECK(render_step_cancellable(*context, state, latest, 7));
  }
  CHECK(state.samples == 2);
  CHECK(same_pixels(get_image(state), get_image(reference)));
  CHECK(state.buffer.evaluations == reference.buffer.evaluations);

  // A newer job: no tile is traced and the sample is not counted.
  auto fresh = make_render_state(*context, params);
  latest     = 8;
  CHECK_FALSE(render_step_cancellable(*context, fresh, latest, 7));
  CHECK(fresh.samples == 0);
  auto traced = 0;
  for (auto& p : fresh.buffer.sums) traced += (p.x != 0 || p.w != 0);
  CHECK(traced == 0);
}

TEST_CASE("render_worker: preview parameters") {
  auto params       = trace_params{};
  params.resolution = 720;
  params.samples    = 64;
  params.pratio     = 8;
  auto preview      = preview_params(params);
  CHECK(preview.resolution == 90);
  CHECK(preview.samples == 1);
  CHECK(preview.seed == params.seed);
  params.pratio = 1000;
  CHECK(preview_params(params).resolution == 1);
  params.pratio = 0;
  CHECK(preview_params(params).resolution == 720);
}

TEST_CASE(
    "render_worker: preview, then every sample, ending on the CLI image") {
  auto params       = trace_params{};
  params.resolution = 48;
  params.samples    = 3;
  params.pratio     = 4;
  auto context      = load_example(params);
  auto camera       = context->scene.cameras[params.camera];
  auto expected     = render_cli(*context, params, camera);

  auto worker = render_worker{};
  start_worker(worker, *context);
  auto job      = restart_render(worker, {params, camera});
  auto previews = 0, backwards = 0;
  auto last = wait_finished(worker, job, params.samples, previews, backwards);
  CHECK(previews <= 1);
  CHECK(backwards == 0);
  CHECK(last.samples == 3);
  CHECK_FALSE(last.preview);
  CHECK(same_pixels(last.image, expected));
  // Done: nothing more comes.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  auto extra = render_update{};
  CHECK_FALSE(take_update(worker, extra));

  // The preview alone (samples = 1 at full resolution follows it): its size
  // is the resolution divided by pratio.
  params.samples = 1;
  params.pratio  = 48;
  job            = restart_render(worker, {params, camera});
  auto update    = render_update{};
  auto sizes_ok  = true;
  auto timeout   = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < timeout) {
    if (!take_update(worker, update)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    if (update.job != job) continue;
    auto size =
        camera_resolution(camera, update.preview ? 1 : params.resolution);
    sizes_ok &= update.image.width == size.x && update.image.height == size.y;
    if (!update.preview) break;
  }
  CHECK(sizes_ok);
  CHECK_FALSE(update.preview);
  stop_worker(worker);
}

TEST_CASE("render_worker: a new job cancels the running one") {
  auto params       = trace_params{};
  params.resolution = 64;
  params.pratio     = 8;
  auto context      = load_example(params);
  auto camera       = context->scene.cameras[params.camera];

  auto worker = render_worker{};
  start_worker(worker, *context);
  // A job of a million samples: only cancellation lets the next one run.
  auto slow    = params;
  slow.samples = 1 << 20;
  restart_render(worker, {slow, camera});
  std::this_thread::sleep_for(std::chrono::milliseconds(30));

  auto moved = camera;
  navigate_camera(moved, navigation_mode::orbit, {40, 10}, 0);
  auto fast                 = params;
  fast.samples              = 2;
  fast.march.max_iterations = 3;  // the worker must use this cap
  fast.shader               = shader_type::normal;
  auto job                  = restart_render(worker, {fast, moved});
  auto previews = 0, backwards = 0;
  auto last = wait_finished(worker, job, fast.samples, previews, backwards);
  stop_worker(worker);
  CHECK(last.samples == 2);
  CHECK(backwards == 0);

  // The same image rendered directly with the moved camera and the
  // iteration cap, and different from the unmoved camera's and from the
  // uncapped one's; the context's cameras are as they were.
  CHECK(context->scene.cameras[params.camera].frame.o == camera.frame.o);
  CHECK(same_pixels(last.image, render_cli(*context, fast, moved)));
  CHECK_FALSE(same_pixels(last.image, render_cli(*context, fast, camera)));
  auto uncapped                 = fast;
  uncapped.march.max_iterations = params.march.max_iterations;
  CHECK_FALSE(same_pixels(last.image, render_cli(*context, uncapped, moved)));
}

TEST_CASE("render worker: views show the image or one AOV layer") {
  auto params       = trace_params{};
  params.resolution = 24;
  params.samples    = 2;
  params.aovs       = aov_bit(aov_type::normal) | aov_bit(aov_type::depth);
  auto context      = load_example(params);
  auto state        = make_render_state(
             *context, params, context->scene.cameras[params.camera]);
  REQUIRE(render_step(*context, state, params.samples, {}));
  CHECK(same_pixels(view_image(state, {0}), get_image(state)));
  auto normal = average_layer(state.buffer, aov_type::normal);
  auto depth  = average_layer(state.buffer, aov_type::depth);
  auto shown  = view_image(state, {1 + (int)aov_type::normal});
  auto gray   = view_image(state, {1 + (int)aov_type::depth});
  for (size_t idx = 0; idx < shown.pixels.size(); idx++) {
    CHECK(shown.pixels[idx].x == normal.values[idx * 3] * 0.5f + 0.5f);
    CHECK(shown.pixels[idx].z == normal.values[idx * 3 + 2] * 0.5f + 0.5f);
    CHECK(gray.pixels[idx].y == depth.values[idx]);
    CHECK(gray.pixels[idx].w == 1);
  }
}

TEST_CASE(
    "render worker: a new view re-shows the render without starting over") {
  auto params       = trace_params{};
  params.resolution = 32;
  params.samples    = 4;
  params.pratio     = 1;
  auto context      = load_example(params);
  auto camera       = context->scene.cameras[params.camera];
  auto kept         = viewer_params_for_views(params);
  auto worker       = render_worker{};
  auto [job, last]  = run_viewer_job(worker, *context, params, camera);
  // Keeping every layer changes no pixel of the image.
  CHECK(same_pixels(last.image, render_cli(*context, params, camera)));

  // Denoised, by each method, then the normals: each comes as an update of
  // the same job with the same samples, equal to the view of a render of
  // the same samples.
  auto state = make_render_state(*context, kept, camera);
  REQUIRE(render_step(*context, state, params.samples, {}));
  auto views = std::vector<render_view>{{0, true, denoise_method::nlm},
      {0, true, denoise_method::nfor}, {1 + (int)aov_type::normal}, {0}};
  for (auto& view : views) {
    INFO("view ", view.view, " denoise ", view.denoise);
    show_render(worker, view);
    auto update  = render_update{};
    auto timeout = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!take_update(worker, update) &&
           std::chrono::steady_clock::now() < timeout)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    CHECK(update.job == job);
    CHECK(update.samples == params.samples);
    CHECK(same_pixels(update.image, view_image(state, view)));
  }
  CHECK_FALSE(same_pixels(view_image(state, views[0]), last.image));
  CHECK_FALSE(
      same_pixels(view_image(state, views[0]), view_image(state, views[1])));
  stop_worker(worker);
}

TEST_CASE(
    "render worker: updates tell the time left and the converged pixels") {
  auto params            = trace_params{};
  params.resolution      = 32;
  params.samples         = 8;
  params.pratio          = 1;
  params.noise_threshold = 0.3f;
  params.min_samples     = 2;
  auto context           = load_example(params);
  auto camera            = context->scene.cameras[params.camera];
  auto kept              = viewer_params_for_views(params);
  auto worker            = render_worker{};
  auto last = run_viewer_job(worker, *context, params, camera).second;
  stop_worker(worker);
  CHECK(last.remaining == 0);
  // The fraction of pixels with fewer samples than the render's.
  auto state = make_render_state(*context, kept, camera);
  REQUIRE(render_step(*context, state, params.samples, {}));
  auto& counts  = state.buffer.counts;
  auto  stopped = std::count_if(
       counts.begin(), counts.end(), [&](int c) { return c < params.samples; });
  CHECK(stopped > 0);
  CHECK(last.converged == doctest::Approx((double)stopped / counts.size()));
  CHECK(same_pixels(last.image, get_image(state)));
}
