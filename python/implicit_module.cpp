// # implicit: the Python extension `_implicit`
//
// The compiled half of the Python package `implicit` (python/implicit/ holds
// the other half: expressions and scene building in pure Python, which write
// the project's JSON scene format). This file only converts: JSON text in,
// scenes, SDF programs, images and meshes out, through the same library
// functions as ypathtrace and ysdf, so Python and the command line see the
// same scenes and compute the same images. Library errors (io_error) become
// `implicit.Error`; bad Python arguments become ValueError or TypeError.
//
// Rendering is the library's render core (trace/render.h): the render
// context, its fallbacks and its parameter checks are the ones ypathtrace
// uses; this file only converts options and drives it. Long calls (loading,
// rendering, baking, evaluating many points) release the GIL. Rendering runs
// on a worker thread while the calling thread wakes every few milliseconds,
// takes the GIL back and delivers Ctrl-C and the progress callback; a pending
// exception cancels the render before its next tile.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <algorithm>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "image/image_io.h"
#include "scene/scene_io.h"
#include "sdf/sdf_expression.h"
#include "sdf/sdf_grid.h"
#include "sdf/sdf_grid_io.h"
#include "sdf/sdf_mesh.h"
#include "sdf/sdf_mesh_io.h"
#include "sdf/sdf_operator_table.h"
#include "sdf/sdf_program.h"
#include "sdf/sdf_tape.h"
#include "sdf/sdf_vm_io.h"
#include "trace/render.h"
#include "trace/render_options.h"
#include "util/error.h"
#include "util/file.h"

namespace py = pybind11;
using namespace implicit;

namespace {

static_assert(sizeof(vec4f) == 4 * sizeof(float), "vec4f must be 4 floats");
static_assert(sizeof(vec3f) == 3 * sizeof(float), "vec3f must be 3 floats");
static_assert(sizeof(vec3i) == 3 * sizeof(int), "vec3i must be 3 ints");

// -----------------------------------------------------------------------------
// CONVERSIONS
// -----------------------------------------------------------------------------

// "(2, 3)" for an array's shape, in messages.
std::string shape_text(const py::array& array) {
  auto text = std::string{"("};
  for (auto i = 0; i < (int)array.ndim(); i++)
    text += (i ? ", " : "") + std::to_string(array.shape(i));
  return text + (array.ndim() == 1 ? ",)" : ")");
}

// An image as a float32 (height, width, 4) array (a copy).
py::array_t<float> image_to_array(const image_data& image) {
  auto array = py::array_t<float>(
      {(py::ssize_t)image.height, (py::ssize_t)image.width, (py::ssize_t)4});
  if (!image.pixels.empty())
    std::memcpy(array.mutable_data(), image.pixels.data(),
        image.pixels.size() * sizeof(vec4f));
  return array;
}

// The AOV layers of a render as arrays by name: (height, width, channels),
// or (height, width) for one channel (depth); with "image" the image.
py::dict layers_to_dict(const render_state& state) {
  auto result     = py::dict{};
  result["image"] = image_to_array(output_image(state.buffer, state.params));
  for (auto& layer : average_layers(state.buffer, state.params)) {
    auto channels = (py::ssize_t)layer.channels.size();
    auto shape    = std::vector<py::ssize_t>{state.height, state.width};
    if (channels > 1) shape.push_back(channels);
    auto array = py::array_t<float>(shape);
    std::memcpy(array.mutable_data(), layer.values.data(),
        layer.values.size() * sizeof(float));
    result[layer.name.c_str()] = array;
  }
  return result;
}

// A (height, width, 4) or (height, width, 3) array as an image; three
// channels get alpha 1.
image_data array_to_image(const py::array& input) {
  auto array =
      py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(
          input);
  if (!array || array.ndim() != 3 || array.shape(0) < 1 || array.shape(1) < 1 ||
      (array.shape(2) != 3 && array.shape(2) != 4))
    throw py::value_error(
        "expected an image array of shape (height, width, 4) or (height, "
        "width, 3), found " +
        (array ? shape_text(array) : std::string{"a non-numeric value"}));
  auto image    = make_image((int)array.shape(1), (int)array.shape(0));
  auto channels = (int)array.shape(2);
  auto data     = array.data();
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto p            = data + idx * channels;
    image.pixels[idx] = {p[0], p[1], p[2], channels == 4 ? p[3] : 1.0f};
  }
  return image;
}

