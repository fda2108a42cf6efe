// # implicit: checked JSON reading (implementation)

#include "json_check.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <new>
#include <set>

#include "../sdf/sdf_primitives.h"
#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PLACES AND ERRORS
// -----------------------------------------------------------------------------

std::string json_message(const json_place& place, const std::string& key,
    const std::string& problem) {
  auto where = place.path;
  if (!key.empty()) where += (where.empty() ? "" : ".") + key;
  auto message = place.filename + ": ";
  if (!where.empty()) message += where + ": ";
  return message + problem;
}

void throw_json_error(const json_place& place, const std::string& key,
    const std::string& problem) {
  throw io_error(json_message(place, key, problem));
}

json_place json_child(const json_place& place, const std::string& key) {
  return {place.filename, place.path.empty() ? key : place.path + "." + key};
}

json_place json_element(
    const json_place& place, size_t index, const json& element) {
  auto path = place.path + "[" + std::to_string(index) + "]";
  // The name makes long arrays readable; a name of the wrong type is
  // reported later by the reader of `name`.
  if (element.is_object()) {
    auto it = element.find("name");
    if (it != element.end() && it->is_string())
      path += " (\"" + it->get<std::string>() + "\")";
  }
  return {place.filename, path};
}

std::string json_type_name(const json& value) {
  switch (value.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    case json::value_t::string: return "a string";
    case json::value_t::array: return "an array";
    case json::value_t::object: return "an object";
    case json::value_t::binary: return "binary data";
    case json::value_t::discarded: return "nothing";
  }
  return "an unknown value";
}

