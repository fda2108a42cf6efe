// # implicit: scene files (implementation)
//
// Yocto/GL 4.2 JSON plus the seed's `sdfunctions`, `volumes` and
// `vol_instances`. Unlike Yocto (missing keys keep defaults, wrong types are
// "parse error", unknown type strings map to the first enumerator), every key
// is checked: unknown keys, wrong types, bad values and out-of-range indices
// throw io_error naming the file, the element and the key. The whole JSON is
// validated before any grid or texture file is read, so a typo is reported at
// once, not after loading a large grid.
//
// `sdfunctions` by type. Seed types keep the seed's keys and meanings; all
// sizes and radii must be > 0 unless noted. The primitives' keys, fields and
// ranges are read from their table (sdf_primitive_table.h, sdf_primitives.h);
// this summary must agree with it.
//
//   type          JSON keys                              sdf_node fields
//   box           whd (full size, corner at origin)      size
//   bbox          whd (half sizes, centred), thickness   size, thickness
//   sphere        radius                                 radius
//   torus         r1 (ring), r2 (tube), axis y           radius, radius2
//   capped_cone   height (half), r1 (bottom), r2 (top)   height, radius,
//                 (r1, r2 >= 0, not both 0), axis y      radius2
//   plane         none (y = 0, normal +y)                -
//   capsule       height (half segment), radius, axis y  height, radius
//   cylinder      height (half), radius, axis y          height, radius
//   rounded_box   whd (half sizes), radius (<= min whd)  size, radius
//   ellipsoid     radii (semi-axes)                      size
//   octahedron    radius (centre to vertex)              radius
//
// Operators nest sdfunction objects (without `material`):
//
//   union, intersection, subtraction     operands (>= 2; folded left, so
//                                        subtraction removes 2.. from 1)
//   smooth_union, smooth_intersection,   operands, blend (> 0; unions and
//   smooth_subtraction                   intersections pair neighbours into
//                                        a balanced tree: fold_sdf_operands)
//   round                                operand, radius (> 0, added)
//   onion                                operand, thickness (> 0, half shell)
//   transform                            operand, frame or world_from_local
//
// Frames. `frame` maps the enclosing space into the object's local space: at
// the top level that is the seed's world->local convention (stored as
// local_from_world as is); on a nested object it becomes an op_transform
// node with child_from_parent = frame. `world_from_local` is the inverse
// (the intuitive way: the object's axes and origin in the enclosing space)
// and is stored inverted. An object may have one of the two, not both.
// Nested objects may carry a `name`, used only in error messages.

#include "scene_io.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "../image/image_io.h"
#include "../sdf/sdf_grid_io.h"
#include "../sdf/sdf_primitives.h"
#include "../util/error.h"
#include "../util/file.h"
#include "json_check.h"