// -----------------------------------------------------------------------------
// SCENES
// -----------------------------------------------------------------------------

// A loaded scene, as its render context (built once for the default
// accelerator settings; renders share it, it never changes).
struct py_scene {
  std::shared_ptr<const render_context> context  = {};
  trace_params                          built    = {};  // its accel settings
  std::string                           filename = "";
  std::vector<std::string>              warnings = {};
};

// Issue each message as a Python UserWarning.
void warn_all(const std::vector<std::string>& messages) {
  for (auto& message : messages)
    if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0)
      throw py::error_already_set();
}

// Load (or parse) a scene and make its render context, without the GIL.
template <typename Load>
std::shared_ptr<py_scene> make_py_scene(
    const std::string& filename, const Load& load) {
  auto scene      = std::make_shared<py_scene>();
  scene->filename = filename;
  {
    py::gil_scoped_release release;
    scene->context = make_render_context(load(scene->warnings), scene->built);
  }
  warn_all(scene->warnings);
  return scene;
}

std::shared_ptr<py_scene> load_scene_file(const std::string& filename) {
  return make_py_scene(filename, [&](std::vector<std::string>& warnings) {
    return load_scene(filename, warnings);
  });
}

std::shared_ptr<py_scene> parse_scene_text(
    const std::string& text, const std::string& filename) {
  return make_py_scene(filename, [&](std::vector<std::string>& warnings) {
    return parse_scene(text, filename, warnings, true);
  });
}

// The context to render `params` with: the scene's own, or, when the
// options change what the context builds (the accelerator, the only build
// setting Python sets), one made from a copy of the scene.
std::shared_ptr<const render_context> context_for(
    const py_scene& scene, const trace_params& params) {
  if (params.accel == scene.built.accel) return scene.context;
  py::gil_scoped_release release;
  auto                   copy = scene.context->scene;
  return make_render_context(std::move(copy), params);
}

// -----------------------------------------------------------------------------
// RENDER OPTIONS
// -----------------------------------------------------------------------------

// The options Python takes: the table's rows for render() (not the output
// stage: save_image() takes exposure and filmic).
std::vector<const render_option*> python_render_options() {
  auto options = std::vector<const render_option*>{};
  for (auto& option : render_option_table())
    if (option.python) options.push_back(&option);
  return options;
}

// An option's keyword: its name with '_' for each '-' (noise_threshold).
std::string python_name(const render_option& option) {
  auto name = option.name;
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

std::string join_names(const std::vector<const render_option*>& options) {
  auto text = std::string{};
  for (auto option : options)
    text += (text.empty() ? "" : ", ") + python_name(*option);
  return text;
}

// The name of a Python value's type, for messages.
std::string type_name(const py::handle& value) {
  return py::str(value.get_type().attr("__name__"));
}

// A Python value as the table's text for `option`: TypeError when Python
// passed the wrong kind of value (an integer option takes an int, not a
// bool or a float; a number an int or a float; a flag a bool; a name a str;
// the camera also None). The range is the table's to check.
std::string option_text(const render_option& option, const py::handle& value) {
  auto is_bool  = py::isinstance<py::bool_>(value);
  auto is_int   = !is_bool && py::isinstance<py::int_>(value);
  auto expected = std::string{};
  switch (option.type) {
    case render_option_type::integer:
    case render_option_type::seed:
      if (is_int) return py::str(value);
      expected = "an integer";
      break;
    case render_option_type::number:
      if (is_int) return py::str(value);  // exact; huge ones out of range
      if (py::isinstance<py::float_>(value)) return py::repr(value);
      expected = "a number";
      break;
    case render_option_type::flag:
      if (is_bool) return value.cast<bool>() ? "true" : "false";
      expected = "True or False";
      break;
    case render_option_type::choice:
    case render_option_type::text:
      if (py::isinstance<py::str>(value)) return value.cast<std::string>();
      if (option.type == render_option_type::text && value.is_none()) return "";
      expected = "a string";
      break;
    case render_option_type::list:
      // "albedo,normal" or ["albedo", "normal"].
      if (py::isinstance<py::str>(value)) return value.cast<std::string>();
      if (value.is_none()) return "";
      if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
        auto text = std::string{};
        for (auto name : value) {
          if (!py::isinstance<py::str>(name)) {
            text = "";
            break;
          }
          text += (text.empty() ? "" : ",") + name.cast<std::string>();
        }
        if (!text.empty() || py::len(value) == 0) return text;
      }
      expected = "a list of names";
      break;
  }
  throw py::type_error(
      option.name + ": expected " + expected + ", found " + type_name(value));
}

