// Tests of the work items of distributed renders and sequences, without MPI:
// the orbit and the file names, plans covering every pixel once, the order
// in which items come out, items as bytes, resumption, and jobs rendered by
// simulated workers in any order giving the single process's images to the
// byte.

#include "render_queue.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "../scene/scene_io.h"
#include "../util/error.h"

using namespace implicit;

namespace {

bool same_bytes(const image_data& a, const image_data& b) {
  return a.width == b.width && a.height == b.height &&
         std::memcmp(a.pixels.data(), b.pixels.data(),
             a.pixels.size() * sizeof(vec4f)) == 0;
}

// How many times each pixel of a plan's frame is covered by its tiles.
std::vector<int> coverage(const render_plan& plan) {
  auto counts = std::vector<int>((size_t)plan.width * plan.height, 0);
  for (auto& tile : plan.tiles)
    for (auto j = tile.y0; j < tile.y1; j++)
      for (auto i = tile.x0; i < tile.x1; i++)
        counts[(size_t)j * plan.width + i]++;
  return counts;
}

// The example scene and resolved parameters at a tiny size.
std::unique_ptr<const render_context> example_context(trace_params& params) {
  auto context =
      make_render_context(load_scene(std::string{IMPLICIT_SOURCE_DIR} +
                                     "/examples/materials/materials.json"),
          params);
  auto warnings = std::vector<std::string>{};
  params        = resolve_params(*context, params, "", warnings);
  return context;
}

// Everything a simulated job produced, by file name.
struct saved_images {
  std::string                       output = "out.exr";
  const render_plan*                plan   = nullptr;
  std::map<std::string, image_data> files  = {};
};

void save_output(void* user, const render_output& output) {
  auto& saved = *(saved_images*)user;
  auto  name  = output_filename(saved.output, *saved.plan, output);
  CHECK(saved.files.count(name) == 0);  // each image once
  saved.files[name] = output.image;
}

// A job rendered by `workers` simulated workers: each takes an item when
// the random order says so, holds up to two, renders and returns them in a
// random order, after a trip through the bytes.
saved_images run_simulated(const render_context& context,
    const trace_params& params, const render_plan& plan, int workers,
    uint32_t seed) {
  auto queue = render_queue{};
  start_render_queue(queue, plan, params, context.scene.cameras[params.camera]);
  auto saved  = saved_images{};
  saved.plan  = &plan;
  auto rng    = std::mt19937{seed};
  auto held   = std::vector<std::vector<render_item>>(workers);
  auto rounds = 0;
  while (unfinished_items(queue) > 0) {
    REQUIRE(rounds++ < 100000);
    auto& items = held[rng() % workers];
    if (items.size() < 2 && rng() % 2) {
      if (auto item = take_item(queue))
        items.push_back(unpack_item(pack_item(*item)));
      continue;
    }
    if (items.empty()) continue;
    auto pick = rng() % items.size();
    auto item = std::move(items[pick]);
    items.erase(items.begin() + pick);
    auto camera = item_camera(plan, queue.camera, item.frame);
    REQUIRE(render_item_samples(context, params, camera, plan, item));
    for (auto& output : finish_item(queue, unpack_item(pack_item(item))))
      save_output(&saved, output);
  }
  CHECK(unassigned_items(queue) == 0);
  return saved;
}

}  // namespace

TEST_CASE("render queue: the turntable orbits the focus point") {
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({1, 2, 5}, {0.5f, 0.5f, 0}, {0, 1, 0});
  camera.focus  = length(vec3f{1, 2, 5} - vec3f{0.5f, 0.5f, 0});
  auto focus    = camera.frame.o - camera.frame.z * camera.focus;
  auto distance = [](vec3f a, vec3f b) { return length(a - b); };
  for (auto frame = 0; frame <= 8; frame++) {
    INFO("frame ", frame);
    auto  moved = turntable_camera(camera, frame, 8);
    auto& f     = moved.frame;
    // Same height, same distance to the focus, still looking at it.
    CHECK(f.o.y == doctest::Approx(camera.frame.o.y));
    CHECK(distance(f.o, focus) == doctest::Approx(camera.focus));
    CHECK(distance(f.o - f.z * moved.focus, focus) < 1e-5f);
    CHECK(f.y.y == doctest::Approx(camera.frame.y.y));
    // Rotated by 2 pi frame / 8 about the vertical through the focus.
    auto angle = 2 * pif * frame / 8;
    auto d = camera.frame.o - focus, e = f.o - focus;
    CHECK(e.x == doctest::Approx(std::cos(angle) * d.x + std::sin(angle) * d.z)
                     .epsilon(1e-4));
    CHECK(e.z == doctest::Approx(-std::sin(angle) * d.x + std::cos(angle) * d.z)
                     .epsilon(1e-4));
  }
  // A quarter turn of a camera on the z axis looking at the origin puts it
  // on the x axis.
  auto simple  = camera_data{};
  simple.frame = lookat_frame({0, 0, 4}, {0, 0, 0}, {0, 1, 0});
  simple.focus = 4;
  auto quarter = turntable_camera(simple, 1, 4).frame.o;
  CHECK(quarter.x == doctest::Approx(4));
  CHECK(std::abs(quarter.z) < 1e-5f);
}

