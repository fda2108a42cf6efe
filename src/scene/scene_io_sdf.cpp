// # implicit: sdfunction objects in scene files (implementation)
//
// An sdfunction object and its operands are read by a post-order walk with
// an explicit stack: an object is started (type, keys and parameters
// checked, its operands listed), its operands are walked one after another,
// then it is finished into nodes over their roots. Operands therefore come
// before their users in the program, as the tape needs, and a deep file
// costs heap, never call stack.

#include "scene_io_sdf.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "../sdf/sdf_expression.h"
#include "../sdf/sdf_operator_table.h"
#include "../sdf/sdf_primitives.h"
#include "../sdf/sdf_vm_io.h"
#include "../util/error.h"
#include "scene_io.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

// A required primitive parameter that must be > 0 (or >= 0).
static float read_primitive_param(const json_place& place, const json& js,
    const std::string& key, bool positive) {
  auto value = 0.0f;
  read_json_required(place, js, key, value, "missing required parameter");
  if (positive) {
    check_positive(place, key, value);
  } else {
    check_non_negative(place, key, value);
  }
  return value;
}

// Read the parameters of a primitive node, in the order of its table entry,
// then check them together.
static void parse_primitive_params(
    const json_place& place, const json& js, sdf_node& node) {
  for (auto& param : primitive_params(node.type)) {
    auto positive = param.range == sdf_param_range::positive;
    auto read     = [&] {
      return read_primitive_param(place, js, param.key, positive);
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

static void check_range(const json_place& place, const std::string& key,
    sdf_key_range range, float value) {
  switch (range) {
    case sdf_key_range::any: break;
    case sdf_key_range::positive: check_positive(place, key, value); break;
    case sdf_key_range::non_negative:
      check_non_negative(place, key, value);
      break;
  }
}

static void check_range(const json_place& place, const std::string& key,
    sdf_key_range range, vec3f value) {
  switch (range) {
    case sdf_key_range::any: break;
    case sdf_key_range::positive: check_positive(place, key, value); break;
    case sdf_key_range::non_negative:
      check_non_negative(place, key, value);
      break;
  }
}

// An array of 3 integers (each one read as read_json() reads an int).
static vec3i read_counts(const json_place& place, const json& js,
    const std::string& key, sdf_key_range range) {
  auto& value = js.at(key);
  if (!value.is_array() || value.size() != 3)
    throw_json_error(place, key,
        "expected an array of 3 integers, found " +
            (value.is_array() ? std::to_string(value.size()) + " values"
                              : json_type_name(value)));
  int counts[3];
  for (auto i = 0; i < 3; i++) {
    auto name    = key + "[" + std::to_string(i) + "]";
    auto element = json{{name, value[i]}};
    read_json(place, element, name, counts[i]);
    if (range != sdf_key_range::any && counts[i] < 0)
      throw_json_error(
          place, name, "must be >= 0, found " + std::to_string(counts[i]));
  }
  return {counts[0], counts[1], counts[2]};
}

// A string of distinct axis letters as bits (x 1, y 2, z 4).
static int read_axes(
    const json_place& place, const json& js, const std::string& key) {
  auto text = std::string{};
  read_json(place, js, key, text);
  auto bits = 0;
  for (auto c : text) {
    auto bit = c == 'x' ? 1 : c == 'y' ? 2 : c == 'z' ? 4 : 0;
    if (!bit)
      throw_json_error(place, key,
          "expected letters among x, y, z (e.g. \"xz\"), found \"" + text +
              "\"");
    if (bits & bit)
      throw_json_error(place, key,
          "\"" + std::string(1, c) + "\" is given twice in \"" + text + "\"");
    bits |= bit;
  }
  if (!bits)
    throw_json_error(place, key, "must name at least one axis (e.g. \"x\")");
  return bits;
}

// [[x0, y0, z0], [x1, y1, z1]] with each minimum below its maximum.
static bbox3f read_box(
    const json_place& place, const json& js, const std::string& key) {
  auto& value = js.at(key);
  if (!value.is_array() || value.size() != 2)
    throw_json_error(place, key,
        "expected [[x0, y0, z0], [x1, y1, z1]], found " +
            (value.is_array() ? std::to_string(value.size()) + " values"
                              : json_type_name(value)));
  auto corners = json{{key + "[0]", value[0]}, {key + "[1]", value[1]}};
  auto box     = bbox3f{};
  read_json(place, corners, key + "[0]", box.min);
  read_json(place, corners, key + "[1]", box.max);
  if (!(box.min.x < box.max.x && box.min.y < box.max.y &&
          box.min.z < box.max.z))
    throw_json_error(place, key,
        "each minimum must be below its maximum, found [" +
            format_number(box.min.x) + ", " + format_number(box.min.y) + ", " +
            format_number(box.min.z) + "] and [" + format_number(box.max.x) +
            ", " + format_number(box.max.y) + ", " + format_number(box.max.z) +
            "]");
  return box;
}

// A string that must not be empty.
static std::string read_text(
    const json_place& place, const json& js, const std::string& key) {
  auto text = std::string{};
  read_json(place, js, key, text);
  if (text.empty()) throw_json_error(place, key, "must not be empty");
  return text;
}

// Read an operator key whose value fills a node field.
static void read_operator_value(const json_place& place, const json& js,
    const sdf_operator_key& key, sdf_node& node) {
  auto number = 0.0f;
  auto vector = vec3f{};
  switch (key.type) {
    case sdf_key_type::number:
      read_json(place, js, key.key, number);
      check_range(place, key.key, key.range, number);
      break;
    case sdf_key_type::vec3:
      read_json(place, js, key.key, vector);
      check_range(place, key.key, key.range, vector);
      break;
    case sdf_key_type::counts:
      node.count = read_counts(place, js, key.key, key.range);
      return;
    case sdf_key_type::axes: node.axes = read_axes(place, js, key.key); return;
    case sdf_key_type::expression:
    case sdf_key_type::uri: read_text(place, js, key.key); return;
    case sdf_key_type::box: read_box(place, js, key.key); return;
    case sdf_key_type::operand:
    case sdf_key_type::operand_list:
    case sdf_key_type::operand_map: return;
  }
  switch (key.field) {
    case sdf_key_field::blend: node.blend = number; break;
    case sdf_key_field::radius: node.radius = number; break;
    case sdf_key_field::thickness: node.thickness = number; break;
    case sdf_key_field::value: node.value = number; break;
    case sdf_key_field::size: node.size = vector; break;
    case sdf_key_field::none:
    case sdf_key_field::count:
    case sdf_key_field::axes: break;
  }
}

// -----------------------------------------------------------------------------
// THE WALK
// -----------------------------------------------------------------------------

namespace {

// One sdfunction object on the walk's stack.
struct sdf_walk_object {
  const json*              js       = nullptr;
  json_place               place    = {};
  const sdf_operator*      op       = nullptr;  // null: a primitive
  sdf_node                 node     = {};
  std::string              key      = "";  // the key holding the operands
  std::vector<const json*> children = {};
  std::vector<std::string> names    = {};  // operand maps: their names
  std::vector<int>         roots    = {};  // the operands' roots, in order
};

struct sdf_walk {
  sdf_program&              program;
  const sdf_file_context&   files;
  std::vector<std::string>& uris;

  sdf_walk_object start(const json& js, const json_place& place, bool top);
  void            list_operands(
                 sdf_walk_object& object, const char* key, sdf_key_type type);
  json_place child_place(const sdf_walk_object& object, size_t i) const;
  int        finish(sdf_walk_object& object, bool top);
  int        finish_expression(sdf_walk_object& object);
  int        run(const json& js, const json_place& place);
};

// Check an object's type and keys, read its parameters and list its
// operands.
sdf_walk_object sdf_walk::start(
    const json& js, const json_place& place, bool top) {
  check_json_object(place, js);
  auto object  = sdf_walk_object{&js, place};
  auto name    = std::string{};
  auto type    = std::string{};
  auto is_type = [&](int i) { return sdf_type_names[i] == type; };
  read_json(place, js, "name", name);
  read_json_required(place, js, "type", type);
  auto valid = std::vector<std::string>{"name", "type"};
  if (top) valid.push_back("material");
  valid.insert(valid.end(), {"frame", "world_from_local"});
  object.op = find_sdf_operator(type);
  if (!object.op) {
    auto index = 0;
    while (index < (int)sdf_type::op_union && !is_type(index)) index++;
    if (index == (int)sdf_type::op_union)
      parse_json_enum(place, "type", type, sdf_json_type_names());
    object.node.type = (sdf_type)index;
    for (auto& param : primitive_params(object.node.type))
      valid.push_back(param.key);
    check_json_keys(place, js, valid, " for type \"" + type + "\"");
    parse_primitive_params(place, js, object.node);
    return object;
  }
  for (auto& key : object.op->keys) valid.push_back(key.key);
  check_json_keys(place, js, valid, " for type \"" + type + "\"");
  object.node.type = object.op->type;
  for (auto& key : object.op->keys) {
    if (!js.contains(key.key)) {
      if (key.required)
        throw_json_error(place, key.key, "missing required parameter");
      continue;
    }
    read_operator_value(place, js, key, object.node);
    list_operands(object, key.key, key.type);
  }
  auto build = object.op->build;
  if (build == sdf_operator_build::transform && !js.contains("frame") &&
      !js.contains("world_from_local"))
    throw_json_error(place, "frame",
        "missing required key (a transform needs frame or "
        "world_from_local)");
  if (build == sdf_operator_build::expression &&
      js.contains("expression") == js.contains("uri"))
    throw_json_error(place, js.contains("uri") ? "uri" : "expression",
        js.contains("uri") ? "conflicts with expression (give one of the two)"
                           : "missing required parameter (or give uri, a "
                             ".vm file)");
  if (build == sdf_operator_build::expression && js.contains("uri") &&
      js.contains("operands"))
    throw_json_error(place, "operands",
        "only an infix expression names operands (a .vm file has none)");
  if (object.node.type == sdf_type::op_repeat && max(object.node.size) <= 0)
    throw_json_error(place, "spacing",
        "must be > 0 on at least one axis (0: no repetition along it)");
  return object;
}

// List the operands under `key` (pointers into the JSON).
void sdf_walk::list_operands(
    sdf_walk_object& object, const char* key, sdf_key_type type) {
  auto& js    = *object.js;
  auto& place = object.place;
  if (type == sdf_key_type::operand) {
    object.key = key;
    object.children.push_back(&js.at(key));
  } else if (type == sdf_key_type::operand_list) {
    auto list = find_json_array(place, js, key);
    if (list->size() < 2)
      throw_json_error(place, key,
          "expected at least 2 operands, found " +
              std::to_string(list->size()));
    // Refuse a model whose nodes could not be indexed (or allocated) before
    // reading it: one node per operand and one per operator at least.
    if (program.nodes.size() + 2 * list->size() > (size_t)sdf_max_nodes)
      throw_json_error(place, key,
          "too many operands: " + std::to_string(list->size()) +
              " would make the model larger than " +
              std::to_string(sdf_max_nodes) + " nodes");
    object.key = key;
    for (auto& element : *list) object.children.push_back(&element);
  } else if (type == sdf_key_type::operand_map) {
    auto& map = js.at(key);
    if (!map.is_object())
      throw_json_error(
          place, key, "expected an object, found " + json_type_name(map));
    object.key = key;
    for (auto& item : map.items()) {
      if (!is_expression_operand_name(item.key()))
        throw_json_error(json_child(place, key), item.key(),
            "not an operand name (letters, digits and _, not first a digit; "
            "not x, y, z, pi or a function)");
      object.names.push_back(item.key());
      object.children.push_back(&item.value());
    }
  }
}

// The place of operand `i`: key, key[i] ("name") or key.name.
json_place sdf_walk::child_place(
    const sdf_walk_object& object, size_t i) const {
  auto place = json_child(object.place, object.key);
  if (!object.names.empty()) return json_child(place, object.names[i]);
  if (object.js->at(object.key).is_array())
    return json_element(place, i, *object.children[i]);
  return place;
}

// The nodes of an object whose operands are done; returns its root.
int sdf_walk::finish(sdf_walk_object& object, bool top) {
  auto root = invalidid;
  if (!object.op) {
    root = add_node(program, object.node);
  } else {
    switch (object.op->build) {
      case sdf_operator_build::fold:
        root = fold_sdf_operands(program, object.roots, object.node);
        break;
      case sdf_operator_build::unary:
        object.node.left = object.roots[0];
        root             = add_node(program, object.node);
        break;
      case sdf_operator_build::transform: root = object.roots[0]; break;
      case sdf_operator_build::expression:
        root = finish_expression(object);
        break;
      case sdf_operator_build::displace: {
        auto text         = object.js->at("expression").get<std::string>();
        auto displacement = invalidid;
        try {
          displacement = parse_sdf_expression(program, text);
        } catch (const io_error& error) {
          throw_json_error(object.place, "expression", error.what());
        }
        object.node.left  = object.roots[0];
        object.node.right = displacement;
        root              = add_node(program, object.node);
        break;
      }
    }
  }
  // A nested object's own frame maps its parent's space into its own.
  auto child_from_parent = frame3f{};
  if (!top && read_local_frame(object.place, *object.js, child_from_parent))
    root = add_transform(program, root, child_from_parent);
  return root;
}

// An expression: its formula or .vm file over the named operands, clipped
// to its bounds.
int sdf_walk::finish_expression(sdf_walk_object& object) {
  auto& js       = *object.js;
  auto& place    = object.place;
  auto  root     = invalidid;
  auto  operands = std::vector<sdf_expression_operand>{};
  for (size_t i = 0; i < object.roots.size(); i++)
    operands.push_back({object.names[i], object.roots[i]});
  if (js.contains("expression")) {
    try {
      root = parse_sdf_expression(
          program, js.at("expression").get<std::string>(), operands);
    } catch (const io_error& error) {
      throw_json_error(place, "expression", error.what());
    }
    for (auto& operand : operands)
      if (operand.uses == 0)
        throw_json_error(json_child(place, "operands"), operand.name,
            "not used by the expression");
  } else {
    auto uri = js.at("uri").get<std::string>();
    uris.push_back(uri);
    if (files.load_files) {
      try {
        auto path = std::filesystem::path(files.directory) / uri;
        root      = load_vm(program, path.string());
      } catch (const io_error& error) {
        throw_json_error(place, "uri", error.what());
      }
    } else {
      auto stand_in  = sdf_node{};
      stand_in.type  = sdf_type::math_const;
      stand_in.value = 1;
      root           = add_node(program, stand_in);
    }
  }
  if (!js.contains("bounds")) return root;
  // The inside of the function within the box: max(f, box), the box's
  // corner at the bounds' minimum (a `box` has its corner at its origin).
  auto bounds = read_box(place, js, "bounds");
  auto box    = sdf_node{};
  box.type    = sdf_type::box;
  box.size    = bounds.max - bounds.min;
  auto clip   = add_transform(program, add_node(program, box),
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -bounds.min});
  auto max    = sdf_node{};
  max.type    = sdf_type::op_intersection;
  max.left    = root;
  max.right   = clip;
  return add_node(program, max);
}

// The walk: start an object, walk its operands, finish it.
int sdf_walk::run(const json& js, const json_place& place) {
  auto stack = std::vector<sdf_walk_object>{};
  stack.push_back(start(js, place, true));
  while (true) {
    auto& object = stack.back();
    auto  next   = object.roots.size();
    if (next < object.children.size()) {
      auto child =
          start(*object.children[next], child_place(object, next), false);
      stack.push_back(std::move(child));
      continue;
    }
    auto top  = stack.size() == 1;
    auto root = finish(object, top);
    stack.pop_back();
    if (top) return root;
    stack.back().roots.push_back(root);
  }
}

}  // namespace

// A command-line value as JSON: a finite number, numbers separated by
// commas, or the text itself (which the reader then reports as not a number).
static json text_json_value(const std::string& text) {
  auto number = [](const std::string& item, json& value) {
    auto end    = (char*)nullptr;
    auto parsed = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != 0 || !std::isfinite(parsed)) return false;
    value = parsed;
    return true;
  };
  auto value = json{};
  if (text.find(',') == std::string::npos)
    return number(text, value) ? value : json(text);
  auto items = json::array();
  auto start = size_t{0};
  while (start <= text.size()) {
    auto end = std::min(text.find(',', start), text.size());
    if (!number(text.substr(start, end - start), value)) return json(text);
    items.push_back(value);
    start = end + 1;
  }
  return items;
}

sdf_program parse_primitive_text(const std::string&         type,
    const std::vector<std::pair<std::string, std::string>>& values,
    const std::string&                                      source) {
  auto place = json_place{source, ""};
  auto names = std::vector<std::string>{};
  for (auto i = 0; i < (int)sdf_type::op_union; i++)
    names.push_back(sdf_type_names[i]);
  auto index = parse_json_enum(place, "type", type, names);
  // Only the parameters: a frame or a name has no place on a command line.
  auto params = json::object();
  for (auto& [key, text] : values) {
    if (params.contains(key)) throw_json_error(place, key, "given twice");
    params[key] = text_json_value(text);
  }
  auto valid = std::vector<std::string>{};
  for (auto& param : primitive_params((sdf_type)index))
    valid.push_back(param.key);
  check_json_keys(place, params, valid, " for type \"" + type + "\"");
  auto js      = params;
  js["type"]   = type;
  auto program = sdf_program{};
  auto uris    = std::vector<std::string>{};
  parse_sdf_object(place, js, program, {"", false}, uris);
  return program;
}

int parse_sdf_object(const json_place& place, const json& js,
    sdf_program& program, const sdf_file_context& files,
    std::vector<std::string>& uris) {
  auto walk = sdf_walk{program, files, uris};
  return walk.run(js, place);
}

}  // namespace implicit
