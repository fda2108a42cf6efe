// # ypathtrace: render implicit-surface scenes
//
// parse options -> the viewer, or the one render driver (render_run.h: single
// images, batches, sequences, MPI ranks). The render core owns every policy;
// this file parses the command line.

#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "render_run.h"
#include "scene/scene_io.h"
#include "trace/render.h"
#include "trace/render_options.h"
#include "util/error.h"
#include "util/file.h"
#ifdef IMPLICIT_VIEWER
#include "gui/viewer.h"
#endif

using namespace implicit;

// -----------------------------------------------------------------------------
// OPTIONS
// -----------------------------------------------------------------------------

struct app_options {
  render_settings render      = {};  // the table's options (render_options.h)
  std::string     scene       = "scene.json";
  std::string     output      = "out.png";
  int             savebatch   = 0;
  bool            interactive = false;
  bool            quiet       = false;
  // Viewer automation (tests and screenshots).
  int                frames      = 0;
  std::string        screenshot  = "";
  std::vector<float> orbit       = {};
  int                orbit_frame = 1;
};

// The placeholder of an option's value in --help.
static const char* value_name(render_option_type type) {
  switch (type) {
    case render_option_type::integer:
    case render_option_type::seed: return "N";
    case render_option_type::number: return "X";
    case render_option_type::flag: return "";
    case render_option_type::choice:
    case render_option_type::text: return "NAME";
    case render_option_type::list: return "LIST";
  }
  return "";
}

// Add one option of the table: its value is parsed and checked by the table
// as CLI11 reads it, so a bad one fails with the table's message.
static void add_render_option(
    CLI::App& app, render_settings& settings, const render_option& option) {
  auto name = "--" + option.name;
  auto set  = [&settings, &option](const std::string& value) {
    try {
      set_render_option(settings, option, value);
    } catch (const io_error& error) {
      throw CLI::ValidationError("--" + std::string{error.what()});
    }
  };
  if (option.type == render_option_type::flag) {
    app.add_flag_callback(
           name, [set] { set("true"); }, option.help)
        ->disable_flag_override();
    return;
  }
  auto help    = option.help;
  auto domain  = render_option_domain(option);
  auto current = get_render_option(settings, option);
  if (!domain.empty()) help += " [" + domain + "]";
  if (!current.empty()) help += " (default " + current + ")";
  app.add_option_function<std::string>(name, set, help)
      ->type_name(value_name(option.type));
}

static void add_options(CLI::App& app, app_options& opts) {
  app.add_option("--scene", opts.scene, "Scene file (JSON)")
      ->capture_default_str();
  app.add_option("--output", opts.output,
         "Output image (.png/.jpg tonemapped, .hdr/.exr linear)")
      ->capture_default_str();
  for (auto& option : render_option_table())
    if (option.cli) add_render_option(app, opts.render, option);
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
  if (!opts.interactive &&
      (opts.frames > 0 || !opts.screenshot.empty() || !opts.orbit.empty()))
    throw CLI::ValidationError(
        "--frames", "--frames, --screenshot and --orbit need --interactive");
  if (!opts.screenshot.empty() && opts.frames == 0)
    throw CLI::ValidationError("--screenshot",
        "--screenshot needs --frames (it saves the last frame)");
  // Ranges and finite values: the render core's one validation.
  try {
    validate_params(opts.render.params);
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

// Open the viewer on the render context.
static void run_interactive(
    const app_options& opts, const render_context& context) {
#ifdef IMPLICIT_VIEWER
  auto viewer        = viewer_params{};
  viewer.name        = std::filesystem::path{opts.scene}.filename().string();
  viewer.output      = opts.output;
  viewer.exposure    = opts.render.params.exposure;
  viewer.filmic      = opts.render.params.filmic;
  viewer.frames      = opts.frames;
  viewer.screenshot  = opts.screenshot;
  viewer.orbit_frame = opts.orbit_frame;
  if (opts.orbit.size() == 2) viewer.orbit = {opts.orbit[0], opts.orbit[1]};
  run_viewer(context, opts.render.params, viewer);
#else
  (void)opts, (void)context;
  throw io_error(
      "this build has no interactive viewer (IMPLICIT_BUILD_VIEWER=OFF); run "
      "without --interactive");
#endif
}

// The viewer on the scene.
static int run_viewer_app(app_options& opts) {
#ifdef IMPLICIT_VIEWER
  check_display();  // before a long scene load
#endif
  auto warnings = std::vector<std::string>{};
  auto scene    = load_scene(opts.scene, warnings);
  auto context  = make_render_context(std::move(scene), opts.render.params);
  opts.render.params = resolve_params(
      *context, opts.render.params, opts.render.camera, warnings);
  for (auto& warning : warnings)
    std::fprintf(stderr, "warning: %s\n", warning.c_str());
  run_interactive(opts, *context);
  return 0;
}

int main(int argc, char** argv) {
  app_options opts;  // not app_options{}: a false GCC 12 -Wmaybe-uninitialized
  auto        app =
      CLI::App{"Render scenes made of implicit surfaces (SDFs and SDF grids).",
          "ypathtrace"};
  add_options(app, opts);
  auto run = run_options{};  // --turntable and --tilesize
  add_run_options(app, run);
  try {
    app.parse(argc, argv);
    validate_options(opts);
    if (opts.interactive && (run.turntable > 0 || launched_by_mpirun()))
      throw CLI::ValidationError(
          "--interactive", "the viewer runs without mpirun and --turntable");
  } catch (const CLI::CallForHelp&) {
    if (is_primary_process()) std::printf("%s", app.help().c_str());
    return 0;
  } catch (const CLI::ParseError& error) {
    if (!is_primary_process()) return 2;  // rank 0 prints it
    // The reason and where to look, not the whole usage: a long help text
    // would scroll the one line that matters out of sight.
    std::fprintf(stderr,
        "ypathtrace: error: %s\nRun 'ypathtrace --help' for the options.\n",
        error.what());
    return 2;
  }
  try {
    auto control = std::unique_ptr<tbb::global_control>{};
    if (opts.render.threads > 0)
      control = std::make_unique<tbb::global_control>(
          tbb::global_control::max_allowed_parallelism, opts.render.threads);
    if (opts.interactive) return run_viewer_app(opts);
    run.scene = opts.scene, run.output = opts.output;
    run.camera = opts.render.camera, run.params = opts.render.params;
    run.savebatch = opts.savebatch, run.quiet = opts.quiet;
    return run_render(run);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
    return 1;
  }
}
