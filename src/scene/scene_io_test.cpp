// Tests for the scene loader: exact data for every key, the seed's frame
// convention, CSG trees, and one check per kind of bad input that the message
// names the file, the array, the element and the key.

#include "scene_io.h"

#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../../tests/shared_data.h"
#include "../image/image_io.h"
#include "../sdf/sdf_grid_io.h"
#include "../sdf/sdf_primitives.h"
#include "../sdf/sdf_tape.h"
#include "../util/error.h"

using namespace implicit;

namespace {

// A valid scene with one of everything; tests change one key at a time.
const char* base_scene_text = R"({
  "asset": {"version": "4.2", "copyright": "test scene", "generator": "hand"},
  "cameras": [
    {"name": "cam", "frame": [1,0,0, 0,1,0, 0,0,1, 0,0.5,3],
     "orthographic": true, "lens": 0.035, "film": 0.024, "aspect": 2,
     "focus": 3, "aperture": 0.01},
    {"name": "plain"}
  ],
  "textures": [{"name": "sky", "uri": "textures/sky.hdr"}],
  "materials": [
    {"name": "floor", "color": [0.7, 0.7, 0.7], "color_tex": 0},
    {"name": "light", "emission": [20, 20, 20]},
    {"name": "all", "type": "gltfpbr", "emission": [1, 2, 3],
     "color": [0.1, 0.2, 0.3], "metallic": 0.25, "roughness": 0.5,
     "ior": 1.33, "trdepth": 0.2, "scattering": [0.4, 0.5, 0.6],
     "scanisotropy": -0.3, "opacity": 0.75, "emission_tex": 0,
     "color_tex": 0, "roughness_tex": 0, "scattering_tex": 0,
     "normal_tex": 0}
  ],
  "environments": [
    {"name": "sky", "frame": [0,0,1, 0,1,0, -1,0,0, 0,0,0],
     "emission": [0.5, 0.5, 0.5], "emission_tex": 0}
  ],
  "volumes": [
    {"name": "sackboy", "uri": "sdfs/sackboy.sdf", "binary": false},
    {"name": "cloud", "uri": "grids/cloud.vdb"}
  ],
  "vol_instances": [
    {"name": "inst", "volume": 1, "material": 2, "scale": 0.5,
     "frame": [1,0,0, 0,1,0, 0,0,1, -0.2,0,0]},
    {"name": "defaults", "volume": 0, "material": 0}
  ],
  "sdfunctions": [
    {"name": "floor", "type": "box", "whd": [2, 0.00001, 2], "material": 0,
     "frame": [1,0,0, 0,1,0, 0,0,1, 1,0,1]},
    {"name": "frame1", "type": "bbox", "whd": [0.3, 0.2, 0.1],
     "thickness": 0.02, "material": 0},
    {"name": "ball", "type": "sphere", "radius": 0.25, "material": 1},
    {"name": "torus1", "type": "torus", "r1": 0.05, "r2": 0.022,
     "material": 2},
    {"name": "cone", "type": "capped_cone", "height": 0.1, "r1": 0.1,
     "r2": 0.02, "material": 2},
    {"name": "ground", "type": "plane", "material": 0},
    {"name": "pill", "type": "capsule", "height": 0.3, "radius": 0.1,
     "material": 0},
    {"name": "can", "type": "cylinder", "height": 0.2, "radius": 0.15,
     "material": 0},
    {"name": "rbox", "type": "rounded_box", "whd": [0.3, 0.2, 0.1],
     "radius": 0.05, "material": 0},
    {"name": "egg", "type": "ellipsoid", "radii": [0.3, 0.2, 0.1],
     "material": 0},
    {"name": "gem", "type": "octahedron", "radius": 0.4, "material": 0},
    {"name": "blob", "type": "smooth_union", "blend": 0.1, "material": 1,
     "operands": [
       {"type": "sphere", "radius": 0.5},
       {"type": "sphere", "radius": 0.25,
        "world_from_local": [1,0,0, 0,1,0, 0,0,1, 1,0,0]}
     ]}
  ]
})";

nlohmann::json base_scene() { return nlohmann::json::parse(base_scene_text); }

// Parse without loading files (grids and textures are other modules' tests).
scene_data parse_text(
    const std::string& text, std::vector<std::string>* warnings = nullptr) {
  auto local = std::vector<std::string>{};
  return parse_scene(text, "scene.json", warnings ? *warnings : local, false);
}

scene_data parse_json_scene(const nlohmann::json& js) {
  return parse_text(js.dump(2));
}

// The io_error message of parsing `text` as "scene.json"; other exceptions
// are reported as such so that a test expecting a message fails.
std::string scene_error(const std::string& text) {
  try {
    parse_text(text);
  } catch (const io_error& error) {
    return error.what();
  } catch (const std::exception& error) {
    return std::string{"not an io_error: "} + error.what();
  }
  return "no error";
}
std::string scene_error(const char* text) {
  return scene_error(std::string{text});
}
std::string scene_error(const nlohmann::json& js) {
  return scene_error(js.dump(2));
}

// doctest's matcher for a std::string.
doctest::Contains contains(const std::string& text) {
  return doctest::Contains(doctest::String(text.c_str()));
}

bool starts_with(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

// A minimal valid scene around `arrays` (JSON members, no braces).
std::string small_scene(const std::string& arrays) {
  return R"({"asset": {"version": "4.2"}, "materials": [{"name": "m"}], )" +
         arrays + "}";
}

// Write `text` as the scene file `filename` and load it with its files.
scene_data load_scene_text(
    const std::filesystem::path& filename, const std::string& text) {
  std::ofstream(filename) << text;
  return load_scene(filename.string());
}

// The one sdfunction of a small scene.
sdf_function_data parse_sdfunction_text(const std::string& sdfunction) {
  auto scene =
      parse_text(small_scene(R"("sdfunctions": [)" + sdfunction + "]"));
  REQUIRE(scene.sdfunctions.size() == 1);
  return scene.sdfunctions[0];
}

// Distance of an sdfunction at a world point.
float world_distance(const sdf_function_data& sdf, vec3f p_world) {
  return eval_sdf(make_sdf_tape(sdf.program),
      transform_point(sdf.local_from_world, p_world));
}

void check_frame(const frame3f& a, const frame3f& b, float eps = 1e-6f) {
  for (auto [u, v] : {std::pair{a.x, b.x}, std::pair{a.y, b.y},
           std::pair{a.z, b.z}, std::pair{a.o, b.o}}) {
    CHECK(u.x == doctest::Approx(v.x).epsilon(eps));
    CHECK(u.y == doctest::Approx(v.y).epsilon(eps));
    CHECK(u.z == doctest::Approx(v.z).epsilon(eps));
  }
}

}  // namespace

// -----------------------------------------------------------------------------
// DATA
// -----------------------------------------------------------------------------