// Options from keyword arguments; absent ones keep the library's defaults.
// Values out of range or unknown names raise ValueError with the table's
// message.
render_settings read_render_options(const py::kwargs& kwargs) {
  auto settings = render_settings{};
  auto options  = python_render_options();
  for (auto item : kwargs) {
    auto key  = item.first.cast<std::string>();
    auto name = key;
    std::replace(name.begin(), name.end(), '_', '-');
    auto option = find_render_option(name);
    if (!option || !option->python)
      throw py::type_error("unknown render option '" + key +
                           "' (options: " + join_names(options) + ")");
    try {
      set_render_option(settings, *option, option_text(*option, item.second));
    } catch (const io_error& error) { throw py::value_error(error.what()); }
  }
  return settings;
}

// A default value as the Python value of its type.
py::object option_value(const render_option& option, const std::string& text) {
  switch (option.type) {
    case render_option_type::integer:
    case render_option_type::seed: return py::int_(py::str(text));
    case render_option_type::number: return py::float_(std::stod(text));
    case render_option_type::flag: return py::bool_(text == "true");
    case render_option_type::choice: return py::str(text);
    case render_option_type::text:
      return text.empty() ? py::object(py::none()) : py::str(text);
    case render_option_type::list: {
      auto names = py::list{};
      for (size_t start = 0; start < text.size();) {
        auto end = std::min(text.find(',', start), text.size());
        names.append(py::str(text.substr(start, end - start)));
        start = end + 1;
      }
      return names;
    }
  }
  return py::none();
}

// The defaults, as a dict of option -> value (the library's trace_params).
py::dict default_render_options() {
  auto defaults = render_settings{};
  auto options  = py::dict{};
  for (auto option : python_render_options())
    options[python_name(*option).c_str()] =
        option_value(*option, get_render_option(defaults, *option));
  return options;
}

// The table for documentation: name -> (type, default, range or choices,
// help).
py::dict render_option_help() {
  auto defaults = render_settings{};
  auto help     = py::dict{};
  for (auto option : python_render_options())
    help[python_name(*option).c_str()] =
        py::make_tuple(render_option_type_names[(int)option->type],
            option_value(*option, get_render_option(defaults, *option)),
            render_option_domain(*option), option->help);
  return help;
}

// -----------------------------------------------------------------------------
// RENDER LOOP
// -----------------------------------------------------------------------------

// How often the waiting thread takes the GIL to check for Ctrl-C and report
// progress.
constexpr auto poll_interval = std::chrono::milliseconds(20);

// The render core's cancel callback: a flag the waiting thread sets.
bool is_cancelled(void* user) {
  return ((std::atomic<bool>*)user)->load(std::memory_order_relaxed);
}

