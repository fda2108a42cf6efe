// # implicit: the table of render options (implementation)

#include "render_options.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// THE TABLE
// -----------------------------------------------------------------------------

// Rows that differ from the defaults of render_option in a few columns.
static render_option make_option(render_option_id id, const char* name,
    render_option_type type, const char* help) {
  auto option = render_option{};
  option.id   = id;
  option.name = name;
  option.type = type;
  option.help = help;
  return option;
}

static render_option integer_option(render_option_id id, const char* name,
    double min, double max, double ui_min, double ui_max, const char* help) {
  auto option   = make_option(id, name, render_option_type::integer, help);
  option.min    = min;
  option.max    = max;
  option.ui_min = ui_min;
  option.ui_max = ui_max;
  return option;
}

static render_option choice_option(render_option_id id, const char* name,
    const std::vector<std::string>& choices, const char* help) {
  auto option    = make_option(id, name, render_option_type::choice, help);
  option.choices = &choices;
  return option;
}

// Built once, on first use (no static initialisation order to rely on).
static std::vector<render_option> make_render_option_table() {
  using id    = render_option_id;
  using type  = render_option_type;
  auto table  = std::vector<render_option>{};
  auto append = [&](render_option option) { table.push_back(option); };
  append(choice_option(id::shader, "shader", shader_type_names,
      "Shader: the path tracer (implicit), normals as colours "
      "(implicit_normal), debug views, or a heat map of sphere-tracing work "
      "(steps)"));
  auto camera   = make_option(id::camera, "camera", type::text,
        "Camera by name (default: default, camera, camera0, camera1, then "
          "the first)");
  camera.viewer = false;  // a combo box of the scene's cameras
  append(camera);
  append(integer_option(id::resolution, "resolution", 1, 16384, 180, 4096,
      "Image size along the longest side"));
  append(integer_option(
      id::samples, "samples", 1, 1 << 20, 16, 4096, "Samples per pixel"));
  append(integer_option(
      id::bounces, "bounces", 1, 1024, 1, 128, "Maximum path length"));
  auto clamp   = make_option(id::clamp, "clamp", type::number,
        "Clamp each sample's radiance to this value");
  clamp.min    = 1e-6;
  clamp.max    = flt_max;
  clamp.ui_min = 1, clamp.ui_max = 10000, clamp.log = true;
  append(clamp);
  auto seed   = make_option(id::seed, "seed", type::seed,
        "Random seed (same seed, same image, whatever the thread count)");
  seed.viewer = false;
  append(seed);
  auto exposure  = make_option(id::exposure, "exposure", type::number,
       "Exposure in stops (.png/.jpg output)");
  exposure.stage = render_option_stage::output;
  exposure.min = -100, exposure.max = 100;
  exposure.ui_min = -5, exposure.ui_max = 5;
  exposure.python = false;  // save_image() takes it
  append(exposure);
  auto filmic   = make_option(id::filmic, "filmic", type::flag,
        "Filmic tone curve, ACES fit (.png/.jpg output)");
  filmic.stage  = render_option_stage::output;
  filmic.python = false;
  append(filmic);
  append(make_option(id::envhidden, "envhidden", type::flag,
      "Hide the environment behind the scene (alpha 0 there)"));
  append(make_option(id::tentfilter, "tentfilter", type::flag,
      "Tent pixel filter instead of box"));
  append(make_option(id::noimplicitmis, "noimplicitmis", type::flag,
      "No light sampling (BSDF sampling only)"));
  append(choice_option(id::mis, "mis", mis_type_names,
      "Light sampling: one (the seed's one-sample MIS) or two (a light and "
      "a BSDF sample per bounce, power heuristic)"));
  append(choice_option(id::sampler, "sampler", sampler_type_names,
      "Random numbers: sobol (scrambled Sobol points, stratified per pixel) "
      "or random (independent PCG32 numbers, as Yocto/GL)"));
  append(
      choice_option(id::lightsampler, "lightsampler", light_sampler_type_names,
          "How a light is picked per sample: bvh (a tree over the emitters' "
          "bounds, power and normals), power, or uniform (the seed's)"));
  append(integer_option(id::stmaxiter, "stmaxiter", 1, 1000000, 1, 4096,
      "Sphere-tracing iteration cap"));
  auto accel   = choice_option(id::accel, "accel", accel_type_names,
        "Intersection: bvh (objects marched in their own boxes) or none (the "
          "seed's minimum over all objects)");
  accel.viewer = false;  // the viewer keeps the accel it was started with
  append(accel);
  auto threads = integer_option(
      id::threads, "threads", 0, 4096, 0, 0, "Worker threads (0: all cores)");
  threads.viewer = false;
  append(threads);
  auto pratio = integer_option(id::pratio, "pratio", 1, 4096, 1, 64,
      "Preview downscale of the viewer (its first, one-sample image)");
  pratio.cli = false, pratio.python = false;
  append(pratio);
  auto aov    = make_option(id::aov, "aov", type::list,
         "Layers to write beside the image: in an .exr as channels "
            "(albedo.R, normal.X, depth.Z, ...), beside other formats as "
            "<output>.<layer>.exr");
  aov.choices = &aov_type_names;
  aov.viewer  = false;  // the viewer shows every layer as a view
  append(aov);
  auto threshold =
      make_option(id::noise_threshold, "noise-threshold", type::number,
          "Adaptive sampling: a pixel stops once the standard error of its "
          "mean relative to the mean (values below 0.1 count as 0.1) is below "
          "this (0.02 is clean, 0.1 a preview; 0: every pixel takes every "
          "sample)");
  threshold.max    = 1000;
  threshold.ui_min = 0, threshold.ui_max = 0.2;
  append(threshold);
  append(integer_option(id::min_samples, "min-samples", 0, 1 << 20, 0, 1024,
      "Adaptive sampling: samples before a pixel may stop (0: the larger of "
      "16 and samples / 16)"));
  auto time   = make_option(id::time, "time", type::number,
        "Time budget in seconds per image: stops after the pass that "
          "reaches it and writes the samples done (0: none)");
  time.max    = 1e9;
  time.viewer = false;
  append(time);
  auto denoise     = make_option(id::denoise, "denoise", type::flag,
          "Denoise the images (and --savebatch images) with their per-pixel "
              "statistics, albedo, normal and depth (image/denoise.h)");
  denoise.refilter = true;
  append(denoise);
  auto denoiser = choice_option(id::denoiser, "denoiser", denoise_method_names,
      "Denoising method: nlm (NL-means, the fastest of the good ones), nfor "
      "(first-order regression: 10-30% lower error at 3x the time) or ttest "
      "(per-pixel t-tests: the cheapest)");
  denoiser.refilter = true;
  append(denoiser);
  return table;
}

