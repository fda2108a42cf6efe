// Tests for the scene format's operators and expressions: each domain
// operator's node and fields, expressions (infix, `.vm` files, named
// operands, bounds), displacement, the operator table walked row by row, and
// one check per error message, with its file, element, key and place.

#include <doctest/doctest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../sdf/sdf_expression_test.h"
#include "../sdf/sdf_operator_table.h"
#include "../util/error.h"
#include "scene_io.h"

using namespace implicit;

namespace {

// A scene of one material and the given sdfunctions (JSON text).
std::string scene_with(const std::string& sdfunctions) {
  return R"({"asset": {"version": "4.2"}, "materials": [{"name": "m"}],
             "sdfunctions": [)" +
         sdfunctions + "]}";
}

scene_data parse_with(const std::string& sdfunctions, bool load_files = false,
    const std::string& filename = "scene.json") {
  auto warnings = std::vector<std::string>{};
  return parse_scene(scene_with(sdfunctions), filename, warnings, load_files);
}

// The program of a scene's one sdfunction.
sdf_program program_of(const std::string& sdfunction) {
  auto scene = parse_with(sdfunction);
  REQUIRE(scene.sdfunctions.size() == 1);
  return scene.sdfunctions[0].program;
}

std::string error_of(const std::string& sdfunctions, bool load_files = false,
    const std::string& filename = "scene.json") {
  try {
    parse_with(sdfunctions, load_files, filename);
  } catch (const io_error& error) {
    return error.what();
  } catch (const std::exception& error) {
    return std::string{"not an io_error: "} + error.what();
  }
  return "no error";
}

bool starts_with(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

// An sdfunction of the given type and keys around a unit sphere operand.
std::string warp(const std::string& type, const std::string& keys) {
  return R"({"name": "w", "material": 0, "type": ")" + type +
         R"(", "operand": {"type": "sphere", "radius": 1}, )" + keys + "}";
}

// A temporary folder for scene and .vm files, removed at the end.
struct temporary_folder {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("implicit_scene_sdf_" + std::to_string((long long)::getpid()));
  temporary_folder() { std::filesystem::create_directories(path / "models"); }
  ~temporary_folder() { std::filesystem::remove_all(path); }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
  }
};

}  // namespace

TEST_CASE("scene_io_sdf: domain operators") {
  auto twist = program_of(warp("twist", R"js("k": 2.5)js"));
  REQUIRE(twist.nodes.size() == 2);
  CHECK(twist.nodes[1].type == sdf_type::op_twist);
  CHECK(twist.nodes[1].value == 2.5f);
  CHECK(twist.nodes[1].left == 0);
  auto bend = program_of(warp("bend", R"js("k": -0.5)js"));
  CHECK(bend.nodes[1].type == sdf_type::op_bend);
  CHECK(bend.nodes[1].value == -0.5f);
  auto endless = program_of(warp("repeat", R"js("spacing": [2, 0, 3])js"));
  CHECK(endless.nodes[1].type == sdf_type::op_repeat);
  CHECK(endless.nodes[1].size == vec3f{2, 0, 3});
  CHECK(endless.nodes[1].count == vec3i{-1, -1, -1});
  auto limited = program_of(
      warp("repeat", R"js("spacing": [2, 1, 3], "limit": [1, 0, 4])js"));
  CHECK(limited.nodes[1].count == vec3i{1, 0, 4});
  auto elongate = program_of(warp("elongate", R"js("h": [0.5, 0, 1])js"));
  CHECK(elongate.nodes[1].type == sdf_type::op_elongate);
  CHECK(elongate.nodes[1].size == vec3f{0.5f, 0, 1});
  auto mirror = program_of(warp("mirror", R"js("axes": "zx")js"));
  CHECK(mirror.nodes[1].type == sdf_type::op_mirror);
  CHECK(mirror.nodes[1].axes == 5);
  CHECK(program_of(warp("mirror", R"js("axes": "y")js")).nodes[1].axes == 2);
  // A nested operator's frame wraps it in a transform, as for any operand.
  auto nested = program_of(R"js({"type": "union", "material": 0, "operands": [
      {"type": "sphere", "radius": 1},
      {"type": "twist", "k": 1, "frame": [1,0,0, 0,1,0, 0,0,1, 1,2,3],
       "operand": {"type": "box", "whd": [1, 1, 1]}}]})js");
  REQUIRE(nested.nodes.size() == 5);
  CHECK(nested.nodes[2].type == sdf_type::op_twist);
  CHECK(nested.nodes[3].type == sdf_type::op_transform);
  CHECK(nested.nodes[4].type == sdf_type::op_union);
}

