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
// Operators nest sdfunction objects (without `material`); their keys, ranges
// and fields are read from their table (sdf_operator_table.h):
//
//   union, intersection, subtraction     operands (>= 2; folded left, so
//                                        subtraction removes 2.. from 1)
//   smooth_union, smooth_intersection,   operands, blend (> 0; a union is
//   smooth_subtraction                   one group of any order,
//                                        intersections pair neighbours into
//                                        a balanced tree: fold_sdf_operands)
//   round                                operand, radius (> 0, added)
//   onion                                operand, thickness (> 0, half shell)
//   transform                            operand, frame or world_from_local
//   twist                                operand, k (radians per unit of y)
//   bend                                 operand, k (radians per unit of x)
//   repeat                               operand, spacing ([3] >= 0, one
//                                        > 0; 0: not repeated on that axis),
//                                        limit ([3] integers >= 0, copies
//                                        each side; absent: endless)
//   elongate                             operand, h ([3] >= 0)
//   mirror                               operand, axes ("x", "xz", ...)
//   expression                           expression (infix, sdf_expression.h)
//                                        or uri (a .vm file, sdf_vm_io.h,
//                                        relative to the scene); operands
//                                        (named objects the formula uses);
//                                        bounds ([[x0,y0,z0],[x1,y1,z1]]:
//                                        the surface is clipped to the box)
//   displace                             operand, expression (added to it)
//
// Math clauses are no types: "add" is refused and "round" is the CSG
// rounding. `.vm` files are read while the sdfunction is parsed (they define
// its nodes), grids and textures after the whole JSON is checked. Objects
// are walked with an explicit stack (scene_io_sdf.cpp): nesting is bounded
// only by the JSON parser's max_json_depth (json_check.h).
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
#include "../sdf/sdf_zero_bounds.h"
#include "../util/error.h"
#include "../util/file.h"
#include "json_check.h"
#include "scene_io_sdf.h"

namespace implicit {

// -----------------------------------------------------------------------------
// REFERENCES
// -----------------------------------------------------------------------------

// "1 texture", "3 textures".
static std::string count_of(size_t count, const std::string& noun) {
  return std::to_string(count) + " " + noun + (count == 1 ? "" : "s");
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

// Parse one element of `sdfunctions` (its objects: scene_io_sdf.cpp).
static sdf_function_data parse_sdfunction(const json_place& place,
    const json& js, size_t num_materials, const sdf_file_context& files) {
  auto sdf = sdf_function_data{};
  read_json(place, js, "name", sdf.name);
  parse_sdf_object(place, js, sdf.program, files, sdf.uris);
  // A function that is no distance bound needs a box for tracing: one it
  // gives, or one of its zero set; an unbounded one is refused here, where
  // the file and the element can be named.
  if (files.check_bounds) {
    auto unbounded = false;
    sdf_surface_bounds(sdf.program, unbounded);
    if (unbounded) throw_json_error(place, "", unbounded_surface_message);
  }
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

// Check a material number against its key's range.
static void check_material_range(const json_place& place,
    const std::string& key, material_key_range range, float value) {
  switch (range) {
    case material_key_range::any: break;
    case material_key_range::non_negative:
      check_non_negative(place, key, value);
      break;
    case material_key_range::positive: check_positive(place, key, value); break;
    case material_key_range::unit: check_unit_range(place, key, value); break;
    case material_key_range::open_symmetric:
      if (!(std::abs(value) < 1))
        throw_json_error(
            place, key, "must be in (-1, 1), found " + format_number(value));
      break;
  }
}

// Colours: every component (the table gives them no other range).
static void check_material_range(const json_place& place,
    const std::string& key, material_key_range range, vec3f value) {
  if (range == material_key_range::non_negative)
    check_non_negative(place, key, value);
  if (range == material_key_range::positive) check_positive(place, key, value);
}

static material_data parse_material(const json_place& place, const json& js,
    size_t num_textures, std::vector<std::string>& warnings) {
  auto keys = std::vector<std::string>{"name", "type"};
  for (auto& key : material_keys) keys.push_back(key.name);
  check_json_keys(place, js, keys);
  auto material = material_data{};
  read_json(place, js, "name", material.name);
  auto type_name = std::string{};
  if (read_json(place, js, "type", type_name))
    material.type = (material_type)parse_json_enum(
        place, "type", type_name, material_type_names);
  for (auto& key : material_keys) {
    switch (key.kind) {
      case material_key_kind::color:
        read_json(place, js, key.name, material.*key.color);
        check_material_range(place, key.name, key.range, material.*key.color);
        break;
      case material_key_kind::number:
        read_json(place, js, key.name, material.*key.number);
        check_material_range(place, key.name, key.range, material.*key.number);
        break;
      case material_key_kind::texture:
        material.*key.texture =
            read_material_texture(place, js, key.name, num_textures, warnings);
        break;
    }
  }
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

// Where the elements that name files were read, to report their errors.
struct scene_file_places {
  std::vector<json_place> textures      = {};
  std::vector<json_place> volumes       = {};
  std::vector<bool>       volume_binary = {};  // a binary grid format
};

// Load the volumes' grids and the textures' images, relative to the scene's
// directory, in parallel (each into its own element). Their errors are
// wrapped with the element and key that named them; the first one in the
// file's order is reported. Textures start first: a sky decodes to many
// times its file's size.
static void load_scene_files(scene_data& scene, const std::string& filename,
    const scene_file_places& places) {
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
        auto format = grid_format_from_uri(volume.uri, places.volume_binary[k]);
        volume.grid = std::make_shared<const grid_data>(
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
        k < volumes ? places.volumes[k] : places.textures[k - volumes], "uri",
        errors[k]);
  }
}

scene_data parse_scene(const std::string& text, const std::string& filename,
    std::vector<std::string>& warnings, bool load_files, bool check_bounds) {
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
  auto places        = scene_file_places{};
  parse_array(
      top, js, "cameras", [&](const json_place& place, const json& element) {
        scene.cameras.push_back(parse_camera(place, element));
      });
  parse_array(
      top, js, "textures", [&](const json_place& place, const json& element) {
        scene.textures.push_back(parse_texture(place, element));
        places.textures.push_back(place);
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
  parse_array(
      top, js, "volumes", [&](const json_place& place, const json& element) {
        auto binary = false;
        scene.volumes.push_back(parse_volume(place, element, binary));
        places.volumes.push_back(place);
        places.volume_binary.push_back(binary);
      });
  parse_array(top, js, "vol_instances",
      [&](const json_place& place, const json& element) {
        scene.vol_instances.push_back(
            parse_vol_instance(place, element, num_volumes, num_materials));
      });
  // `.vm` files are read with their sdfunction: they define its nodes.
  auto files         = sdf_file_context{};
  files.directory    = std::filesystem::path(filename).parent_path().string();
  files.load_files   = load_files;
  files.check_bounds = load_files && check_bounds;
  parse_array(top, js, "sdfunctions",
      [&](const json_place& place, const json& element) {
        scene.sdfunctions.push_back(
            parse_sdfunction(place, element, num_materials, files));
      });
  // Files last, once every element is known to be well formed.
  if (load_files) load_scene_files(scene, filename, places);
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