namespace implicit {

// -----------------------------------------------------------------------------
// VALUE CHECKS
// -----------------------------------------------------------------------------

// Shortest readable form of a number for messages.
static std::string format_number(float value) {
  return format_param_value(value);
}

static std::string format_vec3(vec3f value) {
  return "(" + format_number(value.x) + ", " + format_number(value.y) + ", " +
         format_number(value.z) + ")";
}

// "1 texture", "3 textures".
static std::string count_of(size_t count, const std::string& noun) {
  return std::to_string(count) + " " + noun + (count == 1 ? "" : "s");
}

static void check_positive(
    const json_place& place, const std::string& key, float value) {
  if (!(value > 0))
    throw_json_error(place, key, "must be > 0, found " + format_number(value));
}

static void check_non_negative(
    const json_place& place, const std::string& key, float value) {
  if (!(value >= 0))
    throw_json_error(place, key, "must be >= 0, found " + format_number(value));
}

static void check_positive(
    const json_place& place, const std::string& key, vec3f value) {
  if (!(min(value) > 0))
    throw_json_error(place, key,
        "must be > 0 in every component, found " + format_vec3(value));
}

static void check_non_negative(
    const json_place& place, const std::string& key, vec3f value) {
  if (!(min(value) >= 0))
    throw_json_error(place, key,
        "must be >= 0 in every component, found " + format_vec3(value));
}

static void check_unit_range(
    const json_place& place, const std::string& key, float value) {
  if (!(value >= 0 && value <= 1))
    throw_json_error(
        place, key, "must be in [0, 1], found " + format_number(value));
}

// -----------------------------------------------------------------------------
// FRAMES AND REFERENCES
// -----------------------------------------------------------------------------

// Read a 12-number frame that must be invertible (the renderer inverts
// every frame it uses).
static bool read_invertible_frame(const json_place& place, const json& js,
    const std::string& key, frame3f& frame) {
  if (!read_json(place, js, key, frame)) return false;
  if (!is_invertible(frame))
    throw_json_error(place, key,
        "not invertible (its 3x3 part is singular); a frame is 12 numbers: "
        "x, y, z axes then origin");
  return true;
}

// Read `frame` (enclosing space -> local, the seed's convention) or
// `world_from_local` (local -> enclosing space, stored inverted) as the map
// from the enclosing space to the local one. False when neither is present.
static bool read_local_frame(
    const json_place& place, const json& js, frame3f& local_from_outer) {
  auto has_frame   = js.contains("frame");
  auto has_inverse = js.contains("world_from_local");
  if (has_frame && has_inverse)
    throw_json_error(place, "world_from_local",
        "conflicts with frame (give either frame, world->local, or "
        "world_from_local, local->world)");
  auto frame = frame3f{};
  if (has_frame) {
    read_invertible_frame(place, js, "frame", frame);
    local_from_outer = frame;
    return true;
  }
  if (has_inverse) {
    read_invertible_frame(place, js, "world_from_local", frame);
    local_from_outer = inverse(frame);
    return true;
  }
  return false;
}

// Read a reference to one of `count` elements of `array` (a 0-based index).
// Optional references may be absent or -1 (none).
static int read_reference(const json_place& place, const json& js,
    const std::string& key, size_t count, const std::string& array,
    bool required) {
  auto index = invalidid;
  if (!read_json(place, js, key, index)) {
    if (required) throw_json_error(place, key, "missing required key");
    return invalidid;
  }
  if (!required && index == invalidid) return invalidid;
  if (index < 0 || (size_t)index >= count)
    throw_json_error(place, key,
        "index " + std::to_string(index) + " out of range (the scene has " +
            count_of(count, array) + ")");
  return index;
}

// Read a material's texture slot. The seed scenes reference textures that do
// not exist (Yocto never checked), so an index past the end is dropped with
// a warning instead of failing the load.
static int read_material_texture(const json_place& place, const json& js,
    const std::string& key, size_t count, std::vector<std::string>& warnings) {
  auto index = invalidid;
  if (!read_json(place, js, key, index)) return invalidid;
  if (index == invalidid) return invalidid;
  if (index < 0)
    throw_json_error(place, key,
        "must be -1 (none) or a texture index, found " + std::to_string(index));
  if ((size_t)index >= count) {
    warnings.push_back(json_message(place, key,
        "texture " + std::to_string(index) + " does not exist (the scene has " +
            count_of(count, "texture") + "); ignored"));
    return invalidid;
  }
  return index;
}

// -----------------------------------------------------------------------------
// SDFUNCTIONS
// -----------------------------------------------------------------------------

// Evaluation recurses once per nesting level; a bound keeps hostile files
// from overflowing the stack.
static constexpr int max_sdf_depth = 64;

// JSON parameter keys of each type (see the table at the top; primitives
// list theirs in sdf_primitives.h).
static std::vector<std::string> sdf_parameter_keys(sdf_type type) {
  switch (type) {
    IMPLICIT_SDF_PRIMITIVE_CASES {
      auto keys = std::vector<std::string>{};
      for (auto& param : primitive_params(type)) keys.push_back(param.key);
      return keys;
    }
    case sdf_type::op_union:
    case sdf_type::op_intersection:
    case sdf_type::op_subtraction: return {"operands"};
    case sdf_type::op_smooth_union:
    case sdf_type::op_smooth_intersection:
    case sdf_type::op_smooth_subtraction: return {"operands", "blend"};
    case sdf_type::op_round: return {"operand", "radius"};
    case sdf_type::op_onion: return {"operand", "thickness"};
    case sdf_type::op_transform:
      return {"operand"};
      IMPLICIT_SDF_WARP_CASES
      IMPLICIT_SDF_MATH_CASES return {};
  }
  return {};
}

// A required parameter that must be > 0.
static float read_positive_parameter(
    const json_place& place, const json& js, const std::string& key) {
  auto value = 0.0f;
  read_json_required(place, js, key, value, "missing required parameter");
  check_positive(place, key, value);
  return value;
}

// A required parameter that must be >= 0.
static float read_non_negative_parameter(
    const json_place& place, const json& js, const std::string& key) {
  auto value = 0.0f;
  read_json_required(place, js, key, value, "missing required parameter");
  check_non_negative(place, key, value);
  return value;
}

// Read the parameters of a primitive node, in the order of its table entry,
// then check them together.
static void parse_primitive_params(
    const json_place& place, const json& js, sdf_node& node) {
  for (auto& param : primitive_params(node.type)) {
    auto positive = param.range == sdf_param_range::positive;
    auto read     = [&] {
      return positive ? read_positive_parameter(place, js, param.key)
                          : read_non_negative_parameter(place, js, param.key);
    };
    switch (param.field) {
      case sdf_param_field::size: {
        auto size = vec3f{};
        read_json_required(
            place, js, param.key, size, "missing required parameter");
        if (positive) {
          check_positive(place, param.key, size);
        } else {
          check_non_negative(place, param.key, size);
        }
        node.size = size;
        break;
      }
      case sdf_param_field::radius: node.radius = read(); break;
      case sdf_param_field::radius2: node.radius2 = read(); break;
      case sdf_param_field::height: node.height = read(); break;
      case sdf_param_field::thickness: node.thickness = read(); break;
    }
  }
  auto problem = check_primitive(node);
  if (problem.key) throw_json_error(place, problem.key, problem.problem);
}

static int parse_sdf_shape(const json_place& place, const json& js,
    sdf_program& program, int depth, const std::vector<std::string>& keys);

// Parse a nested sdfunction object; its own frame becomes a transform node.
static int parse_sdf_operand(
    const json_place& place, const json& js, sdf_program& program, int depth) {
  check_json_object(place, js);
  if (depth > max_sdf_depth)
    throw_json_error(place, "",
        "sdfunctions nested deeper than " + std::to_string(max_sdf_depth) +
            " levels");
  auto name = std::string{};
  read_json(place, js, "name", name);
  auto root = parse_sdf_shape(
      place, js, program, depth, {"name", "type", "frame", "world_from_local"});
  auto child_from_parent = frame3f{};
  if (read_local_frame(place, js, child_from_parent))
    root = add_transform(program, root, child_from_parent);
  return root;
}

// Parse the `operand` of a unary operator.
static int parse_sdf_unary_operand(
    const json_place& place, const json& js, sdf_program& program, int depth) {
  auto it = js.find("operand");
  if (it == js.end())
    throw_json_error(place, "operand", "missing required parameter");
  return parse_sdf_operand(
      json_child(place, "operand"), *it, program, depth + 1);
}

// Parse the `operands` of a binary operator and combine them with `op`
// (fold_sdf_operands: folded left, smooth unions and intersections
// balanced).
static int parse_sdf_operands(const json_place& place, const json& js,
    sdf_program& program, int depth, const sdf_node& op) {
  auto operands = find_json_array(place, js, "operands");
  if (!operands)
    throw_json_error(place, "operands", "missing required parameter");
  if (operands->size() < 2)
    throw_json_error(place, "operands",
        "expected at least 2 operands, found " +
            std::to_string(operands->size()));
  // Refuse a model whose nodes could not be indexed (or allocated) before
  // reading it: one node per operand and one per operator at least.
  if (program.nodes.size() + 2 * operands->size() > (size_t)sdf_max_nodes)
    throw_json_error(place, "operands",
        "too many operands: " + std::to_string(operands->size()) +
            " would make the model larger than " +
            std::to_string(sdf_max_nodes) + " nodes");
  auto operands_place = json_child(place, "operands");
  auto operand_place  = [&](size_t i) {
    return json_element(operands_place, i, (*operands)[i]);
  };
  auto roots = std::vector<int>{};
  roots.reserve(operands->size());
  for (size_t i = 0; i < operands->size(); i++)
    roots.push_back(parse_sdf_operand(
        operand_place(i), (*operands)[i], program, depth + 1));
  return fold_sdf_operands(program, roots, op);
}

// Parse the type, parameters and operands of an sdfunction object (not its
// frame) into `program`, operands first; returns the root node. `keys` are
// the keys allowed besides the type's parameters.
static int parse_sdf_shape(const json_place& place, const json& js,
    sdf_program& program, int depth, const std::vector<std::string>& keys) {
  auto type_name = std::string{};
  read_json_required(place, js, "type", type_name);
  auto type =
      (sdf_type)parse_json_enum(place, "type", type_name, sdf_type_names);
  auto valid = keys;
  for (auto& key : sdf_parameter_keys(type)) valid.push_back(key);
  check_json_keys(place, js, valid, " for type \"" + type_name + "\"");

  auto node = sdf_node{};
  node.type = type;
  switch (type) {
    IMPLICIT_SDF_PRIMITIVE_CASES
    parse_primitive_params(place, js, node);
    break;
    case sdf_type::op_union:
    case sdf_type::op_intersection:
    case sdf_type::op_subtraction:
      return parse_sdf_operands(place, js, program, depth, node);
    case sdf_type::op_smooth_union:
    case sdf_type::op_smooth_intersection:
    case sdf_type::op_smooth_subtraction:
      node.blend = read_positive_parameter(place, js, "blend");
      return parse_sdf_operands(place, js, program, depth, node);
    case sdf_type::op_round:
      node.radius = read_positive_parameter(place, js, "radius");
      node.left   = parse_sdf_unary_operand(place, js, program, depth);
      break;
    case sdf_type::op_onion:
      node.thickness = read_positive_parameter(place, js, "thickness");
      node.left      = parse_sdf_unary_operand(place, js, program, depth);
      break;
    case sdf_type::op_transform:
      // The caller turns the frame into a transform (or local_from_world).
      if (!js.contains("frame") && !js.contains("world_from_local"))
        throw_json_error(place, "frame",
            "missing required key (a transform needs frame or "
            "world_from_local)");
      return parse_sdf_unary_operand(place, js, program, depth);
      IMPLICIT_SDF_WARP_CASES
      IMPLICIT_SDF_MATH_CASES
      throw_json_error(
          place, "type", "\"" + type_name + "\" is not supported yet");
  }
  return add_node(program, node);
}

// Parse one element of `sdfunctions`.
static sdf_function_data parse_sdfunction(
    const json_place& place, const json& js, size_t num_materials) {
  auto sdf = sdf_function_data{};
  read_json(place, js, "name", sdf.name);
  parse_sdf_shape(place, js, sdf.program, 0,
      {"name", "type", "material", "frame", "world_from_local"});
  read_local_frame(place, js, sdf.local_from_world);
  sdf.material =
      read_reference(place, js, "material", num_materials, "material", true);
  return sdf;
}

// -----------------------------------------------------------------------------
// YOCTO/GL ELEMENTS
// -----------------------------------------------------------------------------

// Parse the `asset` object: only the versions with the v4.2 layout.
static void parse_asset(
    const json_place& top, const json& js, scene_data& scene) {
  auto it = js.find("asset");
  if (it == js.end())
    throw_json_error(
        top, "asset", "missing required object (e.g. {\"version\": \"4.2\"})");
  auto place = json_child(top, "asset");
  check_json_object(place, *it);
  check_json_keys(place, *it, {"version", "copyright", "generator"});
  auto version = std::string{};
  read_json_required(place, *it, "version", version);
  if (version != "4.2" && version != "5.0")
    throw_json_error(place, "version",
        "unsupported version \"" + version +
            "\" (accepted versions: \"4.2\", \"5.0\")");
  read_json(place, *it, "copyright", scene.copyright);
  auto generator = std::string{};
  read_json(place, *it, "generator", generator);
}

static camera_data parse_camera(const json_place& place, const json& js) {
  check_json_keys(place, js,
      {"name", "frame", "orthographic", "lens", "film", "aspect", "focus",
          "aperture"});
  auto camera = camera_data{};
  read_json(place, js, "name", camera.name);
  read_invertible_frame(place, js, "frame", camera.frame);
  read_json(place, js, "orthographic", camera.orthographic);
  read_json(place, js, "lens", camera.lens);
  check_positive(place, "lens", camera.lens);
  read_json(place, js, "film", camera.film);
  check_positive(place, "film", camera.film);
  read_json(place, js, "aspect", camera.aspect);
  check_positive(place, "aspect", camera.aspect);
  read_json(place, js, "focus", camera.focus);
  check_positive(place, "focus", camera.focus);
  read_json(place, js, "aperture", camera.aperture);
  check_non_negative(place, "aperture", camera.aperture);
  return camera;
}

static texture_data parse_texture(const json_place& place, const json& js) {
  check_json_keys(place, js, {"name", "uri"});
  auto texture = texture_data{};
  read_json(place, js, "name", texture.name);
  read_json_required(place, js, "uri", texture.uri);
  if (texture.uri.empty()) throw_json_error(place, "uri", "must not be empty");
  return texture;
}

static material_data parse_material(const json_place& place, const json& js,
    size_t num_textures, std::vector<std::string>& warnings) {
  check_json_keys(place, js,
      {"name", "type", "emission", "color", "metallic", "roughness", "ior",
          "trdepth", "scattering", "scanisotropy", "opacity", "emission_tex",
          "color_tex", "roughness_tex", "scattering_tex", "normal_tex"});
  auto material = material_data{};
  read_json(place, js, "name", material.name);
  auto type_name = std::string{};
  if (read_json(place, js, "type", type_name))
    material.type = (material_type)parse_json_enum(
        place, "type", type_name, material_type_names);
  read_json(place, js, "emission", material.emission);
  check_non_negative(place, "emission", material.emission);
  read_json(place, js, "color", material.color);
  check_non_negative(place, "color", material.color);
  read_json(place, js, "metallic", material.metallic);
  check_unit_range(place, "metallic", material.metallic);
  read_json(place, js, "roughness", material.roughness);
  check_unit_range(place, "roughness", material.roughness);
  read_json(place, js, "ior", material.ior);
  check_positive(place, "ior", material.ior);
  read_json(place, js, "trdepth", material.trdepth);
  check_positive(place, "trdepth", material.trdepth);
  read_json(place, js, "scattering", material.scattering);
  check_non_negative(place, "scattering", material.scattering);
  // Henyey-Greenstein's pdf is infinite at |g| = 1.
  read_json(place, js, "scanisotropy", material.scanisotropy);
  if (!(std::abs(material.scanisotropy) < 1))
    throw_json_error(place, "scanisotropy",
        "must be in (-1, 1), found " + format_number(material.scanisotropy));
  read_json(place, js, "opacity", material.opacity);
  check_unit_range(place, "opacity", material.opacity);
  material.emission_tex =
      read_material_texture(place, js, "emission_tex", num_textures, warnings);
  material.color_tex =
      read_material_texture(place, js, "color_tex", num_textures, warnings);
  material.roughness_tex =
      read_material_texture(place, js, "roughness_tex", num_textures, warnings);
  material.scattering_tex = read_material_texture(
      place, js, "scattering_tex", num_textures, warnings);
  material.normal_tex =
      read_material_texture(place, js, "normal_tex", num_textures, warnings);
  return material;
}

static environment_data parse_environment(
    const json_place& place, const json& js, size_t num_textures) {
  check_json_keys(place, js, {"name", "frame", "emission", "emission_tex"});
  auto environment = environment_data{};
  read_json(place, js, "name", environment.name);
  read_invertible_frame(place, js, "frame", environment.frame);
  read_json(place, js, "emission", environment.emission);
  check_non_negative(place, "emission", environment.emission);
  environment.emission_tex =
      read_reference(place, js, "emission_tex", num_textures, "texture", false);
  return environment;
}

// -----------------------------------------------------------------------------
// GRIDS
// -----------------------------------------------------------------------------

// Lower-case extension with the dot, e.g. ".vdb".
static std::string lower_extension(const std::string& uri) {
  auto extension = std::filesystem::path(uri).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
      [](unsigned char c) { return (char)std::tolower(c); });
  return extension;
}

