// # ypathtrace: the one render driver (see render_run.h)

#include "render_run.h"

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>

#include "image/image_io.h"
#include "scene/scene_io.h"
#include "util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// OPTIONS
// -----------------------------------------------------------------------------

void add_run_options(CLI::App& app, run_options& options) {
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

int launched_ranks() {
  auto size = env_int("OMPI_COMM_WORLD_SIZE", 0);
  return size > 0 ? size : std::max(0, env_int("PMI_SIZE", 0));
}

bool is_primary_process() {
  return env_int("OMPI_COMM_WORLD_RANK", 0) == 0 &&
         env_int("PMI_RANK", 0) == 0 && env_int("PMIX_RANK", 0) == 0;
}

// -----------------------------------------------------------------------------
// SETUP
// -----------------------------------------------------------------------------

run_setup make_run_setup(const std::string& filename,
    const run_options& options, int workers, bool verbose) {
  auto setup    = run_setup{};
  auto warnings = std::vector<std::string>{};
  auto scene    = load_scene(filename, warnings);
  setup.context = make_render_context(std::move(scene), options.params);
  setup.params =
      resolve_params(*setup.context, options.params, options.camera, warnings);
  if (verbose)
    for (auto& warning : warnings)
      std::fprintf(stderr, "warning: %s\n", warning.c_str());
  setup.camera = setup.context->scene.cameras[setup.params.camera];
  // Which frames are left is asked only where the files are written.
  auto frames = verbose ? frames_to_render(options.output, options.turntable)
                        : std::vector<int>{};
  setup.plan  = make_render_plan(render_size(*setup.context, setup.params),
       setup.params.samples, options.savebatch, options.turntable, frames,
       options.tile_size, workers, setup.params.time);
  return setup;
}

// -----------------------------------------------------------------------------
// RUN
// -----------------------------------------------------------------------------

// Set by SIGINT and SIGTERM; the render asks it between blocks. (The one
// global: a signal handler can reach nothing else.)
static std::atomic<bool> interrupted = false;

static void on_signal(int) { interrupted.store(true); }

static bool is_interrupted(void*) { return interrupted.load(); }

// The bar counts samples per pixel over all frames; the queue reports pixel
// samples.
static void on_progress(void* user, int64_t done, int64_t total) {
  auto& state         = *(run_state*)user;
  auto  units         = (int64_t)state.bar.total;
  state.bar.converged = state.queue.converged;  // the queue's lock is held
  update_progress(state.bar, (int)(units * done / std::max(total, int64_t{1})));
}

void start_run(run_state& state, run_setup& setup, const run_options& options,
    int ranks, bool cancellable) {
  state.options = &options;
  state.setup   = &setup;
  auto message  = "render " + options.scene +
                 (ranks > 1 ? " on " + std::to_string(ranks) + " ranks" : "");
  // Under mpirun stderr is a pipe to mpirun, which may well be on a
  // terminal: rank 0 shows the bar unless --quiet.
  auto& plan = setup.plan;
  start_progress(state.bar, message, (int)plan.frames.size() * plan.samples,
      !options.quiet && (launched_by_mpirun() || stderr_is_terminal()));
  if (plan.turntable == 0) state.bar.limit = plan.time;
  auto callbacks = render_callbacks{
      on_progress, cancellable ? is_interrupted : nullptr, &state};
  start_render_queue(
      state.queue, setup.plan, setup.params, setup.camera, callbacks);
}

void save_run_output(void* user, const render_output& output) {
  auto& state  = *(run_state*)user;
  auto& params = state.setup->params;
  auto name = output_filename(state.options->output, state.setup->plan, output);
  save_image(name, output.image, params.exposure, params.filmic,
      average_layers(output.data, params));
  if (output.final && output.samples < state.setup->plan.samples)
    state.notes.push_back("ypathtrace: the time budget ended " + name + " at " +
                          std::to_string(output.samples) +
                          " samples per pixel");
}

int end_run(run_state& state, bool finished) {
  end_progress(state.bar);
  if (!state.options->quiet)
    for (auto& note : state.notes) std::fprintf(stderr, "%s\n", note.c_str());
  if (finished) return 0;
  auto& options = *state.options;
  if (interrupted.load()) {
    auto& plan = state.setup->plan;
    auto  done = state.queue.done / ((int64_t)plan.width * plan.height);
    std::fprintf(stderr,
        "ypathtrace: interrupted after %lld of %lld samples; %s not "
        "written%s\n",
        (long long)done, (long long)plan.frames.size() * plan.samples,
        options.turntable > 0 ? "the frames not finished are"
                              : options.output.c_str(),
        options.savebatch > 0 || options.turntable > 0
            ? " (the images already saved stay)"
            : "");
    return 130;
  }
  std::fprintf(stderr, "ypathtrace: error: %s\n",
      render_queue_error(state.queue).c_str());
  return 1;
}

// One process: the image or the sequence, items one after another, each
// with every thread.
static int run_local(const run_options& options) {
  auto setup = make_run_setup(options.scene, options, 1, true);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  auto state = run_state{};
  start_run(state, setup, options, 1, true);
  auto finished = false;
  try {
    finished = render_queue_items(
        state.queue, *setup.context, save_run_output, &state);
  } catch (const std::exception& error) {
    stop_render_queue(state.queue, error.what());
  }
  return end_run(state, finished);
}

int run_render(const run_options& options) {
  try {
#ifdef IMPLICIT_MPI
    if (launched_by_mpirun()) return run_ranks(options);
#else
    if (launched_by_mpirun() && launched_ranks() > 1) {
      if (!is_primary_process()) return 0;
      std::fprintf(stderr,
          "warning: this ypathtrace was built without MPI; rank 0 renders "
          "alone\n");
    }
#endif
    return run_local(options);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
    return 1;
  }
}

}  // namespace implicit
