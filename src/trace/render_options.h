// # implicit: the table of render options
//
// Every option a user sets for a render is listed once here, with its type,
// range and help; its default is the one of trace_params (or of
// render_settings). ypathtrace's command line, the Python module's keyword
// arguments and the viewer's panel are made from this table, and
// validate_params() checks its ranges, as the scene loader reads primitives
// from sdf_primitive_table.h. Choices take their names from the enums' name
// tables (shader_type_names, ...). Values travel as text, as on a command
// line: get_render_option() writes one, set_render_option() parses and checks
// one.
#pragma once

#include <string>
#include <vector>

#include "trace.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SETTINGS
// -----------------------------------------------------------------------------

// What one render asks for: the parameters, plus the two settings a front
// end applies itself (the camera by name, through resolve_params(); the
// worker thread count).
struct render_settings {
  trace_params params  = {};
  std::string  camera  = "";  // camera name; "" finds one as Yocto/GL does
  int          threads = 0;   // 0: every core
};

// -----------------------------------------------------------------------------
// THE TABLE
// -----------------------------------------------------------------------------

// One row per option, in the order of --help.
enum class render_option_id {
  // clang-format off
  shader, camera, resolution, samples, bounces, clamp, seed, exposure, filmic,
  envhidden, tentfilter, noimplicitmis, mis, sampler, lightsampler, stmaxiter,
  accel, threads, pratio, aov, noise_threshold, min_samples, time, denoise,
  denoiser
  // clang-format on
};

// How a value is written and checked: integers and numbers within
// [min, max] (numbers also finite), `seed` any 64-bit unsigned integer,
// flags "true" or "false", choices one of `choices`, text anything, a list
// any subset of `choices`, comma-separated ("" for none; stored as one bit
// per choice).
enum class render_option_type {
  integer,
  seed,
  number,
  flag,
  choice,
  text,
  list
};
inline const std::vector<std::string> render_option_type_names = {
    "integer", "seed", "number", "flag", "choice", "text", "list"};

// Where an option appears. Output options act after the render (tone
// mapping of .png/.jpg): the viewer only re-tonemaps for them, and Python
// takes them when saving, not when rendering.
enum class render_option_stage { render, output };

struct render_option {
  render_option_id id = render_option_id::shader;
  // --name, the viewer's label; Python's name= has '_' for each '-'.
  std::string         name   = "";
  render_option_type  type   = render_option_type::integer;
  render_option_stage stage  = render_option_stage::render;
  double              min    = 0;  // integer, number: the valid range
  double              max    = 0;
  double              ui_min = 0;  // the viewer's slider, within the range
  double              ui_max = 0;
  bool                log    = false;  // the slider is logarithmic
  bool                cli    = true;   // ypathtrace --name
  bool                python = true;   // render(name=...)
  bool                viewer = true;   // a widget in the viewer's panel
  // Acts on the samples a render has (denoising): the viewer re-shows its
  // render for it instead of starting over.
  bool        refilter = false;
  std::string help     = "";
  // choice: the enum's name table (shader_type_names, ...), not a copy.
  const std::vector<std::string>* choices = nullptr;
};

// The rows, in the order of render_option_id.
const std::vector<render_option>& render_option_table();

// The row called `name`, or null.
const render_option* find_render_option(const std::string& name);

// -----------------------------------------------------------------------------
// VALUES
// -----------------------------------------------------------------------------

// An option's value as text: integers in decimal, numbers in the shortest
// form that reads back exactly, flags "true"/"false", choices their name.
std::string get_render_option(
    const render_settings& settings, const render_option& option);

// Parse `value` and set the option; throws io_error "name: problem" (not an
// integer, out of range [min, max], not finite, an unknown choice with the
// valid names) and then leaves `settings` unchanged.
void set_render_option(render_settings& settings, const render_option& option,
    const std::string& value);

// Why the option's current value is invalid ("0 is out of range [1, 8]"), or
// "" when it is valid.
std::string check_render_option(
    const render_settings& settings, const render_option& option);

// The range or choices of an option for help texts: "1..16384",
// "implicit|implicit_normal|...", "true|false" or "" (text).
std::string render_option_domain(const render_option& option);

}  // namespace implicit
