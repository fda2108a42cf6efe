// Tests for the checked JSON readers under the scene loader: positions of
// syntax errors, duplicate keys, and each reader's accepted and refused
// values with the exact message.

#include "json_check.h"

#include <doctest/doctest.h>

#include <utility>

#include "../util/error.h"

using namespace implicit;

namespace {

// The io_error message of `read`, or "no error".
template <typename Read>
std::string error_of(Read&& read) {
  try {
    read();
  } catch (const io_error& error) { return error.what(); }
  return "no error";
}

std::pair<int, int> line_column(const std::string& text, size_t offset) {
  auto position = json_line_column(text, offset);
  return {position.x, position.y};
}

}  // namespace

TEST_CASE("scene_io json syntax errors") {
  CHECK(line_column("ab\ncd\n", 0) == std::pair{1, 1});
  CHECK(line_column("ab\ncd\n", 2) == std::pair{1, 3});
  CHECK(line_column("ab\ncd\n", 3) == std::pair{2, 1});
  CHECK(line_column("ab\ncd\n", 4) == std::pair{2, 2});
  CHECK(line_column("ab\ncd\n", 99) == std::pair{3, 1});
  auto parse = [](const std::string& text) {
    return error_of([&] { parse_json(text, "f.json"); });
  };
  CHECK(parse("{\"a\": 1,\n \"b\": tru}") ==
        "f.json:2:10: invalid JSON: syntax error while parsing value - "
        "invalid literal; last read: '\"b\": tru}'");
  CHECK(parse("{\"a\": 1,\n \"b\": 2") ==
        "f.json:2:8: invalid JSON: syntax error while parsing object - "
        "unexpected end of input; expected '}'");
  // The overflowing number is found in the text, not inside a longer one.
  CHECK(parse("[21e999,\n 1e999]") ==
        "f.json:1:2: invalid JSON: number overflow parsing '21e999'");
  CHECK(parse("[2,\n  -1e999]") ==
        "f.json:2:3: invalid JSON: number overflow parsing '-1e999'");
  // Duplicate keys name their place, through arrays and objects.
  CHECK(parse(R"({"a": [{"b": 1}, {"c": 1, "d": {"e": 0, "e": 1}}]})") ==
        "f.json: a[1].d.e: duplicate key (each key may appear once per "
        "object)");
  CHECK(parse(R"({"a": [1, [2, 3], {"x": 1}, {"x": 1, "x": 2}]})") ==
        "f.json: a[3].x: duplicate key (each key may appear once per object)");
  CHECK(parse(R"({"a": 1, "a": 1})") ==
        "f.json: a: duplicate key (each key may appear once per object)");
  // The same key in different objects is fine.
  auto js = parse_json(R"({"a": {"x": 1}, "b": [{"x": 2}, {"x": 3}]})", "f");
  CHECK(js["b"][1]["x"].get<int>() == 3);
}

