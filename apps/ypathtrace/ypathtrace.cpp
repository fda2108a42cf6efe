// # ypathtrace: render implicit-surface scenes
//
// parse options -> load scene -> render context (trace/render.h) -> render
// samples -> save. The render core owns every policy; this file parses,
// reports and writes.

#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "distributed.h"
#include "image/image_io.h"
#include "scene/scene_io.h"
#include "trace/render.h"
#include "util/error.h"
#include "util/file.h"
#include "util/progress.h"
#ifdef IMPLICIT_VIEWER
#include "gui/viewer.h"
#endif

using namespace implicit;

// -----------------------------------------------------------------------------
// OPTIONS
// -----------------------------------------------------------------------------

struct app_options {
  std::string  scene         = "scene.json";
  std::string  output        = "out.png";
  std::string  camera        = "";
  std::string  shader        = "implicit";
  std::string  accel         = "bvh";
  std::string  mis           = "two";
  std::string  sampler       = "sobol";
  trace_params params        = {};
  bool         noimplicitmis = false;
  int          threads       = 0;
  int          savebatch     = 0;
  bool         interactive   = false;
  bool         quiet         = false;
  // Viewer automation (tests and screenshots).
  int                frames      = 0;
  std::string        screenshot  = "";
  std::vector<float> orbit       = {};
  int                orbit_frame = 1;
};

// Turn a name into an enum value using its names table.
template <typename T>
static T parse_enum(const std::string& option, const std::string& value,
    const std::vector<std::string>& names) {
  for (auto i = 0; i < (int)names.size(); i++)
    if (names[i] == value) return (T)i;
  auto valid = std::string{};
  for (auto& name : names) valid += (valid.empty() ? "" : ", ") + name;
  throw CLI::ValidationError(
      option, "unknown value \"" + value + "\" (valid: " + valid + ")");
}

static void add_options(CLI::App& app, app_options& opts) {
  auto& p = opts.params;
  app.add_option("--scene", opts.scene, "Scene file (JSON)")
      ->capture_default_str();
  app.add_option("--output", opts.output,
         "Output image (.png/.jpg tonemapped, .hdr/.exr linear)")
      ->capture_default_str();
  app.add_option(
      "--camera", opts.camera, "Camera name (default: as Yocto/GL finds it)");
  app.add_option("--shader", opts.shader,
         "Shader: implicit, implicit_normal, eyelight, normal, position, "
         "color, "
         "frontfacing, material, steps")
      ->capture_default_str();
  app.add_option(
         "--resolution", p.resolution, "Image size along the longest side")
      ->check(CLI::Range(1, 16384))
      ->capture_default_str();
  app.add_option("--samples", p.samples, "Samples per pixel")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  app.add_option("--bounces", p.bounces, "Maximum path length")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--clamp", p.clamp, "Clamp sample radiance to this value")
      ->capture_default_str();
  app.add_option("--seed", p.seed, "Random seed")->capture_default_str();
  app.add_option("--exposure", p.exposure, "Exposure in stops (LDR output)")
      ->capture_default_str();
  app.add_flag("--filmic", p.filmic, "Filmic tone curve (LDR output)");
  app.add_flag(
      "--envhidden", p.envhidden, "Hide the environment behind the scene");
  app.add_flag(
      "--tentfilter", p.tentfilter, "Tent pixel filter instead of box");
  app.add_flag("--noimplicitmis", opts.noimplicitmis,
      "Disable light sampling (BSDF sampling only)");
  app.add_option("--mis", opts.mis,
         "Light sampling: one (the seed's one-sample MIS) or two (two-sample, "
         "power heuristic)")
      ->capture_default_str();
  app.add_option("--sampler", opts.sampler,
         "Random numbers: sobol (scrambled Sobol points, stratified per "
         "pixel) or random (independent PCG32 numbers, as Yocto/GL)")
      ->capture_default_str();
  app.add_option(
         "--stmaxiter", p.march.max_iterations, "Sphere-tracing iteration cap")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_option("--accel", opts.accel,
         "Intersection: bvh (objects marched in their own boxes) or none (the "
         "seed's minimum over all objects)")
      ->capture_default_str();
  app.add_option("--threads", opts.threads, "Worker threads (0: all cores)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_option("--savebatch", opts.savebatch,
         "Also save the image every N samples as <output>-s<samples>.<ext>")
      ->check(CLI::Range(0, 1 << 20));
  app.add_flag(
      "--interactive", opts.interactive, "Open the interactive viewer");
  app.add_flag("--quiet", opts.quiet, "No progress output");
  auto automation = "Viewer automation";
  app.add_option("--frames", opts.frames,
         "Close the viewer after N frames, once every sample is rendered")
      ->check(CLI::Range(0, 1 << 30))
      ->group(automation);
  app.add_option("--screenshot", opts.screenshot,
         "Save the viewer's last frame to this image")
      ->group(automation);
  app.add_option("--orbit", opts.orbit,
         "Drag the viewer's camera by DX,DY pixels at frame --orbit-frame")
      ->delimiter(',')
      ->expected(2)
      ->group(automation);
  app.add_option("--orbit-frame", opts.orbit_frame, "Frame of the --orbit drag")
      ->check(CLI::Range(1, 1 << 30))
      ->group(automation);
}