TEST_CASE("scene_io seed primitives") {
  auto scene = parse_json_scene(base_scene());
  REQUIRE(scene.sdfunctions.size() == 12);
  auto root = [&](int i) {
    REQUIRE(scene.sdfunctions[i].program.nodes.size() == 1);
    return scene.sdfunctions[i].program.nodes[0];
  };
  auto box = root(0);
  CHECK(scene.sdfunctions[0].name == "floor");
  CHECK(scene.sdfunctions[0].material == 0);
  CHECK(box.type == sdf_type::box);
  CHECK(box.size == vec3f{2, 0.00001f, 2});
  auto bbox = root(1);
  CHECK(bbox.type == sdf_type::bbox);
  CHECK(bbox.size == vec3f{0.3f, 0.2f, 0.1f});
  CHECK(bbox.thickness == 0.02f);
  auto sphere = root(2);
  CHECK(sphere.type == sdf_type::sphere);
  CHECK(sphere.radius == 0.25f);
  CHECK(scene.sdfunctions[2].material == 1);
  auto torus = root(3);
  CHECK(torus.type == sdf_type::torus);
  CHECK(torus.radius == 0.05f);
  CHECK(torus.radius2 == 0.022f);
  auto cone = root(4);
  CHECK(cone.type == sdf_type::capped_cone);
  CHECK(cone.height == 0.1f);
  CHECK(cone.radius == 0.1f);
  CHECK(cone.radius2 == 0.02f);
  auto plane = root(5);
  CHECK(plane.type == sdf_type::plane);
  // No frame: identity.
  check_frame(scene.sdfunctions[5].local_from_world, identity_frame);
  // Seed conventions reach the evaluator unchanged: the box's corner is at
  // the origin, the sphere and torus are centred, the cone spans [-h, h].
  CHECK(eval_primitive(sphere, {0.25f, 0, 0}) == doctest::Approx(0));
  CHECK(eval_primitive(torus, {0.05f, 0.022f, 0}) == doctest::Approx(0));
  CHECK(eval_primitive(cone, {0, 0.1f, 0}) == doctest::Approx(0));
  CHECK(eval_primitive(cone, {0.1f, -0.1f, 0}) == doctest::Approx(0));
  CHECK(eval_primitive(box, {2, 0, 2}) == doctest::Approx(0));
  CHECK(eval_primitive(box, {-0.5f, 0, 1}) == doctest::Approx(0.5f));
}

TEST_CASE("scene_io new primitives") {
  auto scene = parse_json_scene(base_scene());
  auto root  = [&](int i) { return scene.sdfunctions[i].program.nodes.back(); };
  auto capsule = root(6);
  CHECK(capsule.type == sdf_type::capsule);
  CHECK(capsule.height == 0.3f);
  CHECK(capsule.radius == 0.1f);
  auto cylinder = root(7);
  CHECK(cylinder.type == sdf_type::cylinder);
  CHECK(cylinder.height == 0.2f);
  CHECK(cylinder.radius == 0.15f);
  auto rounded = root(8);
  CHECK(rounded.type == sdf_type::rounded_box);
  CHECK(rounded.size == vec3f{0.3f, 0.2f, 0.1f});
  CHECK(rounded.radius == 0.05f);
  auto ellipsoid = root(9);
  CHECK(ellipsoid.type == sdf_type::ellipsoid);
  CHECK(ellipsoid.size == vec3f{0.3f, 0.2f, 0.1f});
  auto octahedron = root(10);
  CHECK(octahedron.type == sdf_type::octahedron);
  CHECK(octahedron.radius == 0.4f);
  // Capsule height is the half segment: the tip is at height + radius.
  CHECK(eval_primitive(capsule, {0, 0.4f, 0}) == doctest::Approx(0));
  CHECK(eval_primitive(octahedron, {0.4f, 0, 0}) == doctest::Approx(0));
}

TEST_CASE("scene_io seed frame convention") {
  // The seed's floor: frame origin (1,0,1) and whd (2,1e-5,2) must cover
  // world x,z in [-1,1], y in [0,1e-5]; `frame` is world->local.
  auto  scene = parse_json_scene(base_scene());
  auto& floor = scene.sdfunctions[0];
  check_frame(
      floor.local_from_world, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}});
  for (auto x : {-1.0f, -0.5f, 0.0f, 0.7f, 1.0f}) {
    for (auto z : {-1.0f, -0.3f, 0.0f, 0.9f, 1.0f}) {
      CHECK(std::abs(world_distance(floor, {x, 0, z})) <= 1e-6f);
      CHECK(world_distance(floor, {x, 1, z}) ==
            doctest::Approx(1 - 0.00001f).epsilon(1e-6));
    }
  }
  CHECK(world_distance(floor, {1.5f, 0, 0}) == doctest::Approx(0.5f));
  CHECK(world_distance(floor, {-1.5f, 0, 0}) == doctest::Approx(0.5f));
  CHECK(world_distance(floor, {0, 0, -1.25f}) == doctest::Approx(0.25f));
  CHECK(world_distance(floor, {0, -0.5f, 0}) == doctest::Approx(0.5f));
  auto bounds = transform_bbox(
      inverse(floor.local_from_world), sdf_bounds(floor.program));
  CHECK(bounds.min.x == doctest::Approx(-1));
  CHECK(bounds.min.y == doctest::Approx(0));
  CHECK(bounds.min.z == doctest::Approx(-1));
  CHECK(bounds.max.x == doctest::Approx(1));
  CHECK(bounds.max.y == doctest::Approx(0.00001f));
  CHECK(bounds.max.z == doctest::Approx(1));
}

TEST_CASE("scene_io world_from_local matches frame") {
  // A box (corner at origin, so rotations show) placed with its axes rotated
  // 90 degrees about y and its origin at (0.3, 0.1, -0.2), written both ways.
  auto by_inverse = parse_sdfunction_text(R"({"type": "box",
      "whd": [0.4, 0.2, 0.1], "material": 0,
      "world_from_local": [0,0,-1, 0,1,0, 1,0,0, 0.3,0.1,-0.2]})");
  auto by_frame   = parse_sdfunction_text(R"({"type": "box",
      "whd": [0.4, 0.2, 0.1], "material": 0,
      "frame": [0,0,1, 0,1,0, -1,0,0, -0.2,-0.1,-0.3]})");
  check_frame(by_inverse.local_from_world, by_frame.local_from_world);
  for (auto x = -1.0f; x <= 1.0f; x += 0.25f) {
    for (auto y = -1.0f; y <= 1.0f; y += 0.5f) {
      for (auto z = -1.0f; z <= 1.0f; z += 0.25f) {
        CHECK(
            world_distance(by_inverse, {x, y, z}) ==
            doctest::Approx(world_distance(by_frame, {x, y, z})).epsilon(1e-5));
      }
    }
  }
  // The local corners land where world_from_local puts them.
  CHECK(std::abs(world_distance(by_inverse, {0.3f, 0.1f, -0.2f})) < 1e-6f);
  CHECK(std::abs(world_distance(by_inverse, {0.4f, 0.3f, -0.6f})) < 1e-6f);
  // 0.5 above the top face (local y = 0.2 is world y = 0.3).
  CHECK(world_distance(by_inverse, {0.35f, 0.8f, -0.4f}) ==
        doctest::Approx(0.5f));
}

