// Tests of the render option table: its rows, values written and read back,
// the checks behind every front end, and validate_params() reading it.

#include "render_options.h"

#include <doctest/doctest.h>

#include <set>

#include "../util/error.h"
#include "render.h"

using namespace implicit;

// The message set_render_option() throws, or "" when it set the value.
static std::string set_error(render_settings& settings, const std::string& name,
    const std::string& value) {
  auto option = find_render_option(name);
  REQUIRE(option != nullptr);
  try {
    set_render_option(settings, *option, value);
  } catch (const io_error& error) { return error.what(); }
  return "";
}

// The message validate_params() throws, or "".
static std::string validate_error(const trace_params& params) {
  try {
    validate_params(params);
  } catch (const io_error& error) { return error.what(); }
  return "";
}

TEST_CASE("render options: one row per option, in the order of the ids") {
  auto& table = render_option_table();
  auto  names = std::set<std::string>{};
  for (auto i = 0; i < (int)table.size(); i++) {
    auto& option = table[i];
    INFO(option.name);
    CHECK((int)option.id == i);
    CHECK(names.insert(option.name).second);
    CHECK(find_render_option(option.name) == &option);
    CHECK(!option.help.empty());
    if (option.type == render_option_type::choice) {
      REQUIRE(option.choices != nullptr);
      CHECK(!option.choices->empty());
    }
    auto ranged = option.type == render_option_type::integer ||
                  option.type == render_option_type::number;
    if (ranged) CHECK(option.min < option.max);
    // A viewer slider stays inside what the renderer accepts.
    if (ranged && option.viewer) {
      CHECK(option.min <= option.ui_min);
      CHECK(option.ui_min < option.ui_max);
      CHECK(option.ui_max <= option.max);
    }
  }
  CHECK(find_render_option("spp") == nullptr);
  // The enums' name tables are the choices, not copies of them.
  CHECK(find_render_option("shader")->choices == &shader_type_names);
  CHECK(find_render_option("accel")->choices == &accel_type_names);
  CHECK(find_render_option("mis")->choices == &mis_type_names);
  CHECK(find_render_option("sampler")->choices == &sampler_type_names);
}

TEST_CASE("render options: the defaults are trace_params' and read back") {
  auto defaults = render_settings{};
  auto value    = [&](const char* name) {
    return get_render_option(defaults, *find_render_option(name));
  };
  CHECK(value("shader") == "implicit");
  CHECK(value("camera") == "");
  CHECK(value("resolution") == "720");
  CHECK(value("samples") == "512");
  CHECK(value("clamp") == "10");
  CHECK(value("seed") == "961748941");
  CHECK(value("noimplicitmis") == "false");
  CHECK(value("mis") == "two");
  CHECK(value("stmaxiter") == "450");
  CHECK(value("pratio") == "8");
  // Every value, written and parsed back, changes nothing.
  for (auto& option : render_option_table()) {
    auto settings = render_settings{};
    CHECK(set_error(settings, option.name, get_render_option(settings, option))
              .empty());
    CHECK(get_render_option(settings, option) ==
          get_render_option(defaults, option));
    CHECK(check_render_option(settings, option).empty());
  }
}