// Parse one volume; `binary` receives the seed's format flag.
static volume_data parse_volume(
    const json_place& place, const json& js, bool& binary) {
  check_json_keys(place, js, {"name", "uri", "binary"});
  auto volume = volume_data{};
  read_json(place, js, "name", volume.name);
  read_json_required(place, js, "uri", volume.uri);
  if (volume.uri.empty()) throw_json_error(place, "uri", "must not be empty");
  // .sdf files come in two formats that only this flag tells apart.
  auto extension = lower_extension(volume.uri);
  binary         = false;
  if (extension == ".vdb" || extension == ".vol") {
    read_json(place, js, "binary", binary);
  } else {
    read_json_required(place, js, "binary", binary,
        "missing required key (false: SDFGen text, true: skanti binary)");
  }
  return volume;
}

static vol_instance_data parse_vol_instance(const json_place& place,
    const json& js, size_t num_volumes, size_t num_materials) {
  check_json_keys(place, js,
      {"name", "volume", "material", "scale", "frame", "world_from_local"});
  auto instance = vol_instance_data{};
  read_json(place, js, "name", instance.name);
  instance.volume =
      read_reference(place, js, "volume", num_volumes, "volume", true);
  instance.material =
      read_reference(place, js, "material", num_materials, "material", true);
  read_json(place, js, "scale", instance.scale);
  check_positive(place, "scale", instance.scale);
  read_local_frame(place, js, instance.local_from_world);
  return instance;
}