TEST_CASE("scene_io csg trees") {
  SUBCASE("union of two spheres with nested frames") {
    // `frame` on a nested object maps the parent into it (a sphere centred
    // at parent x = 2); `world_from_local` maps it out (centred at x = -2).
    auto  sdf   = parse_sdfunction_text(R"({"name": "pair", "type": "union",
        "material": 0, "operands": [
          {"type": "sphere", "radius": 1,
           "frame": [1,0,0, 0,1,0, 0,0,1, -2,0,0]},
          {"type": "sphere", "radius": 1,
           "world_from_local": [1,0,0, 0,1,0, 0,0,1, -2,0,0]}]})");
    auto& nodes = sdf.program.nodes;
    REQUIRE(nodes.size() == 5);
    CHECK(nodes[0].type == sdf_type::sphere);
    CHECK(nodes[1].type == sdf_type::op_transform);
    CHECK(nodes[1].left == 0);
    CHECK(nodes[2].type == sdf_type::sphere);
    CHECK(nodes[3].type == sdf_type::op_transform);
    CHECK(nodes[3].left == 2);
    CHECK(nodes[4].type == sdf_type::op_union);
    CHECK(nodes[4].left == 1);
    CHECK(nodes[4].right == 3);
    REQUIRE(sdf.program.frames.size() == 2);
    check_frame(
        sdf.program.frames[0], {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-2, 0, 0}});
    check_frame(
        sdf.program.frames[1], {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {2, 0, 0}});
    CHECK(world_distance(sdf, {0, 0, 0}) == doctest::Approx(1));
    CHECK(world_distance(sdf, {2, 0, 0}) == doctest::Approx(-1));
    CHECK(world_distance(sdf, {-2, 0, 0}) == doctest::Approx(-1));
    CHECK(world_distance(sdf, {2, 2, 0}) == doctest::Approx(1));
    CHECK(world_distance(sdf, {-3.5f, 0, 0}) == doctest::Approx(0.5f));
  }
  SUBCASE("subtraction removes the second operand") {
    auto sdf = parse_sdfunction_text(R"({"type": "subtraction",
        "material": 0, "operands": [
          {"type": "sphere", "radius": 1},
          {"type": "sphere", "radius": 0.5,
           "world_from_local": [1,0,0, 0,1,0, 0,0,1, 1,0,0]}]})");
    CHECK(sdf.program.nodes.back().type == sdf_type::op_subtraction);
    CHECK(world_distance(sdf, {0, 0, 0}) == doctest::Approx(-0.5f));
    CHECK(world_distance(sdf, {1, 0, 0}) == doctest::Approx(0.5f));
    CHECK(world_distance(sdf, {-0.9f, 0, 0}) == doctest::Approx(-0.1f));
  }
  SUBCASE("intersection, three operands folded left") {
    // Unit ball, box [0,5]^3, ball of radius 2: the ball's positive octant.
    auto  sdf   = parse_sdfunction_text(R"({"type": "intersection",
        "material": 0, "operands": [
          {"type": "sphere", "radius": 1},
          {"type": "box", "whd": [5, 5, 5]},
          {"type": "sphere", "radius": 2}]})");
    auto& nodes = sdf.program.nodes;
    // The operands first, then ((0 1) 2).
    REQUIRE(nodes.size() == 5);
    CHECK(nodes[2].type == sdf_type::sphere);
    CHECK(nodes[3].type == sdf_type::op_intersection);
    CHECK(nodes[3].left == 0);
    CHECK(nodes[3].right == 1);
    CHECK(nodes[4].type == sdf_type::op_intersection);
    CHECK(nodes[4].left == 3);
    CHECK(nodes[4].right == 2);
    CHECK(world_distance(sdf, {0.5f, 0.5f, 0.5f}) ==
          doctest::Approx(std::sqrt(0.75f) - 1));
    CHECK(world_distance(sdf, {0.5f, -0.25f, 0.5f}) == doctest::Approx(0.25f));
    CHECK(world_distance(sdf, {0.1f, 0.2f, 0.1f}) == doctest::Approx(-0.1f));
  }
  SUBCASE("smooth operators store the blend") {
    auto  scene = parse_json_scene(base_scene());
    auto& blob  = scene.sdfunctions[11];
    CHECK(blob.program.nodes.back().type == sdf_type::op_smooth_union);
    CHECK(blob.program.nodes.back().blend == 0.1f);
    auto sdf = parse_sdfunction_text(R"({"type": "smooth_union",
        "blend": 0.2, "material": 0, "operands": [
          {"type": "sphere", "radius": 0.5,
           "world_from_local": [1,0,0, 0,1,0, 0,0,1, -0.6,0,0]},
          {"type": "sphere", "radius": 0.5,
           "world_from_local": [1,0,0, 0,1,0, 0,0,1, 0.6,0,0]}]})");
    // Equal distances 0.1 blend down by blend/4.
    CHECK(world_distance(sdf, {0, 0, 0}) == doctest::Approx(0.05f));
    for (auto type : {"smooth_intersection", "smooth_subtraction"}) {
      auto other =
          parse_sdfunction_text(std::string{R"({"type": ")"} + type +
                                R"(", "blend": 0.3, "material": 0, "operands": [
            {"type": "sphere", "radius": 1}, {"type": "plane"}]})");
      CHECK(sdf_type_names[(int)other.program.nodes.back().type] == type);
      CHECK(other.program.nodes.back().blend == 0.3f);
    }
  }
  SUBCASE("smooth unions of many operands pair neighbours, balanced") {
    // Five spheres of radius 0.5 at x = 0, 1, 2, 3, 4: ((0 1) (2 3)) 4.
    auto text = std::string{R"({"type": "smooth_union", "blend": 0.4,
        "material": 0, "operands": [)"};
    for (auto i = 0; i < 5; i++)
      text += std::string{i ? "," : ""} +
              R"({"type": "sphere", "radius": 0.5, "world_from_local":
              [1,0,0, 0,1,0, 0,0,1, )" +
              std::to_string(i) + ",0,0]}";
    auto  sdf   = parse_sdfunction_text(text + "]}");
    auto& nodes = sdf.program.nodes;
    REQUIRE(nodes.size() == 14);  // 5 spheres, 5 transforms, 4 blends
    auto leaf = [&](int i) { return 2 * i + 1; };  // sphere, then transform
    CHECK(nodes[10].left == leaf(0));
    CHECK(nodes[10].right == leaf(1));
    CHECK(nodes[11].left == leaf(2));
    CHECK(nodes[11].right == leaf(3));
    CHECK(nodes[12].left == 10);
    CHECK(nodes[12].right == 11);
    CHECK(nodes[13].left == 12);
    CHECK(nodes[13].right == leaf(4));
    // Its value: the same smooth minima, in that order.
    auto p        = vec3f{1.5f, 0.3f, 0};
    auto d        = [&](float x) { return length(p - vec3f{x, 0, 0}) - 0.5f; };
    auto expected = smooth_min(smooth_min(smooth_min(d(0), d(1), 0.4f),
                                   smooth_min(d(2), d(3), 0.4f), 0.4f),
        d(4), 0.4f);
    CHECK(world_distance(sdf, p) == doctest::Approx(expected));
  }
  SUBCASE("round, onion and transform") {
    auto rounded = parse_sdfunction_text(R"({"type": "round", "radius": 0.1,
        "material": 0, "operand": {"type": "sphere", "radius": 0.5}})");
    CHECK(rounded.program.nodes.back().type == sdf_type::op_round);
    CHECK(rounded.program.nodes.back().radius == 0.1f);
    CHECK(rounded.program.nodes.back().left == 0);
    CHECK(world_distance(rounded, {1, 0, 0}) == doctest::Approx(0.4f));
    auto onion = parse_sdfunction_text(R"({"type": "onion",
        "thickness": 0.05, "material": 0,
        "operand": {"type": "sphere", "radius": 1}})");
    CHECK(onion.program.nodes.back().thickness == 0.05f);
    CHECK(world_distance(onion, {0, 0, 0}) == doctest::Approx(0.95f));
    CHECK(world_distance(onion, {1, 0, 0}) == doctest::Approx(-0.05f));
    // A nested transform moves its operand; at the top level the frame is
    // the object's local_from_world.
    auto moved = parse_sdfunction_text(R"({"type": "union", "material": 0,
        "operands": [{"type": "sphere", "radius": 1},
          {"type": "transform",
           "world_from_local": [1,0,0, 0,1,0, 0,0,1, 0,3,0],
           "operand": {"type": "sphere", "radius": 1}}]})");
    CHECK(moved.program.nodes.size() == 4);
    CHECK(world_distance(moved, {0, 3, 0}) == doctest::Approx(-1));
    CHECK(world_distance(moved, {0, 1.5f, 0}) == doctest::Approx(0.5f));
    auto top = parse_sdfunction_text(R"({"type": "transform", "material": 0,
        "world_from_local": [1,0,0, 0,1,0, 0,0,1, 0,3,0],
        "operand": {"type": "sphere", "radius": 1}})");
    CHECK(top.program.nodes.size() == 1);
    CHECK(world_distance(top, {0, 3, 0}) == doctest::Approx(-1));
  }
}