TEST_CASE("scene_io_sdf: expressions and displacement") {
  // An infix expression: math clauses in the object's local space.
  auto gyroid = program_of(R"js({"name": "g", "type": "expression",
      "material": 0, "expression": "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"})js");
  for (auto p : {vec3f{0.1f, 0.2f, 0.3f}, vec3f{-1, 2, 0.5f}})
    CHECK(eval_reference(gyroid, p) ==
          doctest::Approx(std::sin(p.x) * std::cos(p.y) +
                          std::sin(p.y) * std::cos(p.z) +
                          std::sin(p.z) * std::cos(p.x))
              .epsilon(1e-6));
  // Named operands: a shape used twice is one node.
  auto displaced = program_of(R"js({"type": "expression", "material": 0,
      "expression": "s + 0.05*sin(20*x) - 0.01*s",
      "operands": {"s": {"type": "sphere", "radius": 1}}})js");
  auto spheres = 0, users = 0;
  for (auto& node : displaced.nodes) {
    spheres += node.type == sdf_type::sphere;
    users += node.left == 0;
    users += node.right == 0;
  }
  CHECK(spheres == 1);
  CHECK(users == 2);
  // Operands keep their own frames and may be any object.
  auto moved = program_of(R"js({"type": "expression", "material": 0,
      "expression": "min(a, b)", "operands": {
        "a": {"type": "sphere", "radius": 1},
        "b": {"type": "repeat", "spacing": [1, 1, 1],
              "world_from_local": [1,0,0, 0,1,0, 0,0,1, 5,0,0],
              "operand": {"type": "sphere", "radius": 0.2}}}})js");
  CHECK(moved.nodes.back().type == sdf_type::math_min);
  // bounds: the function's inside intersected with a box from min to max.
  auto clipped = program_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "bounds": [[-1, -2, -3], [1, 2, 3]]})js");
  REQUIRE(clipped.nodes.size() == 4);
  CHECK(clipped.nodes[0].type == sdf_type::math_x);
  CHECK(clipped.nodes[1].type == sdf_type::box);
  CHECK(clipped.nodes[1].size == vec3f{2, 4, 6});
  CHECK(clipped.nodes[2].type == sdf_type::op_transform);
  CHECK(clipped.frames[0].o == vec3f{1, 2, 3});
  CHECK(clipped.nodes[3].type == sdf_type::op_intersection);
  CHECK(clipped.nodes[3].left == 0);
  CHECK(clipped.nodes[3].right == 2);
  // displace: the operand plus a formula in its space.
  auto bumps =
      program_of(warp("displace", R"js("expression": "0.1*sin(9*x)")js"));
  CHECK(bumps.nodes.back().type == sdf_type::math_add);
  CHECK(bumps.nodes.back().left == 0);
  CHECK(bumps.nodes[bumps.nodes.back().right].type == sdf_type::math_mul);
  // An expression nests like any operand (round, smooth unions).
  auto rounded = program_of(R"js({"type": "smooth_union", "blend": 0.1,
      "material": 0, "operands": [{"type": "round", "radius": 0.1,
        "operand": {"type": "expression", "expression": "x*x + y*y - 1"}},
      {"type": "sphere", "radius": 1}]})js");
  CHECK(rounded.nodes.back().type == sdf_type::op_smooth_union);
}

