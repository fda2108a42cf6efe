// Tests for `.vm` files: fidget's own examples, every opcode against the
// reference evaluator, shared clauses, the round trip through format_vm,
// and one check per error message.

#include "sdf_vm_io.h"

#include <doctest/doctest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "../util/error.h"
#include "sdf_expression.h"
#include "sdf_expression_test.h"

using namespace implicit;

namespace {

sdf_program parse(const std::string& text) {
  auto program = sdf_program{};
  parse_vm(program, text, "model.vm");
  return program;
}

std::string vm_error(const std::string& text) {
  try {
    parse(text);
  } catch (const io_error& error) {
    return error.what();
  } catch (const std::exception& error) {
    return std::string{"not an io_error: "} + error.what();
  }
  return "no error";
}

const vec3f test_points[] = {{0.3f, -0.7f, 0.45f}, {1.25f, 0.5f, -2.0f},
    {-0.1f, 0.2f, 0.9f}, {2.5f, -1.5f, 0.05f}};

// Every opcode once: a model whose value mixes them all (NaN-free at the
// test points: domains are guarded by abs and offsets).
const char* every_opcode = R"(# every opcode
x var-x
y var-y
z var-z
c const 0.75
n neg x
a abs n
s square y
r sqrt a
e exp z
l ln s
si sin x
co cos y
ta tan c
as asin c
ac acos c
at atan z
fl floor e
ce ceil e
ro round e
no not fl
ad add r l
su sub si co
mu mul ta as
di div ac e
mi min ad su
ma max mu di
a2 atan2 y x
mo mod e c
cm compare x y
an and cm mo
or or no a2
t1 add mi ma
t2 add t1 at
t3 add t2 fl
t4 add t3 ce
t5 add t4 ro
t6 add t5 an
t7 add t6 or
)";

}  // namespace

TEST_CASE("sdf_vm: fidget's examples") {
  // models/sphere.vm, with its comment and hexadecimal names.
  auto sphere = parse(R"(# This is a sphere!
0x600000b90000 var-x
0x600000b900a0 square 0x600000b90000
0x600000b90050 var-y
0x600000b900f0 square 0x600000b90050
0x600000b90300 var-z
0x600000b90350 square 0x600000b90300
0x600000b90140 add 0x600000b900a0 0x600000b900f0
0x600000b90150 add 0x600000b90140 0x600000b90350
0x600000b90190 sqrt 0x600000b90150
0x600000b901e0 const 1
0x600000b90200 sub 0x600000b90190 0x600000b901e0)");
  CHECK(sphere.nodes.size() == 11);
  for (auto p : test_points)
    CHECK(eval_reference(sphere, p) ==
          doctest::Approx(length(p) - 1).epsilon(1e-6));
  // models/tanglecube.vm: a quartic, with floats such as "5.0".
  auto tangle = parse(R"(# Recommended settings: --scale 0.222
_x var-x
_y var-y
_z var-z
_x2 square _x
_x4 square _x2
_y2 square _y
_y4 square _y2
_z2 square _z
_z4 square _z2
_5 const 5.0
_x2_5 mul _x2 _5
_y2_5 mul _y2 _5
_z2_5 mul _z2 _5
_s0 sub _x4 _x2_5
_s1 add _s0 _y4
_s2 sub _s1 _y2_5
_s3 add _s2 _z4
_s4 sub _s3 _z2_5
_10 const 10.0
_out add _s4 _10
)");
  for (auto p : test_points) {
    auto tangle_cube = [](double v) { return v * v * v * v - 5 * v * v; };
    CHECK(eval_reference(tangle, p) ==
          doctest::Approx(
              tangle_cube(p.x) + tangle_cube(p.y) + tangle_cube(p.z) + 10)
              .epsilon(1e-6));
  }
}