TEST_CASE("scene_io cameras") {
  auto scene = parse_json_scene(base_scene());
  CHECK(scene.copyright == "test scene");
  REQUIRE(scene.cameras.size() == 2);
  auto& camera = scene.cameras[0];
  CHECK(camera.name == "cam");
  check_frame(camera.frame, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0.5f, 3}});
  CHECK(camera.orthographic == true);
  CHECK(camera.lens == 0.035f);
  CHECK(camera.film == 0.024f);
  CHECK(camera.aspect == 2.0f);
  CHECK(camera.focus == 3.0f);
  CHECK(camera.aperture == 0.01f);
  // Defaults as in scene.h (Yocto/GL's).
  auto& plain = scene.cameras[1];
  CHECK(plain.name == "plain");
  check_frame(plain.frame, identity_frame);
  CHECK(plain.orthographic == false);
  CHECK(plain.lens == 0.050f);
  CHECK(plain.film == 0.036f);
  CHECK(plain.aspect == 1.5f);
  CHECK(plain.focus == 10000.0f);
  CHECK(plain.aperture == 0.0f);
  // No cameras in the file: none added here (the renderer adds one).
  CHECK(parse_text(small_scene(R"("cameras": [])")).cameras.empty());
  CHECK(parse_text(small_scene(R"("textures": [])")).cameras.empty());
}

TEST_CASE("scene_io materials") {
  auto scene = parse_json_scene(base_scene());
  REQUIRE(scene.materials.size() == 3);
  auto& floor = scene.materials[0];
  CHECK(floor.name == "floor");
  CHECK(floor.type == material_type::matte);
  CHECK(floor.color.x == 0.7f);
  CHECK(floor.color_tex == 0);
  CHECK(floor.emission_tex == invalidid);
  CHECK(floor.roughness == 0.0f);
  CHECK(floor.ior == 1.5f);
  CHECK(floor.trdepth == 0.01f);
  CHECK(floor.opacity == 1.0f);
  auto& all = scene.materials[2];
  CHECK(all.type == material_type::gltfpbr);
  CHECK(all.emission == vec3f{1, 2, 3});
  CHECK(all.color == vec3f{0.1f, 0.2f, 0.3f});
  CHECK(all.metallic == 0.25f);
  CHECK(all.roughness == 0.5f);
  CHECK(all.ior == 1.33f);
  CHECK(all.trdepth == 0.2f);
  CHECK(all.scattering == vec3f{0.4f, 0.5f, 0.6f});
  CHECK(all.scanisotropy == -0.3f);
  CHECK(all.opacity == 0.75f);
  CHECK(all.emission_tex == 0);
  CHECK(all.color_tex == 0);
  CHECK(all.roughness_tex == 0);
  CHECK(all.scattering_tex == 0);
  CHECK(all.normal_tex == 0);
  // Every type name parses to its enumerator.
  for (size_t i = 0; i < material_type_names.size(); i++) {
    auto js                    = base_scene();
    js["materials"][0]["type"] = material_type_names[i];
    CHECK((size_t)parse_json_scene(js).materials[0].type == i);
  }
}

TEST_CASE("scene_io environments textures volumes instances") {
  auto scene = parse_json_scene(base_scene());
  REQUIRE(scene.environments.size() == 1);
  auto& environment = scene.environments[0];
  CHECK(environment.name == "sky");
  check_frame(environment.frame, {{0, 0, 1}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 0}});
  CHECK(environment.emission.y == 0.5f);
  CHECK(environment.emission_tex == 0);
  REQUIRE(scene.textures.size() == 1);
  CHECK(scene.textures[0].name == "sky");
  CHECK(scene.textures[0].uri == "textures/sky.hdr");
  REQUIRE(scene.volumes.size() == 2);
  CHECK(scene.volumes[0].name == "sackboy");
  CHECK(scene.volumes[0].uri == "sdfs/sackboy.sdf");
  CHECK(scene.volumes[1].uri == "grids/cloud.vdb");
  REQUIRE(scene.vol_instances.size() == 2);
  auto& instance = scene.vol_instances[0];
  CHECK(instance.name == "inst");
  CHECK(instance.volume == 1);
  CHECK(instance.material == 2);
  CHECK(instance.scale == 0.5f);
  check_frame(instance.local_from_world,
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.2f, 0, 0}});
  auto& defaults = scene.vol_instances[1];
  CHECK(defaults.scale == 1.0f);
  check_frame(defaults.local_from_world, identity_frame);
  // world_from_local on an instance is stored inverted.
  auto js = base_scene();
  js["vol_instances"][0].erase("frame");
  js["vol_instances"][0]["world_from_local"] = {
      0, 0, -1, 0, 1, 0, 1, 0, 0, 0.3, 0.1, -0.2};
  check_frame(parse_json_scene(js).vol_instances[0].local_from_world,
      {{0, 0, 1}, {0, 1, 0}, {-1, 0, 0}, {-0.2f, -0.1f, -0.3f}});
  // Version 5.0 is read the same way; integral floats are fine as indices.
  js                               = base_scene();
  js["asset"]["version"]           = "5.0";
  js["sdfunctions"][2]["material"] = 2.0;
  CHECK(parse_json_scene(js).sdfunctions[2].material == 2);
}

TEST_CASE("scene_io missing material textures warn") {
  // The seed scenes name textures 1 and 2 that do not exist: the load goes
  // on without them, and says so.
  auto js                          = base_scene();
  js["materials"][0]["color_tex"]  = 1;
  js["materials"][2]["normal_tex"] = 7;
  auto warnings                    = std::vector<std::string>{};
  auto scene                       = parse_text(js.dump(), &warnings);
  CHECK(scene.materials[0].color_tex == invalidid);
  CHECK(scene.materials[2].normal_tex == invalidid);
  CHECK(scene.materials[2].color_tex == 0);
  REQUIRE(warnings.size() == 2);
  CHECK(warnings[0] ==
        "scene.json: materials[0] (\"floor\").color_tex: texture 1 does not "
        "exist (the scene has 1 texture); ignored");
  CHECK(warnings[1] ==
        "scene.json: materials[2] (\"all\").normal_tex: texture 7 does not "
        "exist (the scene has 1 texture); ignored");
  // -1 is none, silently.
  js                              = base_scene();
  js["materials"][0]["color_tex"] = -1;
  warnings.clear();
  CHECK(parse_text(js.dump(), &warnings).materials[0].color_tex == invalidid);
  CHECK(warnings.empty());
}