TEST_CASE("scene_io_sdf: .vm files") {
  auto folder = temporary_folder{};
  folder.write("models/ball.vm",
      "# a sphere\n_x var-x\n_y var-y\n_z var-z\n_a square _x\n_b square "
      "_y\n_c square _z\n_s add _a _b\n_t add _s _c\n_r sqrt _t\n_1 const "
      "1\n_d sub _r _1\n");
  folder.write("models/bad.vm", "_x var-x\n_y var-y\n_z foo _x\n");
  auto scene_file = (folder.path / "scene.json").string();
  auto ball       = R"js({"name": "ball", "type": "expression", "material": 0,
      "uri": "models/ball.vm"})js";
  auto scene      = parse_with(ball, true, scene_file);
  REQUIRE(scene.sdfunctions.size() == 1);
  auto& sdf = scene.sdfunctions[0];
  CHECK(sdf.uris == std::vector<std::string>{"models/ball.vm"});
  CHECK(
      eval_reference(sdf.program, {0.3f, 0.4f, 1.2f}) == doctest::Approx(0.3));
  // The infix and .vm forms give the same clauses.
  auto infix = program_of(R"js({"type": "expression", "material": 0,
      "expression": "sqrt(x^2 + y^2 + z^2) - 1"})js");
  for (auto p : {vec3f{0.3f, 0.4f, 1.2f}, vec3f{-2, 0.5f, 0.25f}})
    CHECK(eval_reference(sdf.program, p) == eval_reference(infix, p));
  // Without load_files the file is not read: a stand-in constant.
  auto unread = parse_with(ball, false, scene_file);
  CHECK(unread.sdfunctions[0].program.nodes.size() == 1);
  CHECK(
      unread.sdfunctions[0].uris == std::vector<std::string>{"models/ball.vm"});
  // Errors of the file come with the element and key that named it.
  CHECK(error_of(R"js({"name": "m", "type": "expression", "material": 0,
      "uri": "models/bad.vm"})js",
            true, scene_file) == scene_file + ": sdfunctions[0] (\"m\").uri: " +
                                     (folder.path / "models/bad.vm").string() +
                                     ":3: unknown opcode \"foo\"");
  auto missing = error_of(R"js({"name": "m", "type": "expression",
      "material": 0, "uri": "models/none.vm"})js",
      true, scene_file);
  CHECK(starts_with(missing, scene_file + ": sdfunctions[0] (\"m\").uri: " +
                                 (folder.path / "models/none.vm").string() +
                                 ": cannot open"));
}