const std::vector<render_option>& render_option_table() {
  static const auto table = make_render_option_table();
  return table;
}

const render_option* find_render_option(const std::string& name) {
  for (auto& option : render_option_table())
    if (option.name == name) return &option;
  return nullptr;
}

// -----------------------------------------------------------------------------
// FIELDS
// -----------------------------------------------------------------------------

// A flag stored as its opposite (noimplicitmis is !implicit_mis).
template <typename Bool>
struct negated_flag {
  Bool& value;
};

// Call `visit` with the field that holds option `id` (const or not with
// `settings`): an int, float, bool, uint64_t, std::string, an enum or a
// negated_flag. The one switch over the options.
template <typename Settings, typename Visit>
static auto visit_option(
    Settings& settings, render_option_id id, const Visit& visit) {
  auto& p = settings.params;
  switch (id) {
    case render_option_id::shader: return visit(p.shader);
    case render_option_id::camera: return visit(settings.camera);
    case render_option_id::resolution: return visit(p.resolution);
    case render_option_id::samples: return visit(p.samples);
    case render_option_id::bounces: return visit(p.bounces);
    case render_option_id::clamp: return visit(p.clamp);
    case render_option_id::seed: return visit(p.seed);
    case render_option_id::exposure: return visit(p.exposure);
    case render_option_id::filmic: return visit(p.filmic);
    case render_option_id::envhidden: return visit(p.envhidden);
    case render_option_id::tentfilter: return visit(p.tentfilter);
    case render_option_id::noimplicitmis:
      return visit(
          negated_flag<std::remove_reference_t<decltype((p.implicit_mis))>>{
              p.implicit_mis});
    case render_option_id::mis: return visit(p.mis);
    case render_option_id::sampler: return visit(p.sampler);
    case render_option_id::lightsampler: return visit(p.light_sampler);
    case render_option_id::stmaxiter: return visit(p.march.max_iterations);
    case render_option_id::accel: return visit(p.accel);
    case render_option_id::threads: return visit(settings.threads);
    case render_option_id::pratio: return visit(p.pratio);
    case render_option_id::aov: return visit(p.aovs);
    case render_option_id::noise_threshold: return visit(p.noise_threshold);
    case render_option_id::min_samples: return visit(p.min_samples);
    case render_option_id::time: return visit(p.time);
    case render_option_id::denoise: return visit(p.denoise);
    case render_option_id::denoiser: return visit(p.denoiser);
  }
  return visit(p.samples);  // not reached: -Wswitch lists every id
}