TEST_CASE("sdf_vm: every opcode") {
  auto program = parse(every_opcode);
  for (auto p : test_points) {
    CAPTURE(p.x);
    double x = p.x, y = p.y, z = p.z;
    auto   e = std::exp(z);
    auto   m = std::fmod(e, 0.75);
    auto   expected =
        std::min(std::sqrt(std::abs(-x)) + std::log(y * y),
            std::sin(x) - std::cos(y)) +
        std::max(std::tan(0.75) * std::asin(0.75), std::acos(0.75) / e) +
        std::atan(z) + std::floor(e) + std::ceil(e) + std::round(e) +
        (x == y ? 0.0 : (m < 0 ? m + 0.75 : m)) +
        (std::floor(e) == 0 ? 1.0 : std::atan2(y, x));
    auto value = eval_reference(program, p);
    CHECK(value == doctest::Approx(expected).epsilon(1e-6));
  }
  // Each opcode's clause type, in table order.
  auto seen = std::vector<int>(sdf_math_names.size(), 0);
  for (auto& node : program.nodes)
    if (is_math(node.type))
      seen[(int)node.type - (int)sdf_type::math_const] = 1;
  for (size_t i = 0; i < seen.size(); i++) {
    CAPTURE(sdf_math_names[i]);
    CHECK(seen[i] == 1);
  }
}

TEST_CASE("sdf_vm: layout, sharing, unused clauses") {
  // Comments after spaces, blank lines, CRLF, tabs, a leading '+'.
  auto program = parse(
      "  # indented comment\r\n\r\n_a\tvar-x\r\n   \n_b const +2.5e0\r\n"
      "_c mul _a _b\r\n");
  REQUIRE(program.nodes.size() == 3);
  CHECK(program.nodes[1].value == 2.5f);
  CHECK(eval_reference(program, {2, 0, 0}) == doctest::Approx(5));
  // One clause used twice stays one node with two users.
  auto shared = parse("x var-x\ns square x\nt add s s\n");
  REQUIRE(shared.nodes.size() == 3);
  CHECK(shared.nodes[2].left == 1);
  CHECK(shared.nodes[2].right == 1);
  // Clauses the last one does not reach are dropped.
  auto dead = parse("x var-x\ny var-y\nu sin y\nv cos x\n");
  REQUIRE(dead.nodes.size() == 2);
  CHECK(dead.nodes[0].type == sdf_type::math_x);
  CHECK(dead.nodes[1].type == sdf_type::math_cos);
  // Clauses are appended after what the program holds.
  auto appended = sdf_program{};
  add_node(appended, sdf_node{});
  CHECK(parse_vm(appended, "a var-y\n", "model.vm") == 1);
}

