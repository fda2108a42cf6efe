// # implicit: checked JSON reading
//
// Helpers for loaders that validate everything they read. Each value is read
// at a `json_place` (the file and the element path, e.g.
// `sdfunctions[2] ("torus1")`), so every problem becomes an io_error of the
// form `file: path.key: problem`. Syntax errors carry `file:line:column`.
// Only loaders include this header (it pulls in nlohmann::json).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../math/math.h"

namespace implicit {

using json = nlohmann::json;

// -----------------------------------------------------------------------------
// PLACES AND ERRORS
// -----------------------------------------------------------------------------

// Where a value sits: the file and the element path (empty at the top).
struct json_place {
  std::string filename = "";
  std::string path     = "";
};

// The message "file: path.key: problem" (key or path may be empty).
std::string json_message(const json_place& place, const std::string& key,
    const std::string& problem);

// Throw an io_error with json_message().
[[noreturn]] void throw_json_error(const json_place& place,
    const std::string& key, const std::string& problem);

// The place of the value under `key`: path.key.
json_place json_child(const json_place& place, const std::string& key);

// The place of element `index` of the array at `place`: path[index], followed
// by ` ("name")` when the element is an object with a string `name`.
json_place json_element(
    const json_place& place, size_t index, const json& element);

// "a string", "a number", "an object", ... for messages.
std::string json_type_name(const json& value);

// -----------------------------------------------------------------------------
// PARSING
// -----------------------------------------------------------------------------

// Objects and arrays nested deeper than this are refused by parse_json().
inline constexpr size_t max_json_depth = 256;

// Parse JSON text. Syntax errors throw `filename:line:column: invalid JSON:
// ...`; a key repeated in one object throws (nlohmann would silently keep the
// last value).
json parse_json(const std::string& text, const std::string& filename);

// Line and column (both 1-based) of the character at byte offset `offset`
// (0-based) of `text`; offsets past the end give the end of the text.
vec2i json_line_column(const std::string& text, size_t offset);

// -----------------------------------------------------------------------------
// TYPED READING
// -----------------------------------------------------------------------------

// Each reader looks up `key` in the object `js`: it returns false when the
// key is absent, reads the value when it has the right type, and throws
// naming the key otherwise ("expected a number, found a string").
bool read_json(const json_place& place, const json& js, const std::string& key,
    std::string& value);
bool read_json(const json_place& place, const json& js, const std::string& key,
    bool& value);
// Finite numbers only (also after conversion to float).
bool read_json(const json_place& place, const json& js, const std::string& key,
    float& value);
// Integers (numbers with a fraction are refused) that fit an int.
bool read_json(const json_place& place, const json& js, const std::string& key,
    int& value);
// Arrays of 3 finite numbers.
bool read_json(const json_place& place, const json& js, const std::string& key,
    vec3f& value);
// Arrays of 12 finite numbers: columns x, y, z and origin, as Yocto/GL.
bool read_json(const json_place& place, const json& js, const std::string& key,
    frame3f& value);

// As read_json(), but a missing key throws `problem`.
template <typename T>
inline void read_json_required(const json_place& place, const json& js,
    const std::string& key, T& value,
    const std::string& problem = "missing required key") {
  if (!read_json(place, js, key, value)) throw_json_error(place, key, problem);
}

// The array under `key`, or nullptr when absent; throws when it is not an
// array.
const json* find_json_array(
    const json_place& place, const json& js, const std::string& key);

// Throw unless `value` (found at `place`) is an object.
void check_json_object(const json_place& place, const json& value);

// Throw for the first key of the object `js` not in `valid`, listing them;
// `context` (e.g. ` for type "sphere"`) is appended to "unknown key".
void check_json_keys(const json_place& place, const json& js,
    const std::vector<std::string>& valid, const std::string& context = "");

// Index of `value` in `names`; throws listing the valid names otherwise.
int parse_json_enum(const json_place& place, const std::string& key,
    const std::string& value, const std::vector<std::string>& names);

// Comma-separated list of names for messages.
std::string join_names(const std::vector<std::string>& names);

// -----------------------------------------------------------------------------
// VALUE CHECKS
// -----------------------------------------------------------------------------

// Shortest readable form of a number for messages.
std::string format_number(float value);

// Each throws naming `key` ("must be > 0, found -1") unless the value (each
// component of a vec3) is in range.
void check_positive(
    const json_place& place, const std::string& key, float value);
void check_non_negative(
    const json_place& place, const std::string& key, float value);
void check_positive(
    const json_place& place, const std::string& key, vec3f value);
void check_non_negative(
    const json_place& place, const std::string& key, vec3f value);
void check_unit_range(
    const json_place& place, const std::string& key, float value);

// -----------------------------------------------------------------------------
// FRAMES
// -----------------------------------------------------------------------------

// Read a 12-number frame that must be invertible (the renderer inverts
// every frame it uses); false when `key` is absent.
bool read_invertible_frame(const json_place& place, const json& js,
    const std::string& key, frame3f& frame);

// Read `frame` (enclosing space -> local, the seed's convention) or
// `world_from_local` (local -> enclosing space, stored inverted) as the map
// from the enclosing space to the local one. False when neither is present.
bool read_local_frame(
    const json_place& place, const json& js, frame3f& local_from_outer);

}  // namespace implicit