TEST_CASE("scene_io seed scenes") {
  IMPLICIT_SKIP_WITHOUT_SHARED("seed scenes; the examples cover the format");
  auto dir       = std::string{IMPLICIT_SHARED_DIR} + "/seed_scenes/tests/";
  auto read_text = [](const std::string& filename) {
    auto stream = std::ifstream(filename);
    REQUIRE(stream.good());
    return std::string{std::istreambuf_iterator<char>(stream),
        std::istreambuf_iterator<char>()};
  };
  SUBCASE("07_sdfunction validates exactly") {
    auto filename = dir + "07_sdfunction/sdfunction.json";
    auto warnings = std::vector<std::string>{};
    auto scene    = parse_scene(read_text(filename), filename, warnings, false);
    CHECK(scene.cameras.size() == 7);
    CHECK(scene.cameras[6].orthographic);
    CHECK(scene.cameras[6].aperture == 0.019999999552965164f);
    CHECK(scene.textures.size() == 1);
    CHECK(scene.materials.size() == 7);
    CHECK(scene.volumes.size() == 2);
    CHECK(scene.vol_instances.size() == 2);
    CHECK(scene.vol_instances[0].scale == 0.001f);
    REQUIRE(scene.sdfunctions.size() == 4);
    auto& cone = scene.sdfunctions[2].program.nodes.back();
    CHECK(cone.type == sdf_type::capped_cone);
    CHECK(cone.height == 0.1f);
    CHECK(cone.radius == 0.1f);
    CHECK(cone.radius2 == 0.02f);
    auto& torus = scene.sdfunctions[3];
    CHECK(torus.program.nodes.back().radius == 0.05f);
    CHECK(torus.program.nodes.back().radius2 == 0.022f);
    check_frame(torus.local_from_world,
        {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {-0.06f, 0.1f, -0.05f}});
    // The seed's floor, evaluated the seed's way.
    auto& floor = scene.sdfunctions[0];
    CHECK(std::abs(world_distance(floor, {-0.9f, 0, 0.9f})) < 1e-6f);
    CHECK(world_distance(floor, {0, 0.5f, 0}) ==
          doctest::Approx(0.5f - 0.00001f));
    REQUIRE(warnings.size() == 2);
    CHECK(
        warnings[0] == filename +
                           ": materials[0] (\"floor\").color_tex: texture 1 "
                           "does not exist (the scene has 1 texture); ignored");
    CHECK(warnings[1] == filename +
                             ": materials[3] (\"sackboy1\").color_tex: texture "
                             "2 does not exist (the scene has 1 texture); "
                             "ignored");
  }
  SUBCASE("06_gridsdf validates exactly") {
    auto filename = dir + "06_gridsdf/gridsdf.json";
    auto warnings = std::vector<std::string>{};
    auto scene    = parse_scene(read_text(filename), filename, warnings, false);
    CHECK(scene.materials.size() == 8);
    CHECK(scene.vol_instances.size() == 4);
    CHECK(scene.sdfunctions.size() == 2);
    CHECK(warnings.size() == 3);
  }
  SUBCASE("loading 07_sdfunction with its files") {
    // The loaders exist: the whole scene loads (only this seed: its grids
    // are 8 MB of text).
    auto filename = dir + "07_sdfunction/sdfunction.json";
    auto warnings = std::vector<std::string>{};
    auto scene    = load_scene(filename, warnings);
    CHECK(warnings.size() == 2);
    REQUIRE(scene.volumes.size() == 2);
    REQUIRE(scene.volumes[1].grid);
    auto& bunny = *scene.volumes[1].grid;
    CHECK(bunny.dims == vec3i{84, 85, 65});
    CHECK(bunny.values.size() == (size_t)84 * 85 * 65);
    CHECK(has_grid_accel(bunny));
    REQUIRE(scene.volumes[0].grid);
    CHECK(scene.volumes[0].grid->values.size() ==
          (size_t)grid_samples(scene.volumes[0].grid->dims));
    REQUIRE(scene.textures.size() == 1);
    CHECK(scene.textures[0].image.width == 2048);
    CHECK(scene.textures[0].image.height == 1024);
  }
}

TEST_CASE("scene_io load_scene reads files") {
  auto dir = std::filesystem::path(IMPLICIT_BINARY_DIR) / "scene_io_test";
  std::filesystem::create_directories(dir);
  auto filename = (dir / "small.json").string();
  {
    auto stream = std::ofstream(filename);
    stream << small_scene(
        R"("sdfunctions": [{"type": "sphere", "radius": 2, "material": 0}])");
  }
  auto scene = load_scene(filename);
  REQUIRE(scene.sdfunctions.size() == 1);
  CHECK(scene.sdfunctions[0].program.nodes[0].radius == 2.0f);
  // Missing file, and a directory.
  auto missing = (dir / "missing.json").string();
  CHECK_THROWS_WITH_AS(load_scene(missing),
      contains(missing + ": cannot open (No such file or directory)"),
      io_error);
  CHECK_THROWS_WITH_AS(load_scene(dir.string()),
      contains(dir.string() + ": cannot open (Is a directory)"), io_error);
  // Files referenced by a scene are relative to its directory, and their
  // errors name the element and key that referenced them.
  auto with_volume = small_scene(
      R"("volumes": [{"name": "bunny", "uri": "nowhere/bunny.sdf", "binary": false}])");
  auto inside    = (dir / "scene.json").string();
  auto no_volume = inside + ": volumes[0] (\"bunny\").uri: " +
                   (dir / "nowhere/bunny.sdf").string() +
                   ": cannot open (No such file or directory)";
  CHECK_THROWS_WITH_AS(
      parse_scene(with_volume, inside), no_volume.c_str(), io_error);
  auto with_texture =
      small_scene(R"("textures": [{"name": "sky", "uri": "nowhere/sky.hdr"}])");
  auto no_texture = inside + ": textures[0] (\"sky\").uri: " +
                    (dir / "nowhere/sky.hdr").string() +
                    ": cannot open (No such file or directory)";
  CHECK_THROWS_WITH_AS(
      parse_scene(with_texture, inside), no_texture.c_str(), io_error);
  // Files load in parallel, yet of several bad ones the first in the file's
  // order is reported, every time.
  auto several = small_scene(
      R"("volumes": [{"name": "a", "uri": "nowhere/a.sdf", "binary": false},
                     {"name": "b", "uri": "nowhere/b.sdf", "binary": false}],
         "textures": [{"name": "sky", "uri": "nowhere/sky.hdr"}])");
  for (auto run = 0; run < 20; run++)
    CHECK_THROWS_WITH_AS(parse_scene(several, inside),
        contains(inside + ": volumes[0] (\"a\").uri: "), io_error);
}

TEST_CASE("scene_io loads the grids and textures a scene names") {
  // Files the test makes, so that this runs without ../shared: every
  // format's grid and a texture come back with the values written.
  auto dir = std::filesystem::path(IMPLICIT_BINARY_DIR) / "scene_io_files";
  std::filesystem::create_directories(dir / "files");
  auto grid = make_grid({3, 4, 5}, 0.25f, {0, 0, 0}, 0);
  for (auto n = 0; n < (int)grid.values.size(); n++)
    grid.values[n] = 0.125f * (float)(n % 7) - 0.3f;
  update_grid_accel(grid);
  save_grid((dir / "files/a.sdf").string(), grid, grid_format::sdfgen);
  save_grid((dir / "files/b.sdf").string(), grid, grid_format::skanti);
  save_grid((dir / "files/c.vol").string(), grid, grid_format::mitsuba);
  auto texture = make_image(3, 2);
  for (auto n = 0; n < 6; n++) texture.pixels[n] = {0.5f * (float)n, 1, 2, 1};
  save_image((dir / "files/t.exr").string(), texture);
  auto scene = load_scene_text(dir / "scene.json", small_scene(R"("volumes": [
         {"name": "a", "uri": "files/a.sdf", "binary": false},
         {"name": "b", "uri": "files/b.sdf", "binary": true},
         {"name": "c", "uri": "files/c.vol"}],
       "textures": [{"name": "t", "uri": "files/t.exr"}])"));
  REQUIRE(scene.volumes.size() == 3);
  for (auto& volume : scene.volumes) {
    INFO(volume.name);
    REQUIRE(volume.grid);
    CHECK(volume.grid->dims == grid.dims);
    CHECK(volume.grid->spacing == 0.25f);
    CHECK(volume.grid->values == grid.values);
    CHECK(has_grid_accel(*volume.grid));
  }
  REQUIRE(scene.textures.size() == 1);
  CHECK(scene.textures[0].image.width == 3);
  auto& pixels = scene.textures[0].image.pixels;
  REQUIRE(pixels.size() == texture.pixels.size());
  CHECK(std::memcmp(pixels.data(), texture.pixels.data(),
            pixels.size() * sizeof(vec4f)) == 0);
}

// -----------------------------------------------------------------------------
// ERRORS
// -----------------------------------------------------------------------------

TEST_CASE("scene_io errors: invalid JSON") {
  // Line and column point at the offending character.
  CHECK(starts_with(scene_error("{\n  \"asset\": {\"version\": \"4.2\"},\n"
                                "  \"cameras\": [}\n}"),
      "scene.json:3:15: invalid JSON: syntax error"));
  CHECK(starts_with(scene_error("{\"asset\": {\"version\": \"4.2\"}"),
      "scene.json:1:29: invalid JSON: syntax error"));
  CHECK(starts_with(scene_error(""), "scene.json:1:1: invalid JSON"));
  // Numbers beyond double range are refused by nlohmann without a position.
  CHECK(scene_error("{\n \"a\": [1,\n  1e999]}") ==
        "scene.json:3:3: invalid JSON: number overflow parsing '1e999'");
  // A repeated key would silently drop the first value.
  auto duplicate = scene_error(small_scene(
      R"("sdfunctions": [{"type": "sphere", "radius": 1, "radius": 2, "material": 0}])"));
  CHECK(duplicate ==
        "scene.json: sdfunctions[0].radius: duplicate key (each key may "
        "appear once per object)");
  CHECK(scene_error("[1]") ==
        "scene.json: expected a JSON object, found an array");
}