TEST_CASE("render queue: frame and batch file names") {
  CHECK(frame_filename("out.png", 3) == "out-0003.png");
  CHECK(frame_filename("a.b/out.exr", 12345) == "a.b/out-12345.exr");
  CHECK(frame_filename("a.b/out", 7) == "a.b/out-0007");
  CHECK(batch_filename("out.png", 16) == "out-s0016.png");
  CHECK(
      batch_filename(frame_filename("seq.hdr", 2), 4) == "seq-0002-s0004.hdr");
  auto plan      = render_plan{};
  plan.turntable = 4;
  CHECK(output_filename("seq.png", plan, {2, 8, true, {}}) == "seq-0002.png");
  CHECK(output_filename("seq.png", plan, {2, 8, false, {}}) ==
        "seq-0002-s0008.png");
  plan.turntable = 0;
  CHECK(output_filename("one.png", plan, {0, 8, true, {}}) == "one.png");
  CHECK(output_filename("one.png", plan, {0, 8, false, {}}) == "one-s0008.png");
}

TEST_CASE("render queue: a sequence resumes after the frames written") {
  auto dir = std::filesystem::path{IMPLICIT_BINARY_DIR} / "test_outputs" /
             "render_queue_resume";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  auto output = (dir / "seq.png").string();
  CHECK(frames_to_render(output, 0) == std::vector<int>{0});
  CHECK(frames_to_render(output, 4) == std::vector<int>{0, 1, 2, 3});
  std::ofstream(dir / "seq-0001.png") << "x";
  std::ofstream(dir / "seq-0003.png") << "x";
  CHECK(frames_to_render(output, 4) == std::vector<int>{0, 2});
}

TEST_CASE("render queue: plans cover every pixel and sample once") {
  for (auto [width, height, tile] :
      {std::tuple{45, 30, 16}, {64, 64, 64}, {7, 100, 8}, {200, 3, 32}}) {
    INFO(width, "x", height, " tiles of ", tile);
    for (auto workers : {1, 2, 5}) {
      auto plan =
          make_render_plan({width, height}, 10, 4, 0, {0}, tile, workers);
      auto counts = coverage(plan);
      CHECK(std::count(counts.begin(), counts.end(), 1) ==
            (int64_t)counts.size());
      CHECK(plan.tiles.size() == (workers == 1 ? 1u : plan.tiles.size()));
      // Batches of 4: [0, 4), [4, 8), [8, 10).
      REQUIRE(plan.batches.size() == 3);
      CHECK(plan.batches[0].x == 0);
      for (size_t b = 1; b < plan.batches.size(); b++)
        CHECK(plan.batches[b].x == plan.batches[b - 1].y);
      CHECK(plan.batches.back().y == 10);
    }
  }
  // Sequences: whole frames when there is one per worker, tiles otherwise.
  auto frames = std::vector<int>{0, 1, 2, 3};
  CHECK(make_render_plan({40, 30}, 4, 0, 4, frames, 16, 4).tiles.size() == 1);
  CHECK(make_render_plan({40, 30}, 4, 0, 4, frames, 16, 5).tiles.size() == 6);
  CHECK(make_render_plan({40, 30}, 4, 0, 0, {0}, 16, 2).batches.size() == 1);
  CHECK_THROWS_AS(make_render_plan({40, 30}, 4, 0, 0, {0}, 0, 2), io_error);
}