// Check the options that CLI11 cannot check alone.
static void validate_options(app_options& opts) {
  auto& p = opts.params;
  p.shader =
      parse_enum<shader_type>("--shader", opts.shader, shader_type_names);
  p.accel = parse_enum<accel_type>("--accel", opts.accel, accel_type_names);
  p.mis   = parse_enum<mis_type>("--mis", opts.mis, mis_type_names);
  p.sampler =
      parse_enum<sampler_type>("--sampler", opts.sampler, sampler_type_names);
  p.implicit_mis = !opts.noimplicitmis;
  if (!opts.interactive &&
      (opts.frames > 0 || !opts.screenshot.empty() || !opts.orbit.empty()))
    throw CLI::ValidationError(
        "--frames", "--frames, --screenshot and --orbit need --interactive");
  if (!opts.screenshot.empty() && opts.frames == 0)
    throw CLI::ValidationError("--screenshot",
        "--screenshot needs --frames (it saves the last frame)");
  // Ranges and finite values: the render core's one validation.
  try {
    validate_params(p);
  } catch (const io_error& error) { throw CLI::ValidationError(error.what()); }
  // The output is checked before a render that may take hours.
  auto ext = path_extension(opts.output);
  if (ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".hdr" &&
      ext != ".exr")
    throw CLI::ValidationError(
        "--output", "unsupported image format \"" + opts.output +
                        "\" (use .png, .jpg, .hdr or .exr)");
  // Under mpirun only rank 0 writes; other machines may lack the folder.
  try {
    if (is_primary_process()) check_output_directory(opts.output);
  } catch (const io_error& error) {
    throw CLI::ValidationError("--output", error.what());
  }
}

// -----------------------------------------------------------------------------
// RENDER
// -----------------------------------------------------------------------------

// Set by SIGINT and SIGTERM; the render asks it between tiles. (The one
// global: a signal handler can reach nothing else.)
static std::atomic<bool> interrupted = false;

static void on_signal(int) { interrupted.store(true); }

static bool is_interrupted(void*) { return interrupted.load(); }

// The bar during one pass of `count` samples from `first`: it moves as the
// pass's tiles finish (the library calls one at a time).
struct pass_progress {
  progress_state* progress = nullptr;
  int             first = 0, count = 0;
};

static void on_tile_done(void* user, int64_t done, int64_t total) {
  auto& pass = *(pass_progress*)user;
  update_progress(*pass.progress,
      pass.first +
          (int)((int64_t)pass.count * done / std::max(total, int64_t{1})));
}