TEST_CASE("scene_io errors: asset and top level") {
  auto js = base_scene();
  js.erase("asset");
  CHECK(starts_with(
      scene_error(js), "scene.json: asset: missing required object"));
  js          = base_scene();
  js["asset"] = nlohmann::json::object();
  CHECK(scene_error(js) == "scene.json: asset.version: missing required key");
  js                     = base_scene();
  js["asset"]["version"] = "4.1";
  CHECK(scene_error(js) ==
        "scene.json: asset.version: unsupported version \"4.1\" (accepted "
        "versions: \"4.2\", \"5.0\")");
  js["asset"]["version"] = 4.2;
  CHECK(scene_error(js) ==
        "scene.json: asset.version: expected a string, found a number");
  js          = base_scene();
  js["asset"] = "4.2";
  CHECK(scene_error(js) ==
        "scene.json: asset: expected an object, found a string");
  js                  = base_scene();
  js["asset"]["date"] = "today";
  CHECK(starts_with(scene_error(js), "scene.json: asset.date: unknown key"));
  js           = base_scene();
  js["lights"] = nlohmann::json::array();
  CHECK(scene_error(js) ==
        "scene.json: lights: unknown key (valid keys: asset, cameras, "
        "textures, materials, environments, sdfunctions, volumes, "
        "vol_instances)");
  for (auto key : {"shapes", "instances", "subdivs"}) {
    js      = base_scene();
    js[key] = nlohmann::json::array();
    CHECK(scene_error(js) ==
          std::string{"scene.json: "} + key +
              ": meshes are not supported: implicit renders implicit "
              "surfaces only (use sdfunctions, or volumes and vol_instances)");
  }
  js            = base_scene();
  js["cameras"] = nlohmann::json::object();
  CHECK(scene_error(js) ==
        "scene.json: cameras: expected an array, found an object");
  js               = base_scene();
  js["cameras"][1] = 3;
  CHECK(scene_error(js) ==
        "scene.json: cameras[1]: expected an object, found a number");
}

TEST_CASE("scene_io errors: types and unknown keys") {
  auto js                        = base_scene();
  js["sdfunctions"][2]["radius"] = "big";
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").radius: expected a number, "
        "found a string");
  js                               = base_scene();
  js["cameras"][0]["orthographic"] = 1;
  CHECK(scene_error(js) ==
        "scene.json: cameras[0] (\"cam\").orthographic: expected a boolean, "
        "found a number");
  js                       = base_scene();
  js["cameras"][0]["name"] = 7;
  CHECK(scene_error(js) ==
        "scene.json: cameras[0].name: expected a string, found a number");
  js                          = base_scene();
  js["materials"][1]["color"] = {1, 1};
  CHECK(scene_error(js) ==
        "scene.json: materials[1] (\"light\").color: expected an array of 3 "
        "numbers, found 2 values");
  js                          = base_scene();
  js["materials"][1]["color"] = {1, true, 1};
  CHECK(scene_error(js) ==
        "scene.json: materials[1] (\"light\").color[1]: expected a number, "
        "found a boolean");
  js                               = base_scene();
  js["sdfunctions"][2]["material"] = 1.5;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").material: expected an "
        "integer, found 1.5");
  js                               = base_scene();
  js["sdfunctions"][2]["material"] = "floor";
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").material: expected an "
        "integer, found a string");
  // Unknown type strings list the valid names.
  js                           = base_scene();
  js["sdfunctions"][2]["type"] = "spher";
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[2] (\"ball\").type: unknown type \"spher\" "
      "(valid types: box, bbox, sphere, torus, capped_cone, plane, capsule,"));
  js                         = base_scene();
  js["materials"][0]["type"] = "plastic";
  CHECK(scene_error(js) ==
        "scene.json: materials[0] (\"floor\").type: unknown type \"plastic\" "
        "(valid types: matte, glossy, reflective, transparent, refractive, "
        "subsurface, volumetric, gltfpbr)");
  // Unknown keys, per type for sdfunctions.
  js                         = base_scene();
  js["sdfunctions"][2]["r1"] = 0.5;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").r1: unknown key for type "
        "\"sphere\" (valid keys: name, type, material, frame, "
        "world_from_local, radius)");
  js                      = base_scene();
  js["cameras"][0]["fov"] = 45;
  CHECK(starts_with(scene_error(js),
      "scene.json: cameras[0] (\"cam\").fov: unknown key (valid keys: name, "
      "frame,"));
  for (auto array :
      {"textures", "materials", "environments", "volumes", "vol_instances"}) {
    js                     = base_scene();
    js[array][0]["colour"] = 1;
    auto name              = js[array][0]["name"].get<std::string>();
    CHECK(starts_with(scene_error(js), std::string{"scene.json: "} + array +
                                           "[0] (\"" + name +
                                           "\").colour: unknown key"));
  }
}

TEST_CASE("scene_io errors: sdfunction parameters") {
  auto js = base_scene();
  js["sdfunctions"][3].erase("r2");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[3] (\"torus1\").r2: missing required "
        "parameter");
  js = base_scene();
  js["sdfunctions"][0].erase("whd");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").whd: missing required "
        "parameter");
  js = base_scene();
  js["sdfunctions"][2].erase("type");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").type: missing required key");
  js = base_scene();
  js["sdfunctions"][2].erase("material");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").material: missing required "
        "key");
  // Elements without a name are named by index only.
  js = base_scene();
  js["sdfunctions"][2].erase("name");
  js["sdfunctions"][2]["radius"] = -0.25;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2].radius: must be > 0, found -0.25");
  js                             = base_scene();
  js["sdfunctions"][2]["radius"] = 0;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").radius: must be > 0, found 0");
  js                          = base_scene();
  js["sdfunctions"][0]["whd"] = {2, -1, 2};
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").whd: must be > 0 in every "
        "component, found (2, -1, 2)");
  js                                = base_scene();
  js["sdfunctions"][1]["thickness"] = -0.1;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[1] (\"frame1\").thickness: must be > 0"));
  js                         = base_scene();
  js["sdfunctions"][3]["r1"] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[3] (\"torus1\").r1: must be > 0"));
  // Capped cones may come to a point, but not at both ends.
  js                         = base_scene();
  js["sdfunctions"][4]["r2"] = 0;
  CHECK(parse_json_scene(js).sdfunctions[4].program.nodes[0].radius2 == 0);
  js["sdfunctions"][4]["r1"] = 0;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[4] (\"cone\").r2: r1 and r2 cannot both be 0");
  js                         = base_scene();
  js["sdfunctions"][4]["r1"] = -0.1;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[4] (\"cone\").r1: must be >= 0, found -0.1");
  js                             = base_scene();
  js["sdfunctions"][4]["height"] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[4] (\"cone\").height: must be > 0"));
  for (auto [index, key] : {std::pair{6, "height"}, std::pair{6, "radius"},
           std::pair{7, "height"}, std::pair{7, "radius"},
           std::pair{8, "radius"}, std::pair{10, "radius"}}) {
    js                            = base_scene();
    js["sdfunctions"][index][key] = -1;
    auto name = js["sdfunctions"][index]["name"].get<std::string>();
    CHECK(scene_error(js) == "scene.json: sdfunctions[" +
                                 std::to_string(index) + "] (\"" + name +
                                 "\")." + key + ": must be > 0, found -1");
  }
  js                            = base_scene();
  js["sdfunctions"][9]["radii"] = {0.3, 0, 0.1};
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[9] (\"egg\").radii: must be > 0 in every"));
  js                             = base_scene();
  js["sdfunctions"][8]["radius"] = 0.2;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[8] (\"rbox\").radius: must be <= the "
        "smallest half size 0.1, found 0.2");
}