// Add `samples` samples per pixel to `state`, one render_step() per sample
// (so that a cancel takes effect within one tile of one sample; the core sums
// samples in order, so the image is that of a single step). The steps run on
// a worker thread, in a TBB arena of `threads` threads (0: all), while this
// thread, without the GIL, wakes every poll_interval to run Python's signal
// handlers and call `progress(done, total)` (samples per pixel) when the
// count changed. An exception from either (KeyboardInterrupt from Ctrl-C, or
// one raised by the callback) cancels the render before its next tile and is
// raised here; the state then holds a partial pass.
void render_samples(const render_context& context, render_state& state,
    int samples, int threads, const py::object& progress) {
  auto mutex     = std::mutex{};
  auto finished  = std::condition_variable{};
  auto done      = false;
  auto error     = std::exception_ptr{};
  auto cancel    = std::atomic<bool>{false};
  auto count     = std::atomic<int>{state.samples};
  auto total     = state.samples + samples;
  auto callbacks = render_callbacks{nullptr, is_cancelled, &cancel};
  auto arena =
      tbb::task_arena(threads > 0 ? threads : tbb::task_arena::automatic);

  auto python_error = std::exception_ptr{};
  auto reported     = -1;
  // Deliver signals and progress; true when Python raised.
  auto poll_python = [&]() {
    if (PyErr_CheckSignals() != 0) {
      python_error = std::make_exception_ptr(py::error_already_set());
      return true;
    }
    auto current = count.load();
    if (progress.is_none() || current == reported) return false;
    reported = current;
    try {
      progress(current, total);
    } catch (py::error_already_set&) {
      python_error = std::current_exception();
      return true;
    }
    return false;
  };

  {
    py::gil_scoped_release release;
    auto                   worker = std::thread([&] {
      try {
        arena.execute([&] {
          auto start = std::chrono::steady_clock::now();
          for (auto sample = 0; sample < samples; sample++) {
            if (!render_step(context, state, 1, callbacks)) return;
            count.store(state.samples);
            // The time budget: stop after the step that reaches it.
            auto elapsed = std::chrono::duration<double>(
                std::chrono::steady_clock::now() - start);
            if (state.params.time > 0 && elapsed.count() >= state.params.time)
              return;
          }
        });
      } catch (...) { error = std::current_exception(); }
      {
        auto lock = std::lock_guard<std::mutex>{mutex};
        done      = true;
      }
      finished.notify_all();
    });
    while (true) {
      auto stop = false;
      {
        auto lock = std::unique_lock<std::mutex>{mutex};
        finished.wait_for(lock, poll_interval, [&] { return done; });
        stop = done;
      }
      auto raised = false;
      {
        py::gil_scoped_acquire acquire;
        raised = poll_python();
      }
      if (raised) {
        cancel.store(true);
        break;
      }
      if (stop) break;
    }
    worker.join();
  }
  if (python_error) std::rethrow_exception(python_error);
  if (error) std::rethrow_exception(error);
}

// The context and resolved parameters of a render; the fallbacks (missing
// camera, eyelight without lights) and the checks are the core's.
struct py_render_setup {
  std::shared_ptr<const render_context> context = {};
  trace_params                          params  = {};
  int                                   threads = 0;
};

py_render_setup setup_render(const py_scene& scene, const py::kwargs& kwargs) {
  auto options  = read_render_options(kwargs);
  auto setup    = py_render_setup{};
  setup.threads = options.threads;
  setup.context = context_for(scene, options.params);
  auto warnings = std::vector<std::string>{};
  setup.params =
      resolve_params(*setup.context, options.params, options.camera, warnings);
  warn_all(warnings);
  return setup;
}

// Render a whole image.
py::object render_scene(const std::shared_ptr<py_scene>& scene,
    const py::object& progress, const py::kwargs& kwargs) {
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress: expected a callable or None");
  auto setup = setup_render(*scene, kwargs);
  auto state = render_state{};
  {
    py::gil_scoped_release release;
    state = make_render_state(*setup.context, setup.params);
  }
  render_samples(
      *setup.context, state, setup.params.samples, setup.threads, progress);
  if (setup.params.aovs != 0) return layers_to_dict(state);
  return image_to_array(output_image(state.buffer, state.params));
}

// A progressive render: each step adds samples.
struct py_renderer {
  py_render_setup setup = {};
  render_state    state = {};
  bool busy = false;  // a step is running (read and set with the GIL)
};

std::unique_ptr<py_renderer> make_renderer(
    const std::shared_ptr<py_scene>& scene, const py::kwargs& kwargs) {
  auto renderer   = std::make_unique<py_renderer>();
  renderer->setup = setup_render(*scene, kwargs);
  py::gil_scoped_release release;
  renderer->state =
      make_render_state(*renderer->setup.context, renderer->setup.params);
  return renderer;
}