TEST_CASE("scene_io_sdf: errors name the element, key and place") {
  // The issue's example: the column inside the expression string.
  CHECK(
      error_of(R"js({"name": "a", "type": "sphere", "radius": 1, "material": 0},
      {"name": "b", "type": "sphere", "radius": 1, "material": 0},
      {"name": "c", "type": "sphere", "radius": 1, "material": 0},
      {"name": "gyroid", "type": "expression", "material": 0,
       "expression": "max(sin(x), (y*2"})js") ==
      "scene.json: sdfunctions[3] (\"gyroid\").expression: column 17: "
      "expected ')'");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x + foo(y)"})js") ==
        "scene.json: sdfunctions[0].expression: column 5: unknown function "
        "\"foo\" (functions: sqrt, abs, sin, cos, tan, asin, acos, atan, "
        "atan2, exp, log, min, max, floor, ceil, round, mod, clamp, mix, "
        "square)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x + s", "operands": {"t": {"type": "plane"}}})js") ==
        "scene.json: sdfunctions[0].expression: column 5: unknown variable "
        "\"s\" (variables: x, y, z, pi, t)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "operands": {"t": {"type": "plane"}}})js") ==
        "scene.json: sdfunctions[0].operands.t: not used by the expression");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "operands": {"sin": {"type": "plane"}}})js") ==
        "scene.json: sdfunctions[0].operands.sin: not an operand name "
        "(letters, digits and _, not first a digit; not x, y, z, pi or a "
        "function)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "operands": [{"type": "plane"}]})js") ==
        "scene.json: sdfunctions[0].operands: expected an object, found an "
        "array");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "s", "operands": {"s": {"type": "sphere"}}})js") ==
        "scene.json: sdfunctions[0].operands.s.radius: missing required "
        "parameter");
  CHECK(error_of(R"js({"type": "expression", "material": 0})js") ==
        "scene.json: sdfunctions[0].expression: missing required parameter "
        "(or give uri, a .vm file)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "uri": "a.vm"})js") ==
        "scene.json: sdfunctions[0].uri: conflicts with expression (give one "
        "of the two)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "uri": "a.vm", "operands": {"s": {"type": "plane"}}})js") ==
        "scene.json: sdfunctions[0].operands: only an infix expression names "
        "operands (a .vm file has none)");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": ""})js") ==
        "scene.json: sdfunctions[0].expression: must not be empty");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": 3})js") ==
        "scene.json: sdfunctions[0].expression: expected a string, found a "
        "number");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "bounds": [[0, 0, 0], [1, 0, 1]]})js") ==
        "scene.json: sdfunctions[0].bounds: each minimum must be below its "
        "maximum, found [0, 0, 0] and [1, 0, 1]");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "bounds": [0, 0, 0]})js") ==
        "scene.json: sdfunctions[0].bounds: expected [[x0, y0, z0], [x1, y1, "
        "z1]], found 3 values");
  CHECK(error_of(R"js({"type": "expression", "material": 0,
      "expression": "x", "bounds": [[0, 0], [1, 1, 1]]})js") ==
        "scene.json: sdfunctions[0].bounds[0]: expected an array of 3 "
        "numbers, found 2 values");
  CHECK(error_of(warp("displace", R"js("expression": "sin(")js")) ==
        "scene.json: sdfunctions[0] (\"w\").expression: column 5: expected "
        "a number, a variable, a function or '(', found the end");
  CHECK(error_of(warp("twist", R"js("k": "fast")js")) ==
        "scene.json: sdfunctions[0] (\"w\").k: expected a number, found a "
        "string");
  CHECK(error_of(warp("repeat", R"js("spacing": [0, 0, 0])js")) ==
        "scene.json: sdfunctions[0] (\"w\").spacing: must be > 0 on at least "
        "one axis (0: no repetition along it)");
  CHECK(error_of(warp("repeat", R"js("spacing": [1, -1, 0])js")) ==
        "scene.json: sdfunctions[0] (\"w\").spacing: must be >= 0 in every "
        "component, found (1, -1, 0)");
  CHECK(error_of(warp(
            "repeat", R"js("spacing": [1, 1, 1], "limit": [1, -2, 0])js")) ==
        "scene.json: sdfunctions[0] (\"w\").limit[1]: must be >= 0, found -2");
  CHECK(error_of(warp(
            "repeat", R"js("spacing": [1, 1, 1], "limit": [1, 2.5, 0])js")) ==
        "scene.json: sdfunctions[0] (\"w\").limit[1]: expected an integer, "
        "found 2.5");
  CHECK(error_of(warp("repeat", R"js("spacing": [1, 1, 1], "limit": 3)js")) ==
        "scene.json: sdfunctions[0] (\"w\").limit: expected an array of 3 "
        "integers, found a number");
  CHECK(error_of(warp("elongate", R"js("h": [1, 1])js")) ==
        "scene.json: sdfunctions[0] (\"w\").h: expected an array of 3 "
        "numbers, found 2 values");
  CHECK(error_of(warp("mirror", R"js("axes": "xw")js")) ==
        "scene.json: sdfunctions[0] (\"w\").axes: expected letters among x, "
        "y, z (e.g. \"xz\"), found \"xw\"");
  CHECK(error_of(warp("mirror", R"js("axes": "xx")js")) ==
        "scene.json: sdfunctions[0] (\"w\").axes: \"x\" is given twice in "
        "\"xx\"");
  CHECK(error_of(warp("mirror", R"js("axes": "")js")) ==
        "scene.json: sdfunctions[0] (\"w\").axes: must name at least one axis "
        "(e.g. \"x\")");
  CHECK(error_of(warp("twist", R"js("k": 1, "h": [1, 1, 1])js")) ==
        "scene.json: sdfunctions[0] (\"w\").h: unknown key for type "
        "\"twist\" (valid keys: name, type, material, frame, "
        "world_from_local, operand, k)");
  // Math clauses are no JSON types; "round" is the CSG rounding.
  auto add = error_of(R"js({"type": "add", "material": 0})js");
  CHECK(starts_with(add,
      "scene.json: sdfunctions[0].type: unknown type \"add\" (valid types: "
      "box, bbox, sphere,"));
  CHECK(add.find("round, onion, transform, twist, bend, repeat, elongate, "
                 "mirror, expression, displace)") != std::string::npos);
  CHECK(add.find("var-x") == std::string::npos);
  CHECK(error_of(R"js({"type": "round", "material": 0, "radius": 1})js") ==
        "scene.json: sdfunctions[0].operand: missing required parameter");
}