TEST_CASE("render queue: items come out frame by frame, batch after batch") {
  auto params = trace_params{};
  auto plan   = make_render_plan({40, 20}, 6, 3, 4, {1, 3}, 16, 3);
  auto queue  = render_queue{};
  auto camera = camera_data{};
  start_render_queue(queue, plan, params, camera);
  // Six tiles per frame, two batches, two frames.
  REQUIRE(plan.tiles.size() == 6);
  CHECK(unassigned_items(queue) == 24);
  auto taken = std::vector<render_item>{};
  while (auto item = take_item(queue)) taken.push_back(*item);
  // All of frame 1's first batch, then frame 3's (two frames held at once);
  // second batches wait for their first.
  REQUIRE(taken.size() == 12);
  for (auto k = 0; k < 12; k++) {
    CHECK(taken[k].frame == (k < 6 ? 1 : 3));
    CHECK(taken[k].tile == k % 6);
    CHECK(taken[k].batch == 0);
    CHECK(taken[k].s0 == 0);
    CHECK(taken[k].s1 == 3);
    CHECK(taken[k].data.sums.empty());  // a first batch travels without data
  }
  // Returning tile 2 of frame 3 makes its second batch ready, with the
  // first batch's sums and streams.
  auto item = taken[8];
  item.data.sums.assign(rect_pixels(item.data.rect), {1, 2, 3, 4});
  item.data.rngs.assign(rect_pixels(item.data.rect), make_pixel_rng(5, 6));
  item.data.counts.assign(rect_pixels(item.data.rect), 3);
  CHECK(finish_item(queue, item).empty());
  auto next = take_item(queue);
  REQUIRE(next.has_value());
  CHECK(next->frame == 3);
  CHECK(next->tile == 2);
  CHECK(next->batch == 1);
  CHECK(next->s0 == 3);
  CHECK(next->s1 == 6);
  REQUIRE(next->data.sums.size() == rect_pixels(next->data.rect));
  CHECK(next->data.sums[0].w == 4);
  CHECK(next->data.counts[0] == 3);
  CHECK(next->data.rngs[0].state == item.data.rngs[0].state);
  CHECK_FALSE(take_item(queue).has_value());
  // A returned item the queue never handed out is refused.
  auto stranger  = taken[0];
  stranger.frame = 2;
  stranger.data.sums.assign(rect_pixels(stranger.data.rect), {});
  stranger.data.counts.assign(rect_pixels(stranger.data.rect), 0);
  CHECK_THROWS_AS(finish_item(queue, stranger), io_error);
}

TEST_CASE("render queue: items as bytes") {
  auto item      = render_item{};
  item.frame     = 3;
  item.tile      = 7;
  item.batch     = 1;
  item.data.rect = {16, 20, 8, 10};
  item.s0        = 4;
  item.s1        = 9;
  for (auto k = 0; k < 8; k++) {
    item.data.sums.push_back({1.0f * k, 2, 3, 0.5f});
    item.data.rngs.push_back(make_pixel_rng(11, k));
    item.data.counts.push_back(k);
    item.data.albedos.push_back({0.5f, 0.25f, 1.0f * k});
  }
  auto bytes = pack_item(item);
  auto back  = unpack_item(bytes);
  CHECK(back.frame == 3);
  CHECK(back.tile == 7);
  CHECK(back.batch == 1);
  CHECK(back.data.rect.x0 == 16);
  CHECK(back.data.rect.y1 == 10);
  CHECK(back.s1 == 9);
  CHECK(back.data.counts[7] == 7);
  CHECK(back.data.albedos[7].z == 7);
  CHECK(back.data.normals.empty());
  CHECK(pack_item(back) == bytes);
  // Truncated, padded, or a header that is not an item.
  CHECK_THROWS_AS(unpack_item(bytes.substr(0, bytes.size() - 1)), io_error);
  CHECK_THROWS_AS(unpack_item(bytes + "x"), io_error);
  CHECK_THROWS_AS(unpack_item(bytes.substr(0, 10)), io_error);
  auto header      = item;
  header.data      = {};
  header.data.rect = {5, 4, 0, 1};
  CHECK_THROWS_AS(unpack_item(pack_item(header)), io_error);
}

