// # ypathtrace: the one render driver
//
// Every non-interactive run goes through run_render(): a single image, its
// --savebatch images, a --turntable sequence, in one process or on the ranks
// of an mpirun. The library cuts the job into work items and renders them
// (trace/render_queue.h); this driver loads the scene, shows the progress
// bar, writes the images, turns Ctrl-C and SIGTERM into a stop between
// blocks of pixels, and hands the ranks to mpi_ranks.cpp, which only moves
// bytes.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "trace/render_queue.h"
#include "util/progress.h"

namespace CLI {
class App;
}

namespace implicit {

// What a render run needs from the command line.
struct run_options {
  std::string  scene     = "scene.json";
  std::string  output    = "out.png";
  std::string  camera    = "";
  trace_params params    = {};  // as parsed (exposure and filmic too)
  int          savebatch = 0;
  bool         quiet     = false;
  int          turntable = 0;   // frames of the orbit; 0: one image
  int          tile_size = 32;  // pixels per tile side under mpirun
};

// Add --turntable and --tilesize to the command line.
void add_run_options(CLI::App& app, run_options& options);

// Whether the process was started by mpirun (by the environment variables
// that launchers set); MPI is initialised only then.
bool launched_by_mpirun();

// Ranks of the mpirun job by the launcher's environment (before MPI starts);
// 0 when the launcher does not say.
int launched_ranks();

// Whether this process prints command-line errors: all but the ranks > 0 of
// an mpirun job (so each error shows once).
bool is_primary_process();

// Render the image or sequence, distributed when under mpirun. Prints its
// errors (once) and returns the exit code: 0, 1 for an error, 130 when
// interrupted (the images written so far stay, nothing is half-written).
int run_render(const run_options& options);

// -----------------------------------------------------------------------------
// FOR THE RANKS (mpi_ranks.cpp)
// -----------------------------------------------------------------------------

// What every process renders with: the render core's context, the resolved
// parameters, the camera and the plan.
struct run_setup {
  std::unique_ptr<const render_context> context = {};
  trace_params                          params  = {};
  camera_data                           camera  = {};
  render_plan                           plan    = {};
};

// Load the scene and make the context (the render core applies its
// fallbacks) and the plan for `workers` processes. `verbose` prints the
// warnings (rank 0 only). Throws io_error.
run_setup make_run_setup(const std::string& filename,
    const run_options& options, int workers, bool verbose);

// What saving and the progress bar need while a job runs.
struct run_state {
  const run_options*       options = nullptr;
  run_setup*               setup   = nullptr;
  render_queue             queue   = {};
  progress_state           bar     = {};
  std::vector<std::string> notes   = {};  // printed after the bar
};

// Start the job's queue (with the bar, and Ctrl-C as cancel when asked)
// and the bar.
void start_run(run_state& state, run_setup& setup, const run_options& options,
    int ranks, bool cancellable);

// Write one finished image (render_save for render_queue_items()).
void save_run_output(void* user, const render_output& output);

// End the bar; print why a run stopped and return the exit code.
int end_run(run_state& state, bool finished);

// Run the job on the ranks of an mpirun; every rank calls it (mpi_ranks.cpp).
int run_ranks(const run_options& options);

}  // namespace implicit