// Add `count` samples; an interrupted step leaves the image as it was.
void step_renderer(
    py_renderer& renderer, int count, const py::object& progress) {
  if (count < 1 || count > (1 << 20))
    throw py::value_error(
        "step: the sample count must be in [1, 1048576], found " +
        std::to_string(count));
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress: expected a callable or None");
  if (renderer.busy)
    throw std::runtime_error(
        "step: this renderer is already rendering (in another thread)");
  renderer.busy = true;
  auto backup   = renderer.state;
  try {
    render_samples(*renderer.setup.context, renderer.state, count,
        renderer.setup.threads, progress);
  } catch (...) {
    renderer.state = std::move(backup);
    renderer.busy  = false;
    throw;
  }
  renderer.busy = false;
}

// -----------------------------------------------------------------------------
// SDF EXPRESSIONS
// -----------------------------------------------------------------------------

// An SDF compiled by the scene parser: one program in world space (the
// sdfunction's own frame folded in as a transform node), and its tape,
// compiled once on the first evaluation.
struct py_sdf {
  sdf_program                     program = {};
  std::shared_ptr<const sdf_tape> tape    = {};
};

// The SDF's tape (compiled on first use, with the GIL held).
const sdf_tape& sdf_tape_of(py_sdf& sdf) {
  if (!sdf.tape)
    sdf.tape = std::make_shared<const sdf_tape>(make_sdf_tape(sdf.program));
  return *sdf.tape;
}

bool is_identity(const frame3f& f) {
  return f.x == identity_frame.x && f.y == identity_frame.y &&
         f.z == identity_frame.z && f.o == identity_frame.o;
}

// Compile the single sdfunction of a scene given as JSON text (its `.vm`
// files read relative to `filename`).
py_sdf compile_sdf(const std::string& text, const std::string& filename) {
  auto warnings = std::vector<std::string>{};
  // Evaluated at points only: an unbounded surface is fine.
  auto scene = parse_scene(text, filename, warnings, true, false);
  if (scene.sdfunctions.size() != 1)
    throw_io_error(filename, "expected exactly one sdfunction, found " +
                                 std::to_string(scene.sdfunctions.size()));
  auto& function = scene.sdfunctions.front();
  auto  sdf      = py_sdf{};
  sdf.program    = function.program;
  if (!is_identity(function.local_from_world))
    add_transform(
        sdf.program, root_node(sdf.program), function.local_from_world);
  return sdf;
}

// Distances at an (N, 3) array of points, in the points' float type.
template <typename T>
using c_array = py::array_t<T, py::array::c_style | py::array::forcecast>;

// Distances at an (N, 3) C-contiguous array of points.
template <typename T>
py::array_t<T> eval_points(py_sdf& sdf, const c_array<T>& points) {
  auto& tape   = sdf_tape_of(sdf);
  auto  count  = (size_t)points.shape(0);
  auto  result = py::array_t<T>((py::ssize_t)count);
  auto  in     = points.data();
  auto  out    = result.mutable_data();
  {
    py::gil_scoped_release release;
    // Many points per pass over the clauses.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 4096),
        [&](const tbb::blocked_range<size_t>& range) {
          auto block  = std::vector<vec3f>(range.size());
          auto values = std::vector<float>(range.size());
          for (auto i = range.begin(); i < range.end(); i++)
            block[i - range.begin()] = vec3f{
                (float)in[3 * i], (float)in[3 * i + 1], (float)in[3 * i + 2]};
          eval_sdf(tape, block.data(), values.data(), block.size());
          for (auto i = range.begin(); i < range.end(); i++)
            out[i] = (T)values[i - range.begin()];
        });
  }
  return result;
}

// Values and exact gradients (forward-mode derivatives of the tape) at an
// (N, 3) C-contiguous array of points: an (N, 3) array in the points' type.
template <typename T>
py::array_t<T> gradient_points(py_sdf& sdf, const c_array<T>& points) {
  auto& tape   = sdf_tape_of(sdf);
  auto  count  = (size_t)points.shape(0);
  auto  result = py::array_t<T>({(py::ssize_t)count, (py::ssize_t)3});
  auto  in     = points.data();
  auto  out    = result.mutable_data();
  {
    py::gil_scoped_release release;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 4096),
        [&](const tbb::blocked_range<size_t>& range) {
          auto block     = std::vector<vec3f>(range.size());
          auto values    = std::vector<float>(range.size());
          auto gradients = std::vector<vec3f>(range.size());
          for (auto i = range.begin(); i < range.end(); i++)
            block[i - range.begin()] = vec3f{
                (float)in[3 * i], (float)in[3 * i + 1], (float)in[3 * i + 2]};
          eval_sdf_gradients(tape, block.data(), values.data(),
              gradients.data(), block.size());
          for (auto i = range.begin(); i < range.end(); i++) {
            auto g         = gradients[i - range.begin()];
            out[3 * i]     = (T)g.x;
            out[3 * i + 1] = (T)g.y;
            out[3 * i + 2] = (T)g.z;
          }
        });
  }
  return result;
}