TEST_CASE("render queue: workers in any order give the single image") {
  for (auto sampler : {sampler_type::random, sampler_type::sobol}) {
    INFO(sampler_type_names[(int)sampler]);
    auto params       = trace_params{};
    params.resolution = 24;
    params.samples    = 5;
    params.sampler    = sampler;
    auto context      = example_context(params);
    auto size         = render_size(*context, params);
    // The single process: one image, and the batch images at 2 and 4.
    auto whole = image_data{};
    REQUIRE(render_image(*context, params, whole));
    auto state = make_render_state(*context, params);
    auto batch = std::map<int, image_data>{};
    for (auto s = 0; s < params.samples; s++) {
      REQUIRE(render_step(*context, state));
      batch[state.samples] = get_image(state);
    }
    for (auto [workers, tile] : {std::pair{1, 8}, {3, 7}, {4, 64}}) {
      INFO(workers, " workers, tiles of ", tile);
      auto plan =
          make_render_plan(size, params.samples, 2, 0, {0}, tile, workers);
      auto saved = run_simulated(*context, params, plan, workers, 17);
      REQUIRE(saved.files.size() == 3);
      CHECK(same_bytes(saved.files["out.exr"], whole));
      CHECK(same_bytes(saved.files["out-s0002.exr"], batch[2]));
      CHECK(same_bytes(saved.files["out-s0004.exr"], batch[4]));
    }
  }
}

TEST_CASE("render queue: a sequence's frames are renders of the orbit") {
  auto params       = trace_params{};
  params.resolution = 16;
  params.samples    = 2;
  auto context      = example_context(params);
  auto size         = render_size(*context, params);
  auto camera       = context->scene.cameras[params.camera];
  for (auto workers : {1, 2, 5}) {
    INFO(workers, " workers");
    auto plan  = make_render_plan(size, 2, 0, 3, {0, 2}, 8, workers);
    auto saved = run_simulated(*context, params, plan, workers, 3);
    REQUIRE(saved.files.size() == 2);
    for (auto frame : {0, 2}) {
      auto state = make_render_state(
          *context, params, turntable_camera(camera, frame, 3));
      REQUIRE(render_step(*context, state, params.samples));
      CHECK(same_bytes(
          saved.files[frame_filename("out.exr", frame)], get_image(state)));
    }
  }
}

namespace {

struct progress_log {
  int64_t done = 0, total = 0;
  bool    backwards = false;
  int     cancel_at = -1, calls = 0;
};

void on_progress(void* user, int64_t done, int64_t total) {
  auto& log = *(progress_log*)user;
  if (done < log.done) log.backwards = true;
  log.done  = done;
  log.total = total;
  log.calls++;
}

bool on_cancel(void* user) {
  auto& log = *(progress_log*)user;
  return log.cancel_at >= 0 && log.calls >= log.cancel_at;
}

}  // namespace

TEST_CASE("render queue: progress of the job and cancel between blocks") {
  auto params       = trace_params{};
  params.resolution = 40;
  params.samples    = 3;
  params.shader     = shader_type::normal;
  auto context      = example_context(params);
  auto size         = render_size(*context, params);
  auto plan         = make_render_plan(size, 3, 1, 2, {0, 1}, 16, 1);
  auto camera       = context->scene.cameras[params.camera];
  auto log          = progress_log{};
  auto callbacks    = render_callbacks{on_progress, on_cancel, &log};
  auto queue        = render_queue{};
  start_render_queue(queue, plan, params, camera, callbacks);
  auto saved = saved_images{};
  saved.plan = &plan;
  REQUIRE(render_queue_items(queue, *context, save_output, &saved));
  CHECK(saved.files.size() == 6);  // two frames, each two batch images
  CHECK(log.total == 2 * (int64_t)size.x * size.y * 3);
  CHECK(log.done == log.total);
  CHECK_FALSE(log.backwards);
  // Cancelled: stops, stops the queue, and saves nothing more.
  log           = {};
  log.cancel_at = 2;
  auto again    = render_queue{};
  start_render_queue(again, plan, params, camera, callbacks);
  auto partial = saved_images{};
  partial.plan = &plan;
  CHECK_FALSE(render_queue_items(again, *context, save_output, &partial));
  CHECK(partial.files.empty());
  CHECK(render_queue_error(again) == "cancelled");
  CHECK_FALSE(take_item(again).has_value());
}