// -----------------------------------------------------------------------------
// SCENE
// -----------------------------------------------------------------------------

// Call `parse(place, element)` for each element of the array `key`, after
// checking that each element is an object.
template <typename Parse>
static void parse_array(const json_place& top, const json& js,
    const std::string& key, Parse&& parse) {
  auto array = find_json_array(top, js, key);
  if (!array) return;
  auto place = json_child(top, key);
  for (size_t i = 0; i < array->size(); i++) {
    auto& element       = (*array)[i];
    auto  element_place = json_element(place, i, element);
    check_json_object(element_place, element);
    parse(element_place, element);
  }
}

// Number of elements of the array `key` (0 when absent), for index checks.
static size_t array_size(
    const json_place& top, const json& js, const std::string& key) {
  auto array = find_json_array(top, js, key);
  return array ? array->size() : 0;
}

// Check the top-level keys; mesh arrays get a message of their own.
static void check_scene_keys(const json_place& top, const json& js) {
  auto valid = std::vector<std::string>{"asset", "cameras", "textures",
      "materials", "environments", "sdfunctions", "volumes", "vol_instances"};
  for (auto& item : js.items()) {
    auto& key = item.key();
    if (key == "shapes" || key == "instances" || key == "subdivs")
      throw_json_error(top, key,
          "meshes are not supported: implicit renders implicit surfaces only "
          "(use sdfunctions, or volumes and vol_instances)");
  }
  check_json_keys(top, js, valid);
}

