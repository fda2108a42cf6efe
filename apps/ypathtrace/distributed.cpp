// # ypathtrace: distributed rendering and sequences (see distributed.h)
//
// Rank 0 runs a scheduler of work items (frame, tile, sample batch). Its main
// thread is the only one that calls MPI (MPI_THREAD_FUNNELED): it answers the
// other ranks while a second thread renders items on rank 0 with all cores.
// A tile's first sample batch starts from zero sums and the pixels' own
// random streams; a later batch (--savebatch) carries the tile's sums and
// streams both ways, so it may run on any rank and still continue each
// pixel's sum and stream exactly where the single process would.

#include "distributed.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "image/image_io.h"
#include "scene/scene_io.h"
#include "scene_bundle.h"
#include "trace/render.h"
#include "util/error.h"
#include "util/progress.h"

#ifdef IMPLICIT_MPI
#include <mpi.h>
#endif

namespace implicit {

// -----------------------------------------------------------------------------
// OPTIONS
// -----------------------------------------------------------------------------

void add_distributed_options(CLI::App& app, distributed_options& options) {
  app.add_option("--turntable", options.turntable,
         "Render N frames orbiting the camera about its focus point "
         "(<output>-0000.<ext>, ...; frames already written are skipped)")
      ->check(CLI::Range(0, 1000000));
  app.add_option("--tilesize", options.tile_size,
         "Tile size in pixels for distributed renders (mpirun)")
      ->check(CLI::Range(1, 16384))
      ->capture_default_str();
}

// The value of an environment variable as an int, or `fallback`.
static int env_int(const char* name, int fallback) {
  auto value = std::getenv(name);
  return value && *value ? std::atoi(value) : fallback;
}

// OpenMPI's mpirun sets OMPI_COMM_WORLD_*; PMI launchers (MPICH's mpiexec,
// Slurm's srun) set PMI_* or PMIX_*.
bool launched_by_mpirun() {
  return env_int("OMPI_COMM_WORLD_SIZE", 0) > 0 || env_int("PMI_SIZE", 0) > 0 ||
         std::getenv("PMIX_RANK") != nullptr;
}

bool is_primary_process() {
  return env_int("OMPI_COMM_WORLD_RANK", 0) == 0 &&
         env_int("PMI_RANK", 0) == 0 && env_int("PMIX_RANK", 0) == 0;
}

bool needs_distributed(const distributed_options& options) {
  return options.turntable > 0 || launched_by_mpirun();
}

camera_data turntable_camera(const camera_data& camera, int frame, int frames) {
  auto angle  = 2 * pif * (float)frame / (float)frames;
  auto c      = std::cos(angle);
  auto s      = std::sin(angle);
  auto rotate = [&](vec3f v) {
    return vec3f{c * v.x + s * v.z, v.y, -s * v.x + c * v.z};
  };
  auto& from   = camera.frame;
  auto  focus  = from.o - from.z * camera.focus;  // the camera looks down -z
  auto  result = camera;
  result.frame = {rotate(from.x), rotate(from.y), rotate(from.z),
      focus + rotate(from.o - focus)};
  return result;
}

// out.png -> out<tag>0016.png: a number of at least 4 digits before the
// extension (the validated output always has one).
static std::string numbered_filename(
    const std::string& output, const std::string& tag, int number) {
  auto dot    = output.find_last_of('.');
  auto digits = std::to_string(number);
  while (digits.size() < 4) digits = "0" + digits;
  return output.substr(0, dot) + tag + digits + output.substr(dot);
}

std::string frame_filename(const std::string& output, int frame) {
  return numbered_filename(output, "-", frame);
}

std::string batch_filename(const std::string& output, int samples) {
  return numbered_filename(output, "-s", samples);
}

// -----------------------------------------------------------------------------
// SETUP
// -----------------------------------------------------------------------------

// Everything a rank renders with, built once per rank: the render core's
// context, the resolved parameters, the image size and the camera.
struct render_setup {
  std::unique_ptr<const render_context> context = {};
  trace_params                          params  = {};
  camera_data                           camera  = {};
  int                                   width   = 0;
  int                                   height  = 0;
};

// Load the scene and make the render context; the render core applies its
// fallbacks. `verbose` prints the warnings (rank 0 only).
static render_setup make_render_setup(const std::string& filename,
    const distributed_options& options, bool verbose) {
  auto setup    = render_setup{};
  auto warnings = std::vector<std::string>{};
  auto scene    = load_scene(filename, warnings);
  setup.context = make_render_context(std::move(scene), options.params);
  setup.params =
      resolve_params(*setup.context, options.params, options.camera, warnings);
  if (verbose)
    for (auto& warning : warnings)
      std::fprintf(stderr, "warning: %s\n", warning.c_str());
  setup.camera = setup.context->scene.cameras[setup.params.camera];
  auto size    = render_size(*setup.context, setup.params);
  setup.width  = size.x;
  setup.height = size.y;
  return setup;
}

// Camera of one frame of the run (the orbit keeps the image size).
static camera_data frame_camera(
    const render_setup& setup, const distributed_options& options, int frame) {
  return options.turntable > 0
             ? turntable_camera(setup.camera, frame, options.turntable)
             : setup.camera;
}

// Output file of one frame.
static std::string frame_output(const distributed_options& options, int frame) {
  return options.turntable > 0 ? frame_filename(options.output, frame)
                               : options.output;
}

// -----------------------------------------------------------------------------
// WORK ITEMS
// -----------------------------------------------------------------------------

// Pixels [x0, x1) x [y0, y1).
struct tile_rect {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
};

// Samples [s0, s1) of one tile of one frame, with the tile's accumulated sums
// and random streams (row-major within the tile): before rendering on the
// way out, after it on the way back.
struct tile_work {
  int                    frame = 0, tile = 0, batch = 0;
  tile_rect              rect = {};
  int                    s0 = 0, s1 = 0;
  std::vector<vec4f>     accumulated = {};
  std::vector<rng_state> rngs        = {};
};

// Add samples [s0, s1) to each pixel of the tile, in order, with all threads,
// through the render core. A first batch comes without sums and streams: they
// start at zero and at the pixels' own streams. After the last batch the
// streams are dropped.
static void render_tile_work(
    const render_setup& setup, const camera_data& camera, tile_work& work) {
  auto& rect   = work.rect;
  auto& params = setup.params;
  auto  buffer = make_render_buffer(
       {rect.x0, rect.x1, rect.y0, rect.y1}, setup.width, params.seed);
  if (!work.accumulated.empty()) buffer.sums = std::move(work.accumulated);
  if (!work.rngs.empty()) buffer.rngs = std::move(work.rngs);
  render_samples(*setup.context, params, camera, work.s0, work.s1, buffer);
  work.accumulated = std::move(buffer.sums);
  work.rngs        = std::move(buffer.rngs);
  if (work.s1 == params.samples) work.rngs = {};
}

// -----------------------------------------------------------------------------
// SCHEDULER (rank 0)
// -----------------------------------------------------------------------------

// What the run renders: frames, each cut into tiles and sample batches.
struct render_plan {
  std::vector<tile_rect> tiles   = {};
  std::vector<vec2i>     batches = {};  // [s0, s1) of each batch
  std::vector<int>       frames  = {};  // frames to render, in order
};

// Tiles of `tile_size` pixels (the last row and column may be smaller).
static std::vector<tile_rect> make_tiles(int width, int height, int tile_size) {
  auto tiles = std::vector<tile_rect>{};
  for (auto y = 0; y < height; y += tile_size)
    for (auto x = 0; x < width; x += tile_size)
      tiles.push_back({x, std::min(x + tile_size, width), y,
          std::min(y + tile_size, height)});
  return tiles;
}

// Sample batches: one, or one per --savebatch samples.
static std::vector<vec2i> make_batches(int samples, int savebatch) {
  auto step    = savebatch > 0 ? savebatch : samples;
  auto batches = std::vector<vec2i>{};
  for (auto s0 = 0; s0 < samples; s0 += step)
    batches.push_back({s0, std::min(s0 + step, samples)});
  return batches;
}

// A frame being rendered: rank 0's gathered sums and streams.
struct frame_job {
  camera_data      camera     = {};
  render_state     state      = {};
  std::vector<int> tiles_done = {};  // per batch
  // Sums at the end of each unfinished batch, for --savebatch: a tile may
  // run its next batch before the other tiles finish this one.
  std::map<int, std::vector<vec4f>> batch_sums = {};
};

// The scheduler's state, shared by rank 0's MPI thread and render thread.
struct scheduler {
  const render_setup*        setup      = nullptr;
  const distributed_options* options    = nullptr;
  render_plan                plan       = {};
  size_t                     max_active = 2;  // frames held at once
  std::mutex                 mutex;
  std::condition_variable    changed;
  size_t                     next_frame = 0;  // index into plan.frames
  std::map<int, frame_job>   active     = {};
  std::deque<tile_work>      ready      = {};  // items without their data
  int64_t                    unassigned = 0;
  int64_t                    unfinished = 0;
  progress_state             progress   = {};
  std::string                error      = "";  // of the render thread
};

// Start the frames the scheduler may hold and queue their first batch.
static void activate_frames(scheduler& sched) {
  while (sched.ready.empty() && sched.next_frame < sched.plan.frames.size() &&
         sched.active.size() < sched.max_active) {
    auto  frame = sched.plan.frames[sched.next_frame++];
    auto& job   = sched.active[frame];
    job.camera  = frame_camera(*sched.setup, *sched.options, frame);
    job.state   = make_render_state(
          *sched.setup->context, sched.setup->params, job.camera);
    job.tiles_done.assign(sched.plan.batches.size(), 0);
    for (auto tile = 0; tile < (int)sched.plan.tiles.size(); tile++)
      sched.ready.push_back({frame, tile, 0, sched.plan.tiles[tile]});
  }
}

// Take the next item, with its data copied from the frame's state; none when
// nothing is ready now. Call with the mutex held.
static std::optional<tile_work> take_work(scheduler& sched) {
  activate_frames(sched);
  if (sched.ready.empty()) return std::nullopt;
  auto work = sched.ready.front();
  sched.ready.pop_front();
  sched.unassigned--;
  auto& state = sched.active.at(work.frame).state;
  auto  batch = sched.plan.batches[work.batch];
  work.s0     = batch.x;
  work.s1     = batch.y;
  if (work.batch == 0) return work;  // starts from zero, initial streams
  for (auto j = work.rect.y0; j < work.rect.y1; j++) {
    for (auto i = work.rect.x0; i < work.rect.x1; i++) {
      auto idx = (size_t)j * state.width + i;
      work.accumulated.push_back(state.buffer.sums[idx]);
      work.rngs.push_back(state.buffer.rngs[idx]);
    }
  }
  return work;
}

// Copy a rendered item's sums into an image's, and its streams when it has
// them (`rngs` may be null).
static void copy_tile(const tile_work& work, int width,
    std::vector<vec4f>& accumulated, std::vector<rng_state>* rngs) {
  auto k = size_t{0};
  for (auto j = work.rect.y0; j < work.rect.y1; j++) {
    for (auto i = work.rect.x0; i < work.rect.x1; i++, k++) {
      auto idx         = (size_t)j * width + i;
      accumulated[idx] = work.accumulated[k];
      if (rngs && !work.rngs.empty()) (*rngs)[idx] = work.rngs[k];
    }
  }
}

// Store a rendered item; save the frame's image when a batch completes.
// Call with the mutex held.
static void finish_work(scheduler& sched, const tile_work& work) {
  auto& job   = sched.active.at(work.frame);
  auto& state = job.state;
  copy_tile(work, state.width, state.buffer.sums, &state.buffer.rngs);
  auto  last_batch = (int)sched.plan.batches.size() - 1;
  auto& options    = *sched.options;
  if (work.batch < last_batch) {
    sched.ready.push_back(
        {work.frame, work.tile, work.batch + 1, work.rect, 0, 0, {}, {}});
    if (options.savebatch > 0) {
      auto& sums = job.batch_sums[work.batch];
      if (sums.empty()) sums.assign(state.buffer.sums.size(), {0, 0, 0, 0});
      copy_tile(work, state.width, sums, nullptr);
    }
  }
  sched.unfinished--;
  update_progress(sched.progress, sched.progress.total - (int)sched.unfinished);
  if (++job.tiles_done[work.batch] < (int)sched.plan.tiles.size()) return;
  auto  output = frame_output(options, work.frame);
  auto& params = sched.setup->params;
  if (work.batch == last_batch) {
    state.samples = work.s1;
    save_image(output, get_image(state), params.exposure, params.filmic);
    sched.active.erase(work.frame);
  } else if (options.savebatch > 0) {
    auto sums = render_buffer{
        {0, state.width, 0, state.height}, job.batch_sums.at(work.batch)};
    auto image = average_samples(sums, work.s1);
    save_image(
        batch_filename(output, work.s1), image, params.exposure, params.filmic);
    job.batch_sums.erase(work.batch);
  }
}

// Render items on rank 0 until none are left to assign, waiting for items
// that finished batches make ready.
static void render_local(scheduler& sched) {
  while (true) {
    auto work   = std::optional<tile_work>{};
    auto camera = camera_data{};
    {
      auto lock = std::unique_lock<std::mutex>(sched.mutex);
      sched.changed.wait(lock, [&] {
        if (!sched.error.empty() || sched.unassigned == 0) return true;
        auto next = take_work(sched);
        if (next) work.emplace(std::move(*next));
        return work.has_value();
      });
      if (!work) return;
      camera = sched.active.at(work->frame).camera;
    }
    render_tile_work(*sched.setup, camera, *work);
    auto lock = std::unique_lock<std::mutex>(sched.mutex);
    finish_work(sched, *work);
    sched.changed.notify_all();
  }
}

// Which frames to render: all, or for a sequence those not yet written.
static std::vector<int> frames_to_render(const distributed_options& options) {
  if (options.turntable == 0) return {0};
  auto frames = std::vector<int>{};
  for (auto frame = 0; frame < options.turntable; frame++)
    if (!std::filesystem::exists(frame_filename(options.output, frame)))
      frames.push_back(frame);
  return frames;
}

// Plan the run and start the progress bar.
static void start_scheduler(scheduler& sched, const render_setup& setup,
    const distributed_options& options, int ranks) {
  sched.setup   = &setup;
  sched.options = &options;
  auto& plan    = sched.plan;
  plan.frames   = frames_to_render(options);
  plan.batches  = make_batches(setup.params.samples, options.savebatch);
  // Whole frames per rank when a sequence has a frame for every rank (and a
  // frame fits one message); tiles otherwise.
  auto frame_bytes =
      (double)setup.width * setup.height * (sizeof(vec4f) + sizeof(rng_state));
  auto whole_frames = options.turntable > 0 &&
                      (int)plan.frames.size() >= ranks && frame_bytes < 1e9;
  plan.tiles       = whole_frames
                         ? std::vector<tile_rect>{{0, setup.width, 0, setup.height}}
                         : make_tiles(setup.width, setup.height, options.tile_size);
  sched.max_active = whole_frames ? (size_t)ranks : 2;
  sched.unassigned =
      (int64_t)plan.frames.size() * plan.tiles.size() * plan.batches.size();
  sched.unfinished = sched.unassigned;
  auto message     = "render " + options.scene +
                 (ranks > 1 ? " on " + std::to_string(ranks) + " ranks" : "");
  // Under mpirun stderr is a pipe to mpirun, which may well be on a
  // terminal: rank 0 shows the bar unless --quiet.
  start_progress(sched.progress, message, (int)sched.unfinished,
      !options.quiet && (launched_by_mpirun() || stderr_is_terminal()));
}

// -----------------------------------------------------------------------------
// MPI
// -----------------------------------------------------------------------------

// This process's place in the job; without MPI, rank 0 of 1.
struct mpi_session {
  bool active = false;
  int  rank   = 0;
  int  size   = 1;
};

#ifdef IMPLICIT_MPI

enum message_tag : int { tag_ready = 1, tag_result, tag_work, tag_done };

// Work item <-> bytes: a header of ints (the last two say whether the sums
// and the streams follow), then the sums and the streams.
static constexpr int work_header_size = 11;

// Append an array's bytes (an empty vector's data() may be null).
template <typename T>
static void pack_array(std::string& bytes, const std::vector<T>& values) {
  if (values.empty()) return;
  bytes.append((const char*)values.data(), values.size() * sizeof(T));
}

static std::string pack_work(const tile_work& work) {
  int  header[work_header_size] = {work.frame, work.tile, work.batch,
       work.rect.x0, work.rect.x1, work.rect.y0, work.rect.y1, work.s0, work.s1,
       !work.accumulated.empty(), !work.rngs.empty()};
  auto bytes                    = std::string{};
  bytes.append((const char*)header, sizeof(header));
  pack_array(bytes, work.accumulated);
  pack_array(bytes, work.rngs);
  return bytes;
}

// Copy `count` items from `bytes` at `offset`, advancing it.
template <typename T>
static void unpack_array(const std::string& bytes, size_t& offset, size_t count,
    std::vector<T>& values) {
  if (bytes.size() - offset < count * sizeof(T))
    throw io_error("work item: truncated");
  values.resize(count);
  if (count == 0) return;  // an empty vector's data() may be null
  std::memcpy(values.data(), bytes.data() + offset, count * sizeof(T));
  offset += count * sizeof(T);
}

static tile_work unpack_work(const std::string& bytes) {
  int header[work_header_size] = {};
  if (bytes.size() < sizeof(header)) throw io_error("work item: truncated");
  std::memcpy(header, bytes.data(), sizeof(header));
  auto work  = tile_work{header[0], header[1], header[2],
      {header[3], header[4], header[5], header[6]}, header[7], header[8], {},
      {}};
  auto count = (size_t)(work.rect.x1 - work.rect.x0) *
               (size_t)(work.rect.y1 - work.rect.y0);
  auto offset = sizeof(header);
  unpack_array(bytes, offset, header[9] ? count : 0, work.accumulated);
  unpack_array(bytes, offset, header[10] ? count : 0, work.rngs);
  if (offset != bytes.size()) throw io_error("work item: wrong size");
  return work;
}

// Waiting between polls: blocking MPI calls spin a core that rendering
// needs. The pause doubles from 50 us to 1 ms while nothing arrives (a
// tile takes far longer), and starts again after a message.
struct poll_backoff {
  std::chrono::microseconds pause = std::chrono::microseconds(50);
};

static void pause_briefly(poll_backoff& backoff) {
  std::this_thread::sleep_for(backoff.pause);
  backoff.pause = std::min(backoff.pause * 2, std::chrono::microseconds(1000));
}

static mpi_session start_mpi() {
  auto session  = mpi_session{};
  auto provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  session.active = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &session.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &session.size);
  if (provided < MPI_THREAD_FUNNELED) {
    if (session.rank == 0)
      std::fprintf(stderr,
          "ypathtrace: error: the MPI library does not support threads "
          "(MPI_THREAD_FUNNELED)\n");
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return session;
}

// End the whole job after an error this rank already printed.
[[noreturn]] static void abort_job() {
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::abort();  // MPI_Abort does not return; this satisfies [[noreturn]]
}

// Broadcast bytes from rank 0, in pieces that fit MPI's int counts.
static void broadcast_bytes(std::string& bytes) {
  auto size = (uint64_t)bytes.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  bytes.resize(size);
  constexpr auto piece = uint64_t{1} << 30;
  for (auto offset = uint64_t{0}; offset < size; offset += piece)
    MPI_Bcast(bytes.data() + offset, (int)std::min(piece, size - offset),
        MPI_BYTE, 0, MPI_COMM_WORLD);
}

static void send_bytes(const std::string& bytes, int rank, int tag) {
  MPI_Send(
      bytes.data(), (int)bytes.size(), MPI_BYTE, rank, tag, MPI_COMM_WORLD);
}

// Receive the message that `status` announced.
static std::string receive_bytes(const MPI_Status& status) {
  auto count = 0;
  MPI_Get_count(&status, MPI_BYTE, &count);
  auto bytes = std::string((size_t)count, '\0');
  MPI_Recv(bytes.data(), count, MPI_BYTE, status.MPI_SOURCE, status.MPI_TAG,
      MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return bytes;
}

// Wait for a message from `source` without spinning a core.
static MPI_Status wait_message(int source) {
  auto status  = MPI_Status{};
  auto flag    = 0;
  auto backoff = poll_backoff{};
  while (true) {
    MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (flag) return status;
    pause_briefly(backoff);
  }
}

// Rank 0's MPI thread: hand out items on demand and gather results, while
// the render thread works through the same queue.
static void serve_ranks(scheduler& sched, int ranks) {
  auto idle     = std::deque<int>{};
  auto backoff  = poll_backoff{};
  auto released = 1;  // rank 0 itself
  auto renderer = std::thread([&] {
    try {
      render_local(sched);
    } catch (const std::exception& error) {
      auto lock   = std::lock_guard<std::mutex>(sched.mutex);
      sched.error = error.what();
      sched.changed.notify_all();
    }
  });
  while (released < ranks) {
    auto status = MPI_Status{};
    auto flag   = 0;
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (flag) {
      auto bytes = receive_bytes(status);
      if (status.MPI_TAG == tag_result) {
        auto work = unpack_work(bytes);
        auto lock = std::lock_guard<std::mutex>(sched.mutex);
        finish_work(sched, work);
        sched.changed.notify_all();
      }
      idle.push_back(status.MPI_SOURCE);
    }
    while (!idle.empty()) {
      auto work = std::optional<tile_work>{};
      auto done = false;
      {
        auto lock = std::lock_guard<std::mutex>(sched.mutex);
        if (!sched.error.empty()) break;
        work = take_work(sched);
        done = !work && sched.unassigned == 0;
      }
      if (!work && !done) break;
      auto rank = idle.front();
      idle.pop_front();
      if (work) {
        send_bytes(pack_work(*work), rank, tag_work);
      } else {
        send_bytes({}, rank, tag_done);
        released++;
      }
    }
    {
      auto lock = std::lock_guard<std::mutex>(sched.mutex);
      if (!sched.error.empty()) {
        std::fprintf(stderr, "ypathtrace: error: %s\n", sched.error.c_str());
        abort_job();
      }
    }
    if (flag) {
      backoff = {};
    } else {
      pause_briefly(backoff);
    }
  }
  renderer.join();
  if (!sched.error.empty()) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", sched.error.c_str());
    abort_job();
  }
}

// A rank > 0: ask for items, render them, send them back, until told done.
static void serve_rank_zero(
    const render_setup& setup, const distributed_options& options, int rank) {
  // Test hook: this rank dies after rendering its first item, before
  // sending it, as a crashed machine would.
  auto crash = env_int("IMPLICIT_TEST_CRASH_RANK", -1) == rank;
  send_bytes({}, 0, tag_ready);
  while (true) {
    auto status = wait_message(0);
    auto bytes  = receive_bytes(status);
    if (status.MPI_TAG == tag_done) return;
    auto work = unpack_work(bytes);
    render_tile_work(setup, frame_camera(setup, options, work.frame), work);
    if (crash) std::abort();
    send_bytes(pack_work(work), 0, tag_result);
  }
}

// Rank 0 checks the scene and sends it; the others load the copy. Returns
// nothing on every rank when the scene is bad (rank 0 printed why).
static std::optional<render_setup> share_scene(
    const mpi_session& session, const distributed_options& options) {
  auto setup = std::optional<render_setup>{};
  auto bytes = std::string{};
  auto ok    = 1;
  if (session.rank == 0) {
    try {
      setup = make_render_setup(options.scene, options, true);
      bytes = serialize_bundle(
          make_scene_bundle(options.scene, setup->context->scene));
    } catch (const std::exception& error) {
      std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
      ok = 0;
    }
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) return std::nullopt;
  broadcast_bytes(bytes);
  if (session.rank == 0) return setup;
  try {
    // A loaded scene holds its files' contents: the copy goes at once.
    auto folder   = temporary_folder{};
    auto filename = write_scene_bundle(deserialize_bundle(bytes), folder);
    return make_render_setup(filename, options, false);
  } catch (const std::exception& error) {
    std::fprintf(
        stderr, "ypathtrace: error: rank %d: %s\n", session.rank, error.what());
    abort_job();
  }
}

// The distributed run on every rank; returns the exit code.
static int run_ranks(
    const mpi_session& session, const distributed_options& options) {
  auto setup = share_scene(session, options);
  if (!setup) return 1;
  try {
    if (session.rank > 0) {
      serve_rank_zero(*setup, options, session.rank);
      return 0;
    }
    scheduler sched;
    start_scheduler(sched, *setup, options, session.size);
    if (session.size == 1) {
      render_local(sched);
    } else {
      serve_ranks(sched, session.size);
    }
    end_progress(sched.progress);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s%s\n",
        session.rank > 0
            ? ("rank " + std::to_string(session.rank) + ": ").c_str()
            : "",
        error.what());
    abort_job();
  }
  return 0;
}

#endif

// -----------------------------------------------------------------------------
// RUN
// -----------------------------------------------------------------------------

// One process: a sequence, or a single image under an mpirun of a build
// without MPI.
static int run_single(const distributed_options& options) {
  try {
    auto      setup = make_render_setup(options.scene, options, true);
    scheduler sched;
    start_scheduler(sched, setup, options, 1);
    render_local(sched);
    end_progress(sched.progress);
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
    return 1;
  }
}

int run_distributed(const distributed_options& options) {
#ifdef IMPLICIT_MPI
  if (launched_by_mpirun()) {
    auto session = start_mpi();
    auto code    = run_ranks(session, options);
    MPI_Finalize();
    return code;
  }
#else
  if (launched_by_mpirun() && env_int("OMPI_COMM_WORLD_SIZE", 1) > 1) {
    if (!is_primary_process()) return 0;
    std::fprintf(stderr,
        "warning: this ypathtrace was built without MPI; rank 0 renders "
        "alone\n");
  }
#endif
  return run_single(options);
}

}  // namespace implicit