template <typename T>
inline constexpr bool is_negated_flag = false;
template <typename B>
inline constexpr bool is_negated_flag<negated_flag<B>> = true;

// -----------------------------------------------------------------------------
// VALUES
// -----------------------------------------------------------------------------

// Shortest text that reads back as the same float.
static std::string format_float(float value) {
  char buffer[32];
  auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return error == std::errc{} ? std::string(buffer, end) : "?";
}

// A range bound as text (integers without a fraction).
static std::string format_bound(const render_option& option, double value) {
  if (option.type == render_option_type::integer)
    return std::to_string((long long)value);
  return format_float((float)value);
}

static std::string join_choices(
    const std::vector<std::string>& names, const char* separator) {
  auto text = std::string{};
  for (auto& name : names) text += (text.empty() ? "" : separator) + name;
  return text;
}

// The names of the bits set in a list option's value, comma-separated.
static std::string list_names(const render_option& option, int64_t bits) {
  auto text = std::string{};
  for (size_t k = 0; k < option.choices->size(); k++)
    if (bits & (int64_t{1} << k))
      text += (text.empty() ? "" : ",") + (*option.choices)[k];
  return text;
}

std::string get_render_option(
    const render_settings& settings, const render_option& option) {
  return visit_option(settings, option.id, [&](auto&& field) -> std::string {
    using field_type = std::decay_t<decltype(field)>;
    if constexpr (is_negated_flag<field_type>) {
      return field.value ? "false" : "true";
    } else if constexpr (std::is_same_v<field_type, bool>) {
      return field ? "true" : "false";
    } else if constexpr (std::is_enum_v<field_type>) {
      auto index = (size_t)field;
      return option.choices && index < option.choices->size()
                 ? (*option.choices)[index]
                 : std::to_string(index);
    } else if constexpr (std::is_same_v<field_type, std::string>) {
      return field;
    } else if constexpr (std::is_same_v<field_type, float>) {
      return format_float(field);
    } else {
      if (option.type == render_option_type::list)
        return list_names(option, (int64_t)field);
      return std::to_string(field);
    }
  });
}

// "V is out of range [min, max]", or "" when min <= value <= max.
static std::string range_problem(
    const render_option& option, double value, const std::string& text) {
  if (value >= option.min && value <= option.max) return "";
  return text + " is out of range [" + format_bound(option, option.min) + ", " +
         format_bound(option, option.max) + "]";
}

// The value of an integer, number, flag or choice option as a number (a
// choice: the enum's index).
static double option_number(
    const render_settings& settings, const render_option& option) {
  return visit_option(settings, option.id, [&](auto&& field) -> double {
    using field_type = std::decay_t<decltype(field)>;
    if constexpr (is_negated_flag<field_type>) {
      return field.value ? 0 : 1;
    } else if constexpr (std::is_same_v<field_type, std::string>) {
      return 0;
    } else {
      return (double)field;
    }
  });
}

std::string check_render_option(
    const render_settings& settings, const render_option& option) {
  auto value = option_number(settings, option);
  switch (option.type) {
    case render_option_type::integer:
      return range_problem(option, value, get_render_option(settings, option));
    case render_option_type::number:
      if (!std::isfinite(value))
        return "must be a finite number, not " +
               get_render_option(settings, option);
      return range_problem(option, value, get_render_option(settings, option));
    case render_option_type::choice:
      if (value >= 0 && value < (double)option.choices->size()) return "";
      return "unknown value " + get_render_option(settings, option);
    case render_option_type::list:
      if (value >= 0 && value < std::ldexp(1.0, (int)option.choices->size()))
        return "";
      return "unknown values in " + std::to_string((int64_t)value);
    case render_option_type::seed:
    case render_option_type::flag:
    case render_option_type::text: return "";
  }
  return "";
}

// A value parsed from text, before it is stored.
struct parsed_value {
  int64_t     integer = 0;
  uint64_t    seed    = 0;
  float       number  = 0;
  bool        flag    = false;
  int         choice  = 0;
  std::string text    = "";
};

