// # ypathtrace: distributed rendering and sequences
//
// Started under mpirun, ypathtrace splits the render by pixels over the ranks:
// rank 0 loads and checks the scene, broadcasts it with its files (no shared
// filesystem needed), hands out tiles on demand and renders too; it gathers
// the tiles, shows the progress bar and writes the files. Each pixel takes
// all its samples, in order, with its own random stream on one rank, so the
// image is byte for byte the one of a single process. `--turntable N` renders
// N frames orbiting the camera, with or without MPI.
#pragma once

#include <string>

#include "scene/scene.h"
#include "trace/trace.h"

namespace CLI {
class App;
}

namespace implicit {

// What a distributed or sequence render needs from the command line.
struct distributed_options {
  std::string  scene     = "scene.json";
  std::string  output    = "out.png";
  std::string  camera    = "";
  trace_params params    = {};  // as parsed (exposure and filmic too)
  int          savebatch = 0;
  bool         quiet     = false;
  int          turntable = 0;   // frames of the orbit; 0: one image
  int          tile_size = 64;  // pixels per tile side under mpirun
};

// Add --turntable and --tilesize to the command line.
void add_distributed_options(CLI::App& app, distributed_options& options);

// Whether the process was started by mpirun (by the environment variables
// that launchers set); MPI is initialised only then.
bool launched_by_mpirun();

// Whether this process prints command-line errors: all but the ranks > 0 of
// an mpirun job (so each error shows once).
bool is_primary_process();

// Whether the command needs run_distributed (mpirun or a sequence).
bool needs_distributed(const distributed_options& options);

// Render the image or sequence, distributed when under mpirun. Prints its
// errors (once) and returns the exit code; on a failure after the ranks have
// started, the whole job is aborted, and no output file is left unfinished.
int run_distributed(const distributed_options& options);

// Camera `frame` of `frames` orbiting `camera` about its focus point, around
// the world's vertical (y) axis.
camera_data turntable_camera(const camera_data& camera, int frame, int frames);

// Output name of a sequence frame: out.png -> out-0003.png.
std::string frame_filename(const std::string& output, int frame);

// Name of a batch image (--savebatch): out.png -> out-s0016.png.
std::string batch_filename(const std::string& output, int samples);

}  // namespace implicit