TEST_CASE("scene_io errors: nested operators") {
  auto js                                        = base_scene();
  js["sdfunctions"][11]["operands"][1]["radius"] = -1;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[11] (\"blob\").operands[1].radius: must be "
        "> 0, found -1");
  js                                           = base_scene();
  js["sdfunctions"][11]["operands"][0]["type"] = "blob";
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[11] (\"blob\").operands[0].type: unknown "
      "type \"blob\" (valid types:"));
  js                                   = base_scene();
  js["sdfunctions"][11]["operands"][0] = 2;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[11] (\"blob\").operands[0]: expected an "
        "object, found a number");
  js                                               = base_scene();
  js["sdfunctions"][11]["operands"][0]["material"] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[11] (\"blob\").operands[0].material: unknown "
      "key for type \"sphere\""));
  js = base_scene();
  js["sdfunctions"][11]["operands"].erase(1);
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[11] (\"blob\").operands: expected at least "
        "2 operands, found 1");
  js = base_scene();
  js["sdfunctions"][11].erase("operands");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[11] (\"blob\").operands: missing required "
        "parameter");
  js = base_scene();
  js["sdfunctions"][11].erase("blend");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[11] (\"blob\").blend: missing required "
        "parameter");
  js                             = base_scene();
  js["sdfunctions"][11]["blend"] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[11] (\"blob\").blend: must be > 0"));
  CHECK(
      scene_error(small_scene(
          R"("sdfunctions": [{"name": "r", "type": "round", "radius": 0.1, "material": 0}])")) ==
      "scene.json: sdfunctions[0] (\"r\").operand: missing required "
      "parameter");
  CHECK(scene_error(small_scene(R"("sdfunctions": [{"name": "o",
      "type": "onion", "thickness": -0.1, "material": 0,
      "operand": {"type": "plane"}}])")) ==
        "scene.json: sdfunctions[0] (\"o\").thickness: must be > 0, found "
        "-0.1");
  CHECK(scene_error(small_scene(R"("sdfunctions": [{"name": "r",
      "type": "round", "radius": 0.1, "material": 0,
      "operand": {"type": "round", "radius": 0.1,
        "operand": {"type": "sphere"}}}])")) ==
        "scene.json: sdfunctions[0] (\"r\").operand.operand.radius: missing "
        "required parameter");
  CHECK(starts_with(scene_error(small_scene(R"("sdfunctions": [{"name": "t",
      "type": "transform", "material": 0,
      "operand": {"type": "plane"}}])")),
      "scene.json: sdfunctions[0] (\"t\").frame: missing required key"));
  // Nesting is walked without recursion: 250 levels load (253 JSON levels);
  // the JSON parser's depth limit is the only one.
  auto deep = std::string{R"({"type": "sphere", "radius": 1})"};
  for (auto i = 0; i < 250; i++)
    deep = R"({"type": "round", "radius": 0.01, "operand": )" + deep + "}";
  deep.insert(1, R"("name": "deep", "material": 0, )");
  auto scene = parse_text(small_scene(R"("sdfunctions": [)" + deep + "]"));
  REQUIRE(scene.sdfunctions.size() == 1);
  CHECK(scene.sdfunctions[0].program.nodes.size() == 251);
  CHECK(scene.sdfunctions[0].program.nodes.back().type == sdf_type::op_round);
  CHECK(scene.sdfunctions[0].program.nodes[0].type == sdf_type::sphere);
}

TEST_CASE("scene_io errors: frames") {
  auto js                       = base_scene();
  js["sdfunctions"][0]["frame"] = {1, 0, 0, 0, 0, 0, 0, 0, 1, 1, 0, 1};
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[0] (\"floor\").frame: not invertible"));
  js                            = base_scene();
  js["sdfunctions"][0]["frame"] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0};
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").frame: expected an array of "
        "12 numbers, found 11 values");
  js                               = base_scene();
  js["sdfunctions"][0]["frame"][3] = "0";
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").frame[3]: expected a number, "
        "found a string");
  // NaN cannot be written in JSON (nlohmann writes null for it).
  js                               = base_scene();
  js["sdfunctions"][0]["frame"][0] = std::nan("");
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").frame[0]: expected a number, "
        "found null");
  js                               = base_scene();
  js["sdfunctions"][0]["frame"][9] = 1e39;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[0] (\"floor\").frame[9]: out of float range "
        "(1e+39)");
  js                                       = base_scene();
  js["sdfunctions"][0]["world_from_local"] = js["sdfunctions"][0]["frame"];
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[0] (\"floor\").world_from_local: conflicts "
      "with frame"));
  js                                       = base_scene();
  js["sdfunctions"][2]["world_from_local"] = {
      0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[2] (\"ball\").world_from_local: not "
      "invertible"));
  js                                                          = base_scene();
  js["sdfunctions"][11]["operands"][1]["world_from_local"][4] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: sdfunctions[11] (\"blob\").operands[1].world_from_local: "
      "not invertible"));
  js                        = base_scene();
  js["cameras"][0]["frame"] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  CHECK(starts_with(scene_error(js),
      "scene.json: cameras[0] (\"cam\").frame: not invertible"));
  js                             = base_scene();
  js["environments"][0]["frame"] = {1, 0, 0};
  CHECK(starts_with(scene_error(js),
      "scene.json: environments[0] (\"sky\").frame: expected an array of 12"));
  js                                 = base_scene();
  js["vol_instances"][0]["frame"][0] = 0;
  js["vol_instances"][0]["frame"][4] = 0;
  CHECK(starts_with(scene_error(js),
      "scene.json: vol_instances[0] (\"inst\").frame: not invertible"));
}

TEST_CASE("scene_io errors: references") {
  auto js                          = base_scene();
  js["sdfunctions"][2]["material"] = 3;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").material: index 3 out of range "
        "(the scene has 3 materials)");
  js["sdfunctions"][2]["material"] = -1;
  CHECK(scene_error(js) ==
        "scene.json: sdfunctions[2] (\"ball\").material: index -1 out of "
        "range (the scene has 3 materials)");
  js                               = base_scene();
  js["vol_instances"][0]["volume"] = 2;
  CHECK(scene_error(js) ==
        "scene.json: vol_instances[0] (\"inst\").volume: index 2 out of range "
        "(the scene has 2 volumes)");
  js = base_scene();
  js["vol_instances"][1].erase("volume");
  CHECK(scene_error(js) ==
        "scene.json: vol_instances[1] (\"defaults\").volume: missing "
        "required key");
  js = base_scene();
  js["vol_instances"][1].erase("material");
  CHECK(scene_error(js) ==
        "scene.json: vol_instances[1] (\"defaults\").material: missing "
        "required key");
  js                                 = base_scene();
  js["vol_instances"][0]["material"] = 9;
  CHECK(starts_with(scene_error(js),
      "scene.json: vol_instances[0] (\"inst\").material: index 9 out of"));
  js                                    = base_scene();
  js["environments"][0]["emission_tex"] = 1;
  CHECK(scene_error(js) ==
        "scene.json: environments[0] (\"sky\").emission_tex: index 1 out of "
        "range (the scene has 1 texture)");
  js                              = base_scene();
  js["materials"][0]["color_tex"] = -2;
  CHECK(scene_error(js) ==
        "scene.json: materials[0] (\"floor\").color_tex: must be -1 (none) "
        "or a texture index, found -2");
  // Without the array, any reference is out of range.
  CHECK(scene_error(R"({"asset": {"version": "4.2"}, "sdfunctions": [
      {"type": "plane", "material": 0}]})") ==
        "scene.json: sdfunctions[0].material: index 0 out of range (the "
        "scene has 0 materials)");
}