// Points of shape (N, 3) as float32 or float64, for `name`.
template <typename Call>
py::array with_points(const py::array& points, const char* name, Call call) {
  if (points.ndim() != 2 || points.shape(1) != 3)
    throw py::value_error(std::string(name) +
                          ": expected points of shape (N, 3), found " +
                          shape_text(points));
  if (py::isinstance<py::array_t<float>>(points))
    return call(c_array<float>::ensure(points));
  auto doubles = c_array<double>::ensure(points);
  if (!doubles)
    throw py::type_error(std::string(name) + ": the points must be numbers");
  return call(doubles);
}

py::array gradient_sdf_array(py_sdf& sdf, const py::array& points) {
  return with_points(points, "gradient",
      [&](const auto& p) -> py::array { return gradient_points(sdf, p); });
}

py::array eval_sdf_array(py_sdf& sdf, const py::array& points) {
  return with_points(points, "eval",
      [&](const auto& p) -> py::array { return eval_points(sdf, p); });
}

// The operator table (sdf_operator_table.h) as a list of dicts: name,
// help, and keys (key, type, range, required, help), for the Python layer's
// checks and documentation.
py::list operator_table() {
  auto ranges = std::vector<std::string>{"any", "positive", "non_negative"};
  auto table  = py::list{};
  for (auto& op : sdf_operators) {
    auto keys = py::list{};
    for (auto& key : op.keys) {
      auto row        = py::dict{};
      row["key"]      = key.key;
      row["type"]     = sdf_key_type_names[(int)key.type];
      row["range"]    = ranges[(int)key.range];
      row["required"] = key.required;
      row["help"]     = key.help;
      keys.append(row);
    }
    auto row    = py::dict{};
    row["name"] = op.name;
    row["help"] = op.help;
    row["keys"] = keys;
    table.append(row);
  }
  return table;
}

// Parse a formula whose other names are `names`, for the Python layer's
// early errors: io_error "column C: ..." or "name: not used ...".
void check_expression(
    const std::string& text, const std::vector<std::string>& names) {
  auto program  = sdf_program{};
  auto operands = std::vector<sdf_expression_operand>{};
  for (auto& name : names) {
    if (!is_expression_operand_name(name))
      throw io_error(name +
                     ": not an operand name (letters, digits and _, not "
                     "first a digit; not x, y, z, pi or a function)");
    operands.push_back({name, add_node(program, sdf_node{})});
  }
  parse_sdf_expression(program, text, operands);
  for (auto& operand : operands)
    if (operand.uses == 0)
      throw io_error(operand.name + ": not used by the expression");
}

py::tuple bounds_tuple(const bbox3f& box) {
  return py::make_tuple(py::make_tuple(box.min.x, box.min.y, box.min.z),
      py::make_tuple(box.max.x, box.max.y, box.max.z));
}

// The bake region: explicit bounds or the SDF's own, padded by `pad` voxels.
bbox3f bake_bounds(
    const py_sdf& sdf, float voxel, int pad, const py::object& bounds) {
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw py::value_error(
        "voxel: must be a finite number > 0, found " + std::to_string(voxel));
  if (pad < 0)
    throw py::value_error("pad: must be >= 0, found " + std::to_string(pad));
  auto box = sdf_bounds(sdf.program);
  if (!bounds.is_none()) {
    auto b = bounds.cast<std::vector<std::vector<float>>>();
    if (b.size() != 2 || b[0].size() != 3 || b[1].size() != 3)
      throw py::value_error(
          "bounds: expected ((xmin, ymin, zmin), (xmax, ymax, zmax))");
    box = {{b[0][0], b[0][1], b[0][2]}, {b[1][0], b[1][1], b[1][2]}};
  } else if (!is_finite(box) || is_empty(box)) {
    throw py::value_error(
        "the SDF is unbounded (a plane?): give bounds=((xmin, ymin, zmin), "
        "(xmax, ymax, zmax))");
  }
  return expand(box, pad * voxel);
}