// Open the viewer on the render context.
static void run_interactive(
    const app_options& opts, const render_context& context) {
#ifdef IMPLICIT_VIEWER
  auto viewer        = viewer_params{};
  viewer.name        = std::filesystem::path{opts.scene}.filename().string();
  viewer.output      = opts.output;
  viewer.exposure    = opts.params.exposure;
  viewer.filmic      = opts.params.filmic;
  viewer.frames      = opts.frames;
  viewer.screenshot  = opts.screenshot;
  viewer.orbit_frame = opts.orbit_frame;
  if (opts.orbit.size() == 2) viewer.orbit = {opts.orbit[0], opts.orbit[1]};
  run_viewer(context, opts.params, viewer);
#else
  (void)opts, (void)context;
  throw io_error(
      "this build has no interactive viewer (IMPLICIT_BUILD_VIEWER=OFF); run "
      "without --interactive");
#endif
}

static int run(app_options& opts) {
#ifdef IMPLICIT_VIEWER
  if (opts.interactive) check_display();  // before a long scene load
#endif
  auto warnings = std::vector<std::string>{};
  auto scene    = load_scene(opts.scene, warnings);
  auto context  = make_render_context(std::move(scene), opts.params);
  auto params   = resolve_params(*context, opts.params, opts.camera, warnings);
  for (auto& warning : warnings)
    std::fprintf(stderr, "warning: %s\n", warning.c_str());

  if (opts.interactive) {
    opts.params = params;
    run_interactive(opts, *context);
    return 0;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  auto state    = make_render_state(*context, params);
  auto progress = progress_state{};
  start_progress(progress, "render " + opts.scene, params.samples,
      !opts.quiet && stderr_is_terminal());
  // Passes of up to max_pass_samples, ending at each --savebatch image:
  // every pixel takes a pass's samples one after the other, and each finds
  // in cache what the previous one read (3-10% faster on the seed's scenes
  // at 32 spp than a pass per sample). The image is the same.
  for (auto sample = 0; sample < params.samples;) {
    auto end = std::min(params.samples, sample + max_pass_samples);
    if (opts.savebatch > 0)
      end = std::min(end, (sample / opts.savebatch + 1) * opts.savebatch);
    auto pass      = pass_progress{&progress, sample, end - sample};
    auto callbacks = render_callbacks{on_tile_done, is_interrupted, &pass};
    if (!render_step(*context, state, end - sample, callbacks)) {
      end_progress(progress);
      std::fprintf(stderr,
          "ypathtrace: interrupted after %d of %d samples; %s not written\n",
          state.samples, params.samples, opts.output.c_str());
      return 130;
    }
    update_progress(progress, end);
    if (opts.savebatch > 0 && end % opts.savebatch == 0 &&
        end < params.samples) {
      save_image(batch_filename(opts.output, end), get_image(state),
          params.exposure, params.filmic);
    }
    sample = end;
  }
  end_progress(progress);
  save_image(opts.output, get_image(state), params.exposure, params.filmic);
  return 0;
}

int main(int argc, char** argv) {
  auto app =
      CLI::App{"Render scenes made of implicit surfaces (SDFs and SDF grids).",
          "ypathtrace"};
  auto opts = app_options{};
  add_options(app, opts);
  auto dist = distributed_options{};  // mpirun and --turntable
  add_distributed_options(app, dist);
  try {
    app.parse(argc, argv);
    validate_options(opts);
    if (opts.interactive && needs_distributed(dist))
      throw CLI::ValidationError(
          "--interactive", "the viewer runs without mpirun and --turntable");
  } catch (const CLI::CallForHelp&) {
    if (is_primary_process()) std::printf("%s", app.help().c_str());
    return 0;
  } catch (const CLI::ParseError& error) {
    if (!is_primary_process()) return 2;  // rank 0 prints it
    std::fprintf(stderr, "ypathtrace: error: %s\n\n%s", error.what(),
        app.help().c_str());
    return 2;
  }
  try {
    auto control = std::unique_ptr<tbb::global_control>{};
    if (opts.threads > 0)
      control = std::make_unique<tbb::global_control>(
          tbb::global_control::max_allowed_parallelism, opts.threads);
    if (needs_distributed(dist)) {
      dist.scene = opts.scene, dist.output = opts.output;
      dist.camera = opts.camera, dist.params = opts.params;
      dist.savebatch = opts.savebatch, dist.quiet = opts.quiet;
      return run_distributed(dist);
    }
    return run(opts);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
    return 1;
  }
}