std::string join_names(const std::vector<std::string>& names) {
  auto joined = std::string{};
  for (auto& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

// -----------------------------------------------------------------------------
// PARSING
// -----------------------------------------------------------------------------

vec2i json_line_column(const std::string& text, size_t offset) {
  offset      = std::min(offset, text.size());
  auto line   = 1 + (int)std::count(text.begin(), text.begin() + offset, '\n');
  auto before = offset == 0 ? std::string::npos : text.rfind('\n', offset - 1);
  auto start  = before == std::string::npos ? 0 : before + 1;
  return {line, (int)(offset - start) + 1};
}

// An open object or array while parsing, to name the place of a duplicate
// key: the object's current key or the array's current element.
struct json_scope {
  bool                  is_object = false;
  std::string           key       = "";
  size_t                index     = 0;
  std::set<std::string> keys      = {};
};

// Path of the innermost scope's parent values, e.g. `sdfunctions[0]`.
static std::string scope_path(const std::vector<json_scope>& scopes) {
  auto path = std::string{};
  for (size_t i = 0; i + 1 < scopes.size(); i++) {
    auto& scope = scopes[i];
    if (scope.is_object) {
      path += (path.empty() ? "" : ".") + scope.key;
    } else {
      path += "[" + std::to_string(scope.index) + "]";
    }
  }
  // The innermost scope is an object whose key is the duplicate; an array
  // scope never reports, so it adds nothing here.
  return path;
}

// nlohmann's SAX events, forwarded to its DOM builder, with the keys of
// each open object tracked: a scene with two `radius` keys is a mistake
// (nlohmann keeps the last). Not json::parse() with a callback: in nlohmann
// 3.11.2 the callback parser scans the enclosing array after every object,
// quadratic in a long `operands` list (100,000 operands: 10 s instead of
// 0.3).
struct checked_sax {
  using dom_parser = nlohmann::detail::json_sax_dom_parser<json>;
  dom_parser              dom;
  const std::string&      filename;
  std::vector<json_scope> scopes = {};

  checked_sax(json& result, const std::string& name)
      : dom{result, true}, filename{name} {}
  void element_done() {
    if (!scopes.empty() && !scopes.back().is_object) scopes.back().index++;
  }
  bool null() {
    element_done();
    return dom.null();
  }
  bool boolean(bool value) {
    element_done();
    return dom.boolean(value);
  }
  bool number_integer(json::number_integer_t value) {
    element_done();
    return dom.number_integer(value);
  }
  bool number_unsigned(json::number_unsigned_t value) {
    element_done();
    return dom.number_unsigned(value);
  }
  bool number_float(json::number_float_t value, const json::string_t& text) {
    element_done();
    return dom.number_float(value, text);
  }
  bool string(json::string_t& value) {
    element_done();
    return dom.string(value);
  }
  bool binary(json::binary_t& value) {
    element_done();
    return dom.binary(value);
  }
  bool start_object(std::size_t size) {
    // Code that walks the JSON (and nlohmann's own copy and dump) recurses
    // once per level: bound it here, with a clear message.
    if (scopes.size() >= max_json_depth)
      throw_json_error({filename, scope_path(scopes)},
          scopes.empty() ? "" : scopes.back().key,
          "nested deeper than " + std::to_string(max_json_depth) + " levels");
    scopes.push_back({true, "", 0, {}});
    return dom.start_object(size);
  }
  bool key(json::string_t& key) {
    auto& scope = scopes.back();
    if (!scope.keys.insert(key).second)
      throw_json_error({filename, scope_path(scopes)}, key,
          "duplicate key (each key may appear once per object)");
    scope.key = key;
    return dom.key(key);
  }
  bool end_object() {
    scopes.pop_back();
    element_done();
    return dom.end_object();
  }
  bool start_array(std::size_t size) {
    // Code that walks the JSON (and nlohmann's own copy and dump) recurses
    // once per level: bound it here, with a clear message.
    if (scopes.size() >= max_json_depth)
      throw_json_error({filename, scope_path(scopes)},
          scopes.empty() ? "" : scopes.back().key,
          "nested deeper than " + std::to_string(max_json_depth) + " levels");
    scopes.push_back({false, "", 0, {}});
    return dom.start_array(size);
  }
  bool end_array() {
    scopes.pop_back();
    element_done();
    return dom.end_array();
  }
  template <class Exception>
  bool parse_error(
      std::size_t position, const std::string& token, const Exception& error) {
    return dom.parse_error(position, token, error);
  }
};

json parse_json(const std::string& text, const std::string& filename) {
  try {
    auto result = json{};
    auto sax    = checked_sax{result, filename};
    json::sax_parse(text, &sax);
    return result;
  } catch (const json::parse_error& error) {
    // nlohmann's byte is 1-based and points at the last character read.
    auto position = json_line_column(text, error.byte > 0 ? error.byte - 1 : 0);
    // Keep nlohmann's description, dropping its id and position prefix.
    auto what    = std::string{error.what()};
    auto problem = what;
    auto start   = what.find("parse error");
    if (start != std::string::npos) start = what.find(": ", start);
    if (start != std::string::npos) problem = what.substr(start + 2);
    throw io_error(filename + ":" + std::to_string(position.x) + ":" +
                   std::to_string(position.y) + ": invalid JSON: " + problem);
  } catch (const std::bad_alloc&) {
    // A JSON text larger than the memory left: still an error naming it.
    throw io_error(filename + ": out of memory parsing the JSON");
  } catch (const json::exception& error) {
    // Numbers beyond double range (1e999) are out_of_range errors without a
    // position; the message quotes the number, so look for it in the text.
    auto what    = std::string{error.what()};
    auto id_end  = what.find("] ");
    auto problem = id_end == std::string::npos ? what : what.substr(id_end + 2);
    auto first = what.find('\''), last = what.rfind('\'');
    if (first != std::string::npos && last > first + 1) {
      auto token  = what.substr(first + 1, last - first - 1);
      auto offset = text.find(token);
      // Skip matches inside a longer number (1e999 inside 21e999).
      while (offset != std::string::npos && offset > 0 &&
             std::string{"0123456789.-+eE"}.find(text[offset - 1]) !=
                 std::string::npos)
        offset = text.find(token, offset + 1);
      if (offset != std::string::npos) {
        auto position = json_line_column(text, offset);
        throw io_error(filename + ":" + std::to_string(position.x) + ":" +
                       std::to_string(position.y) +
                       ": invalid JSON: " + problem);
      }
    }
    throw io_error(filename + ": invalid JSON: " + problem);
  }
}

// -----------------------------------------------------------------------------
// TYPED READING
// -----------------------------------------------------------------------------

// A JSON number as a finite float; `key` names it in errors.
static float json_to_float(
    const json_place& place, const std::string& key, const json& value) {
  if (!value.is_number())
    throw_json_error(
        place, key, "expected a number, found " + json_type_name(value));
  auto number = value.get<double>();
  if (!std::isfinite(number)) throw_json_error(place, key, "must be finite");
  // Checked before the cast: converting an out-of-range double to float is
  // undefined behaviour.
  if (std::abs(number) > (double)flt_max)
    throw_json_error(place, key, "out of float range (" + value.dump() + ")");
  return (float)number;
}

// Read a fixed-size array of finite numbers.
static void json_to_floats(const json_place& place, const std::string& key,
    const json& value, float* numbers, size_t count) {
  auto expected = "an array of " + std::to_string(count) + " numbers";
  if (!value.is_array())
    throw_json_error(place, key,
        "expected " + expected + ", found " + json_type_name(value));
  if (value.size() != count)
    throw_json_error(place, key,
        "expected " + expected + ", found " + std::to_string(value.size()) +
            (value.size() == 1 ? " value" : " values"));
  for (size_t i = 0; i < count; i++)
    numbers[i] =
        json_to_float(place, key + "[" + std::to_string(i) + "]", value[i]);
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    std::string& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  if (!it->is_string())
    throw_json_error(
        place, key, "expected a string, found " + json_type_name(*it));
  value = it->get<std::string>();
  return true;
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    bool& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  if (!it->is_boolean())
    throw_json_error(
        place, key, "expected a boolean, found " + json_type_name(*it));
  value = it->get<bool>();
  return true;
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    float& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  value = json_to_float(place, key, *it);
  return true;
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    int& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  if (it->is_number_unsigned()) {
    auto number = it->get<unsigned long long>();
    if (number > (unsigned long long)INT_MAX)
      throw_json_error(place, key, "integer too large (" + it->dump() + ")");
    value = (int)number;
  } else if (it->is_number_integer()) {
    auto number = it->get<long long>();
    if (number < INT_MIN || number > INT_MAX)
      throw_json_error(place, key, "integer too large (" + it->dump() + ")");
    value = (int)number;
  } else if (it->is_number_float()) {
    // Writers that only have doubles emit 2.0; a fraction is a mistake.
    auto number = it->get<double>();
    if (!std::isfinite(number) || number != std::floor(number) ||
        number < INT_MIN || number > INT_MAX)
      throw_json_error(place, key, "expected an integer, found " + it->dump());
    value = (int)number;
  } else {
    throw_json_error(
        place, key, "expected an integer, found " + json_type_name(*it));
  }
  return true;
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    vec3f& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  float numbers[3];
  json_to_floats(place, key, *it, numbers, 3);
  value = {numbers[0], numbers[1], numbers[2]};
  return true;
}

bool read_json(const json_place& place, const json& js, const std::string& key,
    frame3f& value) {
  auto it = js.find(key);
  if (it == js.end()) return false;
  float n[12];
  json_to_floats(place, key, *it, n, 12);
  value = {{n[0], n[1], n[2]}, {n[3], n[4], n[5]}, {n[6], n[7], n[8]},
      {n[9], n[10], n[11]}};
  return true;
}

const json* find_json_array(
    const json_place& place, const json& js, const std::string& key) {
  auto it = js.find(key);
  if (it == js.end()) return nullptr;
  if (!it->is_array())
    throw_json_error(
        place, key, "expected an array, found " + json_type_name(*it));
  return &*it;
}

void check_json_object(const json_place& place, const json& value) {
  if (!value.is_object())
    throw_json_error(
        place, "", "expected an object, found " + json_type_name(value));
}

void check_json_keys(const json_place& place, const json& js,
    const std::vector<std::string>& valid, const std::string& context) {
  for (auto& item : js.items()) {
    if (std::find(valid.begin(), valid.end(), item.key()) != valid.end())
      continue;
    throw_json_error(place, item.key(),
        "unknown key" + context + " (valid keys: " + join_names(valid) + ")");
  }
}

int parse_json_enum(const json_place& place, const std::string& key,
    const std::string& value, const std::vector<std::string>& names) {
  auto it = std::find(names.begin(), names.end(), value);
  if (it == names.end())
    throw_json_error(place, key,
        "unknown " + key + " \"" + value + "\" (valid " + key +
            "s: " + join_names(names) + ")");
  return (int)(it - names.begin());
}

// -----------------------------------------------------------------------------
// VALUE CHECKS
// -----------------------------------------------------------------------------

// Shortest readable form of a number for messages.
std::string format_number(float value) { return format_param_value(value); }

static std::string format_vec3(vec3f value) {
  return "(" + format_number(value.x) + ", " + format_number(value.y) + ", " +
         format_number(value.z) + ")";
}

void check_positive(
    const json_place& place, const std::string& key, float value) {
  if (!(value > 0))
    throw_json_error(place, key, "must be > 0, found " + format_number(value));
}

void check_non_negative(
    const json_place& place, const std::string& key, float value) {
  if (!(value >= 0))
    throw_json_error(place, key, "must be >= 0, found " + format_number(value));
}

void check_positive(
    const json_place& place, const std::string& key, vec3f value) {
  if (!(min(value) > 0))
    throw_json_error(place, key,
        "must be > 0 in every component, found " + format_vec3(value));
}

void check_non_negative(
    const json_place& place, const std::string& key, vec3f value) {
  if (!(min(value) >= 0))
    throw_json_error(place, key,
        "must be >= 0 in every component, found " + format_vec3(value));
}

void check_unit_range(
    const json_place& place, const std::string& key, float value) {
  if (!(value >= 0 && value <= 1))
    throw_json_error(
        place, key, "must be in [0, 1], found " + format_number(value));
}

// -----------------------------------------------------------------------------
// FRAMES
// -----------------------------------------------------------------------------

// Read a 12-number frame that must be invertible (the renderer inverts
// every frame it uses).
bool read_invertible_frame(const json_place& place, const json& js,
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
bool read_local_frame(
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

}  // namespace implicit