// Sample the SDF on a grid, as `ysdf bake` does.
grid_data bake_sdf(
    const py_sdf& sdf, float voxel, int pad, const py::object& bounds) {
  auto                   box = bake_bounds(sdf, voxel, pad, bounds);
  py::gil_scoped_release release;
  return bake_grid(sdf.program, identity_frame, box, voxel);
}

// Triangle mesh of the zero set: bake, then OpenVDB volumeToMesh, as
// `ysdf bake` followed by `ysdf to-mesh`.
mesh_data mesh_sdf(
    const py_sdf& sdf, float voxel, int pad, const py::object& bounds) {
  auto                   grid = bake_sdf(sdf, voxel, pad, bounds);
  py::gil_scoped_release release;
  return grid_to_mesh(grid);
}

py::tuple mesh_to_arrays(const mesh_data& mesh) {
  auto vertices =
      py::array_t<float>({(py::ssize_t)mesh.positions.size(), (py::ssize_t)3});
  auto faces =
      py::array_t<int>({(py::ssize_t)mesh.triangles.size(), (py::ssize_t)3});
  if (!mesh.positions.empty())
    std::memcpy(vertices.mutable_data(), mesh.positions.data(),
        mesh.positions.size() * sizeof(vec3f));
  if (!mesh.triangles.empty())
    std::memcpy(faces.mutable_data(), mesh.triangles.data(),
        mesh.triangles.size() * sizeof(vec3i));
  return py::make_tuple(vertices, faces);
}

}  // namespace

// -----------------------------------------------------------------------------
// MODULE
// -----------------------------------------------------------------------------