// Walks the operator table: each operator loads by its JSON name, and each
// required key, when missing, is reported by name.
TEST_CASE("scene_io_sdf: operator table, every operator and key") {
  auto sphere = nlohmann::json{{"type", "sphere"}, {"radius", 1}};
  for (auto& op : sdf_operators) {
    CAPTURE(op.name);
    auto js        = nlohmann::json::object();
    js["type"]     = op.name;
    js["material"] = 0;
    for (auto& key : op.keys) {
      auto value = nlohmann::json{};
      switch (key.type) {
        case sdf_key_type::operand: value = sphere; break;
        case sdf_key_type::operand_list: value = {sphere, sphere}; break;
        case sdf_key_type::operand_map: value = {{"s", sphere}}; break;
        case sdf_key_type::number: value = 0.5; break;
        case sdf_key_type::vec3: value = {0.5, 1, 0}; break;
        case sdf_key_type::counts: value = {1, 2, 3}; break;
        case sdf_key_type::axes: value = "xy"; break;
        case sdf_key_type::expression: value = "x + 1"; break;
        case sdf_key_type::uri: continue;  // expression is given
        case sdf_key_type::box: value = {{-1, -1, -1}, {1, 1, 1}}; break;
      }
      js[key.key] = value;
    }
    if (op.build == sdf_operator_build::expression) js["expression"] = "s + x";
    if (op.build == sdf_operator_build::transform)
      js["frame"] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 2, 3};
    auto program = program_of(js.dump());
    auto type    = program.nodes.back().type;
    switch (op.build) {
      case sdf_operator_build::fold:
      case sdf_operator_build::unary: CHECK(type == op.type); break;
      case sdf_operator_build::transform:
        CHECK(type == sdf_type::sphere);
        break;
      case sdf_operator_build::expression:
        CHECK(type == sdf_type::op_intersection);
        break;
      case sdf_operator_build::displace:
        CHECK(type == sdf_type::math_add);
        break;
    }
    for (auto& key : op.keys) {
      if (!key.required) continue;
      auto missing = js;
      missing.erase(key.key);
      CHECK(error_of(missing.dump()) == "scene.json: sdfunctions[0]." +
                                            std::string{key.key} +
                                            ": missing required parameter");
    }
    CHECK(!op.help[0] == false);
    for (auto& key : op.keys) CHECK(!key.help[0] == false);
  }
}