TEST_CASE("scene_io errors: value ranges") {
  struct bad_value {
    std::string array;
    int         index;
    std::string key;
    double      value;
    std::string problem;
  };
  auto cases = std::vector<bad_value>{
      {"cameras", 0, "lens", 0, "must be > 0, found 0"},
      {"cameras", 0, "film", -0.036, "must be > 0, found -0.036"},
      {"cameras", 0, "aspect", 0, "must be > 0, found 0"},
      {"cameras", 0, "focus", -1, "must be > 0, found -1"},
      {"cameras", 0, "aperture", -0.1, "must be >= 0, found -0.1"},
      {"materials", 2, "roughness", 1.5, "must be in [0, 1], found 1.5"},
      {"materials", 2, "metallic", -0.5, "must be in [0, 1], found -0.5"},
      {"materials", 2, "opacity", 2, "must be in [0, 1], found 2"},
      {"materials", 2, "ior", 0, "must be > 0, found 0"},
      {"materials", 2, "trdepth", -1, "must be > 0, found -1"},
      {"materials", 2, "scanisotropy", 1, "must be in (-1, 1), found 1"},
      {"vol_instances", 0, "scale", 0, "must be > 0, found 0"},
  };
  for (auto& bad : cases) {
    auto js                           = base_scene();
    js[bad.array][bad.index][bad.key] = bad.value;
    auto name = js[bad.array][bad.index]["name"].get<std::string>();
    CHECK(scene_error(js) == "scene.json: " + bad.array + "[" +
                                 std::to_string(bad.index) + "] (\"" + name +
                                 "\")." + bad.key + ": " + bad.problem);
  }
  auto js                        = base_scene();
  js["materials"][1]["emission"] = {1, -1, 1};
  CHECK(scene_error(js) ==
        "scene.json: materials[1] (\"light\").emission: must be >= 0 in every "
        "component, found (1, -1, 1)");
  js                          = base_scene();
  js["materials"][2]["color"] = {0.1, 0.2, -0.3};
  CHECK(starts_with(scene_error(js),
      "scene.json: materials[2] (\"all\").color: must be >= 0"));
  js                                = base_scene();
  js["environments"][0]["emission"] = {-1, 0, 0};
  CHECK(starts_with(scene_error(js),
      "scene.json: environments[0] (\"sky\").emission: must be >= 0"));
}

TEST_CASE("scene_io errors: volumes and textures") {
  auto js = base_scene();
  js["volumes"][0].erase("binary");
  CHECK(scene_error(js) ==
        "scene.json: volumes[0] (\"sackboy\").binary: missing required key "
        "(false: SDFGen text, true: skanti binary)");
  js                         = base_scene();
  js["volumes"][0]["binary"] = "no";
  CHECK(scene_error(js) ==
        "scene.json: volumes[0] (\"sackboy\").binary: expected a boolean, "
        "found a string");
  // .vdb and .vol need no flag, upper case included.
  js                      = base_scene();
  js["volumes"][1]["uri"] = "grids/cloud.VOL";
  CHECK(parse_json_scene(js).volumes[1].uri == "grids/cloud.VOL");
  js = base_scene();
  js["volumes"][0].erase("uri");
  CHECK(scene_error(js) ==
        "scene.json: volumes[0] (\"sackboy\").uri: missing required key");
  js = base_scene();
  js["textures"][0].erase("uri");
  CHECK(scene_error(js) ==
        "scene.json: textures[0] (\"sky\").uri: missing required key");
  js                       = base_scene();
  js["textures"][0]["uri"] = "";
  CHECK(scene_error(js) ==
        "scene.json: textures[0] (\"sky\").uri: must not be empty");
}

TEST_CASE("scene_io large sdfunctions: long operand lists, deep nesting") {
  // Operand lists load in about linear time: 10x the operands may not take
  // more than 30x the time (a quadratic step takes 100x; the README has the
  // timings of 10,000 and 100,000).
  auto load_seconds = [](int count) {
    auto text = std::string{R"("sdfunctions": [{"name": "u", "type": "union",
        "material": 0, "operands": [)"};
    for (auto i = 0; i < count; i++)
      text +=
          std::string{i ? "," : ""} +
          R"({"type": "sphere", "radius": 0.1, "frame": [1,0,0,0,1,0,0,0,1,)" +
          std::to_string(i % 100) + "," + std::to_string(i / 100) + ",0]}";
    text += "]}]";
    auto start = std::chrono::steady_clock::now();
    auto scene = parse_text(small_scene(text));
    auto seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    REQUIRE(scene.sdfunctions.size() == 1);
    CHECK(scene.sdfunctions[0].program.nodes.size() == (size_t)count * 3 - 1);
    return seconds;
  };
  auto small = load_seconds(3000), large = load_seconds(30000);
  // Timings are reported, not asserted (bench_large measures the loader).
  MESSAGE("load seconds: 3,000 operands " << small << ", 30,000 " << large);
  // 10,000 nested levels are refused with the element's place, no crash.
  auto deep = std::string{R"({"name": "deep", "material": 0, )"};
  deep += R"("type": "round", "radius": 0.01, "operand": )";
  for (auto i = 1; i < 10000; i++)
    deep += R"({"type": "round", "radius": 0.01, "operand": )";
  deep += R"({"type": "sphere", "radius": 1})" + std::string(10000, '}');
  auto error = scene_error(small_scene(R"("sdfunctions": [)" + deep + "]"));
  CHECK(starts_with(error, "scene.json: sdfunctions[0].operand."));
  CHECK(error.find(": nested deeper than 256 levels") != std::string::npos);
}

// Walks the primitive table: each primitive loads by its JSON name with its
// parameters into its fields, and a missing parameter is reported by key.
TEST_CASE("scene_io primitive table: every primitive and parameter") {
  for (auto t = 0; t < (int)sdf_type::op_union; t++) {
    auto type = (sdf_type)t;
    auto name = sdf_type_names[t];
    CAPTURE(name);
    auto js        = nlohmann::json::object();
    js["type"]     = name;
    js["material"] = 0;
    auto expected  = sdf_node{};
    expected.type  = type;
    auto k         = 0;
    for (auto& param : primitive_params(type)) {
      // Values that pass every check: sizes above the other parameters.
      auto value = 0.25f + 0.125f * (float)k++;
      switch (param.field) {
        case sdf_param_field::size:
          expected.size = vec3f{1, 1.25f, 1.5f};
          js[param.key] = {1, 1.25f, 1.5f};
          break;
        case sdf_param_field::radius: expected.radius = value; break;
        case sdf_param_field::radius2: expected.radius2 = value; break;
        case sdf_param_field::height: expected.height = value; break;
        case sdf_param_field::thickness: expected.thickness = value; break;
      }
      if (param.field != sdf_param_field::size) js[param.key] = value;
    }
    auto sdf = parse_sdfunction_text(js.dump());
    REQUIRE(sdf.program.nodes.size() == 1);
    auto& node = sdf.program.nodes[0];
    CHECK(node.type == type);
    CHECK(node.size == expected.size);
    CHECK(node.radius == expected.radius);
    CHECK(node.radius2 == expected.radius2);
    CHECK(node.height == expected.height);
    CHECK(node.thickness == expected.thickness);
    for (auto& param : primitive_params(type)) {
      auto missing = js;
      missing.erase(param.key);
      CHECK(scene_error(
                small_scene(R"("sdfunctions": [)" + missing.dump() + "]")) ==
            "scene.json: sdfunctions[0]." + std::string{param.key} +
                ": missing required parameter");
    }
    // A key of no parameter is refused for this type.
    auto unknown       = js;
    unknown["unknown"] = 1;
    auto message =
        scene_error(small_scene(R"("sdfunctions": [)" + unknown.dump() + "]"));
    CHECK(message.find("sdfunctions[0].unknown: unknown key") !=
          std::string::npos);
  }
}