namespace {

// Scenes, rendering and the progressive renderer.
void bind_scenes(py::module_& m) {
  py::class_<py_scene, std::shared_ptr<py_scene>>(m, "LoadedScene")
      .def_property_readonly(
          "filename", [](const py_scene& s) { return s.filename; })
      .def_property_readonly(
          "warnings", [](const py_scene& s) { return s.warnings; })
      .def_property_readonly("cameras",
          [](const py_scene& s) {
            auto names = std::vector<std::string>{};
            for (auto& camera : s.context->scene.cameras)
              names.push_back(camera.name);
            return names;
          })
      .def_property_readonly("num_sdfunctions",
          [](const py_scene& s) { return s.context->scene.sdfunctions.size(); })
      .def_property_readonly("num_vol_instances",
          [](const py_scene& s) {
            return s.context->scene.vol_instances.size();
          })
      .def_property_readonly("num_materials",
          [](const py_scene& s) { return s.context->scene.materials.size(); });

  m.def("load_scene", &load_scene_file, py::arg("filename"));
  m.def("parse_scene", &parse_scene_text, py::arg("text"), py::arg("filename"));

  m.def("render", &render_scene, py::arg("scene"),
      py::arg("progress") = py::none());
  m.def("default_render_options", &default_render_options);
  m.def("render_option_help", &render_option_help);
  m.attr("shader_names")        = shader_type_names;
  m.attr("material_type_names") = material_type_names;
  // (name, kind) of every material key: "color", "number" or "texture".
  auto keys = py::list{};
  for (auto& key : material_keys) {
    auto kind = key.kind == material_key_kind::color    ? "color"
                : key.kind == material_key_kind::number ? "number"
                                                        : "texture";
    keys.append(py::make_tuple(key.name, kind));
  }
  m.attr("material_keys") = keys;

  py::class_<py_renderer>(m, "Renderer")
      .def(py::init(&make_renderer), py::arg("scene"))
      .def("step", &step_renderer, py::arg("samples") = 1,
          py::arg("progress") = py::none())
      .def_property_readonly(
          "samples", [](const py_renderer& r) { return r.state.samples; })
      .def_property_readonly(
          "width", [](const py_renderer& r) { return r.state.width; })
      .def_property_readonly(
          "height", [](const py_renderer& r) { return r.state.height; })
      .def_property_readonly("shader",
          [](const py_renderer& r) {
            return shader_type_names[(int)r.state.params.shader];
          })
      .def("image", [](const py_renderer& r) {
        if (r.busy)
          throw std::runtime_error(
              "image: the renderer is rendering (in another thread)");
        return image_to_array(get_image(r.state));
      });
}

// Images and files.
void bind_files(py::module_& m) {
  m.def(
      "save_image",
      [](const std::string& filename, const py::array& array, float exposure,
          bool filmic) {
        if (!std::isfinite(exposure))
          throw py::value_error("exposure: must be finite");
        auto                   image = array_to_image(array);
        py::gil_scoped_release release;
        save_image(filename, image, exposure, filmic);
      },
      py::arg("filename"), py::arg("image"), py::arg("exposure") = 0.0f,
      py::arg("filmic") = false);
  m.def(
      "write_file",
      [](const std::string& filename, const py::bytes& data) {
        auto                   bytes = std::string{data};
        py::gil_scoped_release release;
        write_file(filename, bytes);
      },
      py::arg("filename"), py::arg("data"));
  m.def(
      "load_image",
      [](const std::string& filename) {
        auto image = image_data{};
        {
          py::gil_scoped_release release;
          image = load_image(filename);
        }
        return image_to_array(image);
      },
      py::arg("filename"));
}

// Compiled SDFs: evaluation, meshes, grids and .vm files.
void bind_sdfs(py::module_& m) {
  py::class_<py_sdf>(m, "CompiledSDF")
      .def("eval", &eval_sdf_array, py::arg("points"))
      .def("gradient", &gradient_sdf_array, py::arg("points"))
      .def("bounds",
          [](const py_sdf& sdf) {
            return bounds_tuple(sdf_bounds(sdf.program));
          })
      .def(
          "mesh",
          [](const py_sdf& sdf, float voxel, int pad,
              const py::object& bounds) {
            return mesh_to_arrays(mesh_sdf(sdf, voxel, pad, bounds));
          },
          py::arg("voxel"), py::arg("pad"), py::arg("bounds"))
      .def(
          "save_mesh",
          [](const py_sdf& sdf, const std::string& filename, float voxel,
              int pad, const py::object& bounds) {
            auto                   mesh = mesh_sdf(sdf, voxel, pad, bounds);
            py::gil_scoped_release release;
            save_mesh(filename, mesh);
          },
          py::arg("filename"), py::arg("voxel"), py::arg("pad"),
          py::arg("bounds"))
      .def(
          "save_vm",
          [](const py_sdf& sdf, const std::string& filename) {
            save_vm(filename, sdf.program);
          },
          py::arg("filename"))
      .def(
          "save_grid",
          [](const py_sdf& sdf, const std::string& filename, float voxel,
              int pad, const py::object& bounds, bool binary) {
            auto                   grid = bake_sdf(sdf, voxel, pad, bounds);
            py::gil_scoped_release release;
            save_grid(filename, grid, grid_format_from_uri(filename, binary));
          },
          py::arg("filename"), py::arg("voxel"), py::arg("pad"),
          py::arg("bounds"), py::arg("binary"));
  m.def("compile_sdf", &compile_sdf, py::arg("text"), py::arg("filename"));
  m.def("sdf_operators", &operator_table);
  m.def(
      "check_expression", &check_expression, py::arg("text"), py::arg("names"));
  m.def(
      "check_vm",
      [](const std::string& filename) {
        auto program = sdf_program{};
        load_vm(program, filename);
      },
      py::arg("filename"));
  m.attr("sdf_expression_functions") = sdf_expression_functions;
}

}  // namespace

PYBIND11_MODULE(_implicit, m) {
  m.doc() =
      "implicit's renderer, SDF evaluator and file writers (internal; "
      "use the package `implicit`)";
  py::register_exception<io_error>(m, "Error", PyExc_Exception);

  bind_scenes(m);
  bind_files(m);
  bind_sdfs(m);
}