TEST_CASE("scene_io json typed reading") {
  auto place = json_place{"f.json", "things[1] (\"t\")"};
  auto js    = json::parse(R"({"s": "text", "b": true, "f": 0.5, "i": 7,
      "i2": 2.0, "i3": 2.5, "big": 3000000000, "neg": -3000000000,
      "huge": 1e39, "v": [1, 2, 3], "v2": [1, 2], "v3": [1, "2", 3],
      "m": [1,0,0, 0,1,0, 0,0,1, 4,5,6], "n": null, "o": {}})");
  auto s     = std::string{};
  auto b     = false;
  auto f     = 0.0f;
  auto i     = 0;
  auto v     = vec3f{};
  auto m     = frame3f{};
  CHECK(read_json(place, js, "s", s));
  CHECK(s == "text");
  CHECK(read_json(place, js, "b", b));
  CHECK(b);
  CHECK(read_json(place, js, "f", f));
  CHECK(f == 0.5f);
  CHECK(read_json(place, js, "i", f));
  CHECK(f == 7.0f);
  CHECK(read_json(place, js, "i", i));
  CHECK(i == 7);
  CHECK(read_json(place, js, "i2", i));
  CHECK(i == 2);
  CHECK(read_json(place, js, "v", v));
  CHECK(v == vec3f{1, 2, 3});
  CHECK(read_json(place, js, "m", m));
  CHECK(m.o == vec3f{4, 5, 6});
  CHECK(m.y == vec3f{0, 1, 0});
  // Absent keys leave the value alone.
  f = 9;
  CHECK(!read_json(place, js, "missing", f));
  CHECK(f == 9.0f);
  auto error = [&](const std::string& key, auto value) {
    return error_of([&] { read_json(place, js, key, value); });
  };
  auto prefix = std::string{"f.json: things[1] (\"t\")."};
  CHECK(error("s", f) == prefix + "s: expected a number, found a string");
  CHECK(error("n", f) == prefix + "n: expected a number, found null");
  CHECK(error("f", s) == prefix + "f: expected a string, found a number");
  CHECK(error("o", b) == prefix + "o: expected a boolean, found an object");
  CHECK(error("v", i) == prefix + "v: expected an integer, found an array");
  CHECK(error("i3", i) == prefix + "i3: expected an integer, found 2.5");
  CHECK(error("big", i) == prefix + "big: integer too large (3000000000)");
  CHECK(error("neg", i) == prefix + "neg: integer too large (-3000000000)");
  CHECK(error("huge", f) == prefix + "huge: out of float range (1e+39)");
  CHECK(error("v2", v) ==
        prefix + "v2: expected an array of 3 numbers, found 2 values");
  CHECK(error("v3", v) == prefix + "v3[1]: expected a number, found a string");
  CHECK(error("s", v) ==
        prefix + "s: expected an array of 3 numbers, found a string");
  CHECK(error("v", m) ==
        prefix + "v: expected an array of 12 numbers, found 3 values");
  CHECK(error_of([&] { read_json_required(place, js, "x", f); }) ==
        prefix + "x: missing required key");
  CHECK(error_of([&] { find_json_array(place, js, "o"); }) ==
        prefix + "o: expected an array, found an object");
  CHECK(find_json_array(place, js, "missing") == nullptr);
  CHECK(error_of([&] { check_json_keys(place, js["o"], {}); }) == "no error");
  CHECK(error_of([&] {
    check_json_keys(place, js, {"s", "b"});
  }) == prefix + "big: unknown key (valid keys: s, b)");
  CHECK(parse_json_enum(place, "kind", "b", {"a", "b"}) == 1);
  CHECK(error_of([&] {
    parse_json_enum(place, "kind", "c", {"a", "b"});
  }) == prefix + "kind: unknown kind \"c\" (valid kinds: a, b)");
  // Places: elements carry their name when they have a string one.
  auto top = json_place{"f.json", ""};
  CHECK(json_child(top, "a").path == "a");
  CHECK(json_element(json_child(top, "a"), 2, json::parse(R"({"name": "n"})"))
            .path == "a[2] (\"n\")");
  CHECK(json_element(json_child(top, "a"), 2, json::parse(R"({"name": 1})"))
            .path == "a[2]");
  CHECK(json_message(top, "", "bad") == "f.json: bad");
  CHECK(json_message(top, "k", "bad") == "f.json: k: bad");
}

TEST_CASE("scene_io json nesting is bounded") {
  auto nested = [](size_t depth) {
    return std::string(depth, '[') + std::string(depth, ']');
  };
  CHECK(error_of([&] { parse_json(nested(max_json_depth), "f.json"); }) ==
        "no error");
  auto error = error_of([&] { parse_json(nested(100000), "f.json"); });
  CHECK(error.find("f.json: ") == 0);
  CHECK(error.find("nested deeper than 256 levels") != std::string::npos);
  auto objects = std::string{};
  for (auto i = 0; i < 300; i++) objects += "{\"a\": ";
  objects += "1" + std::string(300, '}');
  error = error_of([&] { parse_json(objects, "g.json"); });
  CHECK(error.find("g.json: a.a.a.") == 0);
  CHECK(error.find("nested deeper than 256 levels") != std::string::npos);
}