TEST_CASE("render options: values are parsed and checked by the table") {
  auto settings = render_settings{};
  CHECK(set_error(settings, "samples", "64").empty());
  CHECK(settings.params.samples == 64);
  CHECK(set_error(settings, "samples", "+65").empty());
  CHECK(settings.params.samples == 65);
  CHECK(set_error(settings, "clamp", "0.25").empty());
  CHECK(settings.params.clamp == 0.25f);
  CHECK(set_error(settings, "noimplicitmis", "true").empty());
  CHECK(!settings.params.implicit_mis);
  CHECK(set_error(settings, "shader", "eyelight").empty());
  CHECK(settings.params.shader == shader_type::eyelight);
  CHECK(set_error(settings, "seed", "18446744073709551615").empty());
  CHECK(settings.params.seed == 18446744073709551615ull);
  CHECK(set_error(settings, "camera", "front").empty());
  CHECK(settings.camera == "front");
  CHECK(set_error(settings, "stmaxiter", "1000").empty());
  CHECK(settings.params.march.max_iterations == 1000);

  // Each failure names the option and leaves the value as it was.
  auto before = settings;
  CHECK(set_error(settings, "samples", "0") ==
        "samples: 0 is out of range [1, 1048576]");
  CHECK(set_error(settings, "samples", "abc") ==
        "samples: \"abc\" is not an integer");
  CHECK(set_error(settings, "samples", "1e3") ==
        "samples: \"1e3\" is not an integer");
  CHECK(set_error(settings, "samples", "4294967297") ==
        "samples: 4294967297 is out of range [1, 1048576]");
  CHECK(set_error(settings, "samples", "99999999999999999999999") ==
        "samples: 99999999999999999999999 is out of range [1, 1048576]");
  CHECK(set_error(settings, "samples", "") ==
        "samples: missing value (expected an integer)");
  CHECK(set_error(settings, "clamp", "nan") ==
        "clamp: must be a finite number, not nan");
  CHECK(set_error(settings, "clamp", "-inf") ==
        "clamp: must be a finite number, not -inf");
  CHECK(set_error(settings, "clamp", "1e39").find("out of range") !=
        std::string::npos);
  CHECK(set_error(settings, "exposure", "101") ==
        "exposure: 101 is out of range [-100, 100]");
  CHECK(set_error(settings, "seed", "-1") ==
        "seed: -1 is out of range [0, 18446744073709551615]");
  CHECK(set_error(settings, "seed", "18446744073709551616") ==
        "seed: 18446744073709551616 is out of range [0, "
        "18446744073709551615]");
  CHECK(set_error(settings, "filmic", "3") ==
        "filmic: \"3\" is not true or false");
  CHECK(set_error(settings, "mis", "three") ==
        "mis: unknown value \"three\" (valid: one, two)");
  CHECK(set_error(settings, "shader", "nope")
            .find("valid: implicit, implicit_normal, eyelight") !=
        std::string::npos);
  CHECK(set_error(settings, "threads", "-1") ==
        "threads: -1 is out of range [0, 4096]");
  for (auto& option : render_option_table())
    CHECK(get_render_option(settings, option) ==
          get_render_option(before, option));
}

TEST_CASE("render options: validate_params checks the table's ranges") {
  CHECK(validate_error(trace_params{}).empty());
  auto bad = [](auto change) {
    auto params = trace_params{};
    change(params);
    return validate_error(params);
  };
  CHECK(bad([](trace_params& p) { p.samples = 0; }) ==
        "render parameter samples: 0 is out of range [1, 1048576]");
  CHECK(bad([](trace_params& p) { p.resolution = 16385; }) ==
        "render parameter resolution: 16385 is out of range [1, 16384]");
  CHECK(bad([](trace_params& p) { p.march.max_iterations = -2; }) ==
        "render parameter stmaxiter: -2 is out of range [1, 1000000]");
  CHECK(bad([](trace_params& p) { p.pratio = 0; }) ==
        "render parameter pratio: 0 is out of range [1, 4096]");
  CHECK(bad([](trace_params& p) { p.clamp = 0; }) ==
        "render parameter clamp: 0 is out of range [1e-06, 3.4028235e+38]");
  CHECK(bad([](trace_params& p) { p.exposure = -flt_max * 2; }) ==
        "render parameter exposure: must be a finite number, not -inf");
  CHECK(bad([](trace_params& p) { p.shader = (shader_type)99; }) ==
        "render parameter shader: unknown value 99");
  CHECK(bad([](trace_params& p) {
    p.sampler = (sampler_type)-1;
  }).find("render parameter sampler: unknown value") == 0);
  // Every integer option's bounds are accepted, one past them refused.
  for (auto& option : render_option_table()) {
    if (option.type != render_option_type::integer) continue;
    INFO(option.name);
    auto settings = render_settings{};
    for (auto bound : {option.min, option.max}) {
      set_render_option(settings, option, std::to_string((long long)bound));
      CHECK(check_render_option(settings, option).empty());
    }
    CHECK(set_error(
              settings, option.name, std::to_string((long long)option.max + 1))
              .find("out of range") != std::string::npos);
  }
}

TEST_CASE("render options: help texts show ranges and choices") {
  CHECK(render_option_domain(*find_render_option("samples")) == "1..1048576");
  CHECK(render_option_domain(*find_render_option("mis")) == "one|two");
  CHECK(render_option_domain(*find_render_option("filmic")) == "true|false");
  CHECK(render_option_domain(*find_render_option("camera")) == "");
}