// Parse an integer or a number (a leading '+' is fine, as strtod takes
// it); the problem, or "" when it parsed.
template <typename T>
static std::string parse_number(
    const render_option& option, const std::string& text, T& value) {
  auto begin = text.data(), end = text.data() + text.size();
  if (begin < end && *begin == '+') begin++;
  auto [ptr, error] = std::from_chars(begin, end, value);
  auto what         = std::is_integral_v<T> ? std::string{"an integer"}
                                            : std::string{"a number"};
  if (text.empty()) return "missing value (expected " + what + ")";
  if (error == std::errc::result_out_of_range && ptr == end)
    return text + " is out of range [" + format_bound(option, option.min) +
           ", " + format_bound(option, option.max) + "]";
  if (error != std::errc{} || ptr != end)
    return "\"" + text + "\" is not " + what;
  return "";
}

// Parse `text` for the option; the problem, or "" when it is valid.
static std::string parse_value(
    const render_option& option, const std::string& text, parsed_value& value) {
  switch (option.type) {
    case render_option_type::integer: {
      auto problem = parse_number(option, text, value.integer);
      if (!problem.empty()) return problem;
      return range_problem(option, (double)value.integer, text);
    }
    case render_option_type::seed: {
      if (!text.empty() && text[0] == '-')
        return text + " is out of range [0, 18446744073709551615]";
      auto problem = parse_number(option, text, value.seed);
      if (problem.find("out of range") != std::string::npos)
        return text + " is out of range [0, 18446744073709551615]";
      return problem;
    }
    case render_option_type::number: {
      auto problem = parse_number(option, text, value.number);
      if (!problem.empty()) return problem;
      if (!std::isfinite(value.number))
        return "must be a finite number, not " + text;
      return range_problem(option, value.number, text);
    }
    case render_option_type::flag: {
      if (text != "true" && text != "false")
        return "\"" + text + "\" is not true or false";
      value.flag = text == "true";
      return "";
    }
    case render_option_type::choice: {
      auto& names = *option.choices;
      for (auto i = 0; i < (int)names.size(); i++) {
        if (names[i] != text) continue;
        value.choice = i;
        return "";
      }
      return "unknown value \"" + text +
             "\" (valid: " + join_choices(names, ", ") + ")";
    }
    case render_option_type::text: value.text = text; return "";
    case render_option_type::list: {
      auto& names = *option.choices;
      for (size_t start = 0; start < text.size();) {
        auto end  = std::min(text.find(',', start), text.size());
        auto name = text.substr(start, end - start);
        auto k    = std::find(names.begin(), names.end(), name) - names.begin();
        if (k == (int64_t)names.size())
          return "unknown value \"" + name + "\" (valid: any of " +
                 join_choices(names, ", ") + ")";
        value.integer |= int64_t{1} << k;
        start = end + 1;
      }
      return "";
    }
  }
  return "";
}

void set_render_option(render_settings& settings, const render_option& option,
    const std::string& text) {
  auto value   = parsed_value{};
  auto problem = parse_value(option, text, value);
  if (!problem.empty()) throw io_error(option.name + ": " + problem);
  visit_option(settings, option.id, [&](auto&& field) {
    using field_type = std::decay_t<decltype(field)>;
    if constexpr (is_negated_flag<field_type>) {
      field.value = !value.flag;
    } else if constexpr (std::is_same_v<field_type, bool>) {
      field = value.flag;
    } else if constexpr (std::is_enum_v<field_type>) {
      field = (field_type)value.choice;
    } else if constexpr (std::is_same_v<field_type, std::string>) {
      field = value.text;
    } else if constexpr (std::is_same_v<field_type, float>) {
      field = value.number;
    } else if constexpr (std::is_same_v<field_type, uint64_t>) {
      field = value.seed;
    } else {
      field = (int)value.integer;
    }
  });
}

std::string render_option_domain(const render_option& option) {
  switch (option.type) {
    case render_option_type::integer:
    case render_option_type::number:
      return format_bound(option, option.min) + ".." +
             format_bound(option, option.max);
    case render_option_type::seed: return "0..18446744073709551615";
    case render_option_type::flag: return "true|false";
    case render_option_type::choice: return join_choices(*option.choices, "|");
    case render_option_type::list: return join_choices(*option.choices, ",");
    case render_option_type::text: return "";
  }
  return "";
}

}  // namespace implicit