TEST_CASE("sdf_vm: format, save and load round trip") {
  auto program = parse(every_opcode);
  auto text    = format_vm(program, root_node(program));
  CHECK(text.rfind("# ", 0) == 0);
  auto again = parse(text);
  REQUIRE(again.nodes.size() == program.nodes.size());
  for (size_t i = 0; i < program.nodes.size(); i++) {
    CAPTURE(i);
    CHECK(again.nodes[i].type == program.nodes[i].type);
    CHECK(again.nodes[i].left == program.nodes[i].left);
    CHECK(again.nodes[i].right == program.nodes[i].right);
    CHECK(again.nodes[i].value == program.nodes[i].value);
  }
  // Constants keep every bit (shortest form that reads back the same).
  auto constants = parse(
      "a const 0.1\nb const 3.4028235e38\nc const "
      "1e-45\nd const -0\ne add a b\nf add e c\ng add f d\n");
  auto copy = parse(format_vm(constants, root_node(constants)));
  for (auto i = 0; i < 4; i++) {
    CHECK(copy.nodes[i].value == constants.nodes[i].value);
    CHECK(std::signbit(copy.nodes[i].value) ==
          std::signbit(constants.nodes[i].value));
  }
  // A shared clause is written once.
  auto shared = parse("x var-x\ns square x\nt add s s\n");
  auto lines  = format_vm(shared, 2);
  CHECK(lines ==
        "# 3 clauses written by implicit; the last one is the value\n"
        "_0 var-x\n_1 square _0\n_2 add _1 _1\n");
  // From an infix expression, through a file and back.
  auto infix = sdf_program{};
  parse_sdf_expression(infix, "sqrt(x^2 + y^2 + z^2) - mix(1, 2, 0.5)");
  auto directory = std::filesystem::temp_directory_path() /
                   ("implicit_vm_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(directory);
  auto filename = (directory / "model.vm").string();
  save_vm(filename, infix);
  auto loaded = sdf_program{};
  load_vm(loaded, filename);
  for (auto p : test_points)
    CHECK(eval_reference(loaded, p) == eval_reference(infix, p));
  // Errors of the file layer name the file.
  auto missing = std::string{};
  try {
    load_vm(loaded, (directory / "missing.vm").string());
  } catch (const io_error& error) { missing = error.what(); }
  CHECK(missing.find("missing.vm: cannot open") != std::string::npos);
  auto folder = std::string{};
  try {
    load_vm(loaded, directory.string());
  } catch (const io_error& error) { folder = error.what(); }
  CHECK(folder.rfind(directory.string() + ": cannot open", 0) == 0);
  std::filesystem::remove_all(directory);
}

TEST_CASE("sdf_vm: shapes cannot be written") {
  auto program = sdf_program{};
  auto sphere  = sdf_node{};
  sphere.type  = sdf_type::sphere;
  auto leaf    = add_node(program, sphere);
  auto x       = sdf_node{};
  x.type       = sdf_type::math_x;
  auto add     = sdf_node{};
  add.type     = sdf_type::math_add;
  add.left     = leaf;
  add.right    = add_node(program, x);
  add_node(program, add);
  auto message = std::string{};
  try {
    save_vm("/nonexistent/shape.vm", program);
  } catch (const io_error& error) { message = error.what(); }
  CHECK(message ==
        "/nonexistent/shape.vm: the expression holds a sphere node, which a "
        ".vm file cannot hold (only math clauses)");
}

TEST_CASE("sdf_vm: errors name the file and the line") {
  CHECK(vm_error("") ==
        "model.vm: no clauses (the file is empty or holds only comments)");
  CHECK(vm_error("# nothing\n\n   \n") ==
        "model.vm: no clauses (the file is empty or holds only comments)");
  CHECK(
      vm_error("a var-x\n\nb foo a\n") == "model.vm:3: unknown opcode \"foo\"");
  CHECK(vm_error("a var-x\nb\n") == "model.vm:2: missing opcode after \"b\"");
  CHECK(vm_error("a var-x\nb add a c\n") ==
        "model.vm:2: \"c\" is used before it is defined");
  CHECK(vm_error("b neg b\n") ==
        "model.vm:1: \"b\" is used before it is defined");
  CHECK(vm_error("a var-x\nb add a\n") ==
        "model.vm:2: add takes 2 arguments, found 1");
  CHECK(vm_error("a var-x\nb sqrt a a\n") ==
        "model.vm:2: sqrt takes 1 argument, found 2");
  CHECK(vm_error("a var-x 1\n") ==
        "model.vm:1: var-x takes no arguments, found 1");
  CHECK(vm_error("a const\n") ==
        "model.vm:1: const takes 1 argument (a number), found 0");
  CHECK(vm_error("a const 1 2\n") ==
        "model.vm:1: const takes 1 argument (a number), found 2");
  CHECK(vm_error("a const one\n") ==
        "model.vm:1: const takes a finite number, found \"one\"");
  CHECK(vm_error("a const 1.5x\n") ==
        "model.vm:1: const takes a finite number, found \"1.5x\"");
  CHECK(vm_error("a const inf\n") ==
        "model.vm:1: const takes a finite number, found \"inf\"");
  CHECK(vm_error("a const nan\n") ==
        "model.vm:1: const takes a finite number, found \"nan\"");
  CHECK(vm_error("a const 1e39\n") ==
        "model.vm:1: const \"1e39\" is out of the range of 32-bit floats");
  CHECK(vm_error("a var-x\na var-y\n") ==
        "model.vm:2: \"a\" is already defined on line 1");
  // Binary bytes and long tokens stay one readable line.
  CHECK(vm_error(std::string("a \x01\xff\0b", 6)) ==
        "model.vm:1: unknown opcode \"???b\"");
  CHECK(vm_error("a " + std::string(100, 'q')) ==
        "model.vm:1: unknown opcode \"" + std::string(32, 'q') + "...\"");
  // A failed parse leaves the program as it was.
  auto program = sdf_program{};
  add_node(program, sdf_node{});
  CHECK_THROWS_AS(parse_vm(program, "a var-x\nb neg c\n", "m.vm"), io_error);
  CHECK(program.nodes.size() == 1);
}

TEST_CASE("sdf_vm: the clause limit") {
  auto text = std::string{};
  text.reserve(16 * (sdf_max_clauses + 1));
  for (auto i = 0; i <= sdf_max_clauses; i++)
    text += "_" + std::to_string(i) + " var-x\n";
  CHECK(vm_error(text) == "model.vm:" + std::to_string(sdf_max_clauses + 1) +
                              ": more than 1048576 clauses (the most one "
                              "expression may hold)");
}