scene_data parse_scene(const std::string& text, const std::string& filename,
    std::vector<std::string>& warnings, bool load_files) {
  auto js  = parse_json(text, filename);
  auto top = json_place{filename, ""};
  if (!js.is_object())
    throw_json_error(
        top, "", "expected a JSON object, found " + json_type_name(js));
  check_scene_keys(top, js);

  auto scene = scene_data{};
  parse_asset(top, js, scene);
  // References are checked against the array sizes, so the order of the
  // arrays in the file does not matter.
  auto num_textures  = array_size(top, js, "textures");
  auto num_materials = array_size(top, js, "materials");
  auto num_volumes   = array_size(top, js, "volumes");
  parse_array(
      top, js, "cameras", [&](const json_place& place, const json& element) {
        scene.cameras.push_back(parse_camera(place, element));
      });
  auto texture_places = std::vector<json_place>{};
  parse_array(
      top, js, "textures", [&](const json_place& place, const json& element) {
        scene.textures.push_back(parse_texture(place, element));
        texture_places.push_back(place);
      });
  parse_array(
      top, js, "materials", [&](const json_place& place, const json& element) {
        scene.materials.push_back(
            parse_material(place, element, num_textures, warnings));
      });
  parse_array(top, js, "environments",
      [&](const json_place& place, const json& element) {
        scene.environments.push_back(
            parse_environment(place, element, num_textures));
      });
  auto volume_places = std::vector<json_place>{};
  auto volume_binary = std::vector<bool>{};
  parse_array(
      top, js, "volumes", [&](const json_place& place, const json& element) {
        auto binary = false;
        scene.volumes.push_back(parse_volume(place, element, binary));
        volume_places.push_back(place);
        volume_binary.push_back(binary);
      });
  parse_array(top, js, "vol_instances",
      [&](const json_place& place, const json& element) {
        scene.vol_instances.push_back(
            parse_vol_instance(place, element, num_volumes, num_materials));
      });
  parse_array(top, js, "sdfunctions",
      [&](const json_place& place, const json& element) {
        scene.sdfunctions.push_back(
            parse_sdfunction(place, element, num_materials));
      });
  if (!load_files) return scene;

  // Files last, relative to the scene's directory, loaded in parallel (each
  // into its own element). Their errors are wrapped with the element and key
  // that named them; the first one in the file's order is reported.
  // Textures start first: a sky decodes to many times its file's size.
  auto directory = std::filesystem::path(filename).parent_path();
  auto volumes   = scene.volumes.size();
  auto count     = volumes + scene.textures.size();
  auto errors    = std::vector<std::string>(count);
  auto failed    = std::vector<char>(count, 0);
  tbb::parallel_for(size_t{0}, count, [&](size_t order) {
    auto k = (order + volumes) % count;  // textures, then volumes
    try {
      if (k < volumes) {
        auto& volume = scene.volumes[k];
        auto  format = grid_format_from_uri(volume.uri, volume_binary[k]);
        volume.grid  = std::make_shared<const grid_data>(
            load_grid((directory / volume.uri).string(), format));
      } else {
        auto& texture = scene.textures[k - volumes];
        texture.image = load_image((directory / texture.uri).string());
      }
    } catch (const io_error& error) {
      errors[k] = error.what();
      failed[k] = 1;
    }
  });
  for (size_t k = 0; k < count; k++) {
    if (!failed[k]) continue;
    throw_json_error(
        k < volumes ? volume_places[k] : texture_places[k - volumes], "uri",
        errors[k]);
  }
  return scene;
}

scene_data parse_scene(const std::string& text, const std::string& filename) {
  auto warnings = std::vector<std::string>{};
  return parse_scene(text, filename, warnings);
}

scene_data load_scene(
    const std::string& filename, std::vector<std::string>& warnings) {
  return parse_scene(read_file(filename), filename, warnings);
}

scene_data load_scene(const std::string& filename) {
  auto warnings = std::vector<std::string>{};
  return load_scene(filename, warnings);
}

}  // namespace implicit
