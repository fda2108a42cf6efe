// Tests for the infix parser: values against the same formulas in C++ (by
// the reference evaluator of sdf_expression_test.h), precedence, lowering,
// shared clauses, and one check per error message.

#include "sdf_expression.h"

#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "../util/error.h"
#include "sdf_expression_test.h"

using namespace implicit;

namespace {

sdf_program parse(const std::string& text) {
  auto program = sdf_program{};
  parse_sdf_expression(program, text);
  return program;
}

// The io_error message of parsing `text`.
std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const io_error& error) {
    return error.what();
  } catch (const std::exception& error) {
    return std::string{"not an io_error: "} + error.what();
  }
  return "no error";
}

// Points that avoid the domain edges of the formulas below.
const vec3f test_points[] = {{0.3f, -0.7f, 0.45f}, {1.25f, 0.5f, -2.0f},
    {-0.1f, 0.2f, 0.9f}, {2.5f, -1.5f, 0.05f}};

// Check that `text` evaluates as `formula` (double) at the test points.
template <typename Formula>
void check_formula(const std::string& text, const Formula& formula) {
  CAPTURE(text);
  auto program = parse(text);
  for (auto p : test_points) {
    CAPTURE(p.x);
    auto expected = formula((double)p.x, (double)p.y, (double)p.z);
    auto value    = eval_reference(program, p);
    CHECK(value == doctest::Approx(expected).epsilon(1e-5));
  }
}

// Number of nodes of each type reachable in a program.
int count_type(const sdf_program& program, sdf_type type) {
  auto count = 0;
  for (auto& node : program.nodes) count += node.type == type;
  return count;
}

}  // namespace

TEST_CASE("sdf_expression: formulas against C++") {
  check_formula("x", [](double x, double, double) { return x; });
  check_formula("x*x + y*y + z*z - 1",
      [](double x, double y, double z) { return x * x + y * y + z * z - 1; });
  // The gyroid sphere.
  check_formula(
      "max(abs(sin(5*x)*cos(5*y) + sin(5*y)*cos(5*z) + sin(5*z)*cos(5*x)) - "
      "0.5, 5*(sqrt(x*x+y*y+z*z) - 0.8))",
      [](double x, double y, double z) {
        auto g = std::abs(std::sin(5 * x) * std::cos(5 * y) +
                          std::sin(5 * y) * std::cos(5 * z) +
                          std::sin(5 * z) * std::cos(5 * x)) -
                 0.5;
        return std::max(g, 5 * (std::sqrt(x * x + y * y + z * z) - 0.8));
      });
  check_formula("tan(x) + asin(z/3) - acos(z/3) + atan(y) + atan2(y, x)",
      [](double x, double y, double z) {
        return std::tan(x) + std::asin(z / 3) - std::acos(z / 3) +
               std::atan(y) + std::atan2(y, x);
      });
  check_formula(
      "exp(x) * log(z*z) / square(y)", [](double x, double y, double z) {
        return std::exp(x) * std::log(z * z) / (y * y);
      });
  check_formula("floor(3*x) + ceil(3*y) + round(3*z) + mod(7*x, 0.7)",
      [](double x, double y, double z) {
        auto m = std::fmod(7 * x, 0.7);
        return std::floor(3 * x) + std::ceil(3 * y) + std::round(3 * z) +
               (m < 0 ? m + 0.7 : m);
      });
  check_formula(
      "min(x, y, z) + max(x, y, z, 0.5)", [](double x, double y, double z) {
        return std::min({x, y, z}) + std::max({x, y, z, 0.5});
      });
  check_formula("clamp(x, -0.2, 0.4) + mix(y, z, 0.25)",
      [](double x, double y, double z) {
        return std::min(std::max(x, -0.2), 0.4) + y + (z - y) * 0.25;
      });
  check_formula(
      "2*pi*x", [](double x, double, double) { return 2 * M_PI * x; });
  check_formula(".5e1 * 2. - 1E-1 + +x",
      [](double x, double, double) { return 5.0 * 2 - 0.1 + x; });
}

TEST_CASE("sdf_expression: precedence and associativity") {
  check_formula("1 - 2 - x", [](double x, double, double) { return -1 - x; });
  check_formula("8 / 2 / x", [](double x, double, double) { return 4 / x; });
  check_formula(
      "1 + 2 * x ^ 2", [](double x, double, double) { return 1 + 2 * x * x; });
  check_formula("-x^2", [](double x, double, double) { return -(x * x); });
  check_formula("(-x)^2", [](double x, double, double) { return x * x; });
  check_formula("-2^2", [](double, double, double) { return -4; });
  check_formula("2^3^2", [](double, double, double) { return 512; });
  check_formula(
      "2^-x", [](double x, double, double) { return std::pow(2, -x); });
  check_formula("-x*y", [](double x, double y, double) { return -x * y; });
  check_formula("- - x", [](double x, double, double) { return x; });
  check_formula("x - -1", [](double x, double, double) { return x + 1; });
  check_formula(
      "((((x))))*(y)", [](double x, double y, double) { return x * y; });
}

TEST_CASE("sdf_expression: powers are lowered to clauses") {
  // Integer powers: squares and products, no exp or ln.
  for (auto n = -9; n <= 9; n++) {
    CAPTURE(n);
    auto text    = "x^" + std::to_string(n);
    auto program = parse(text);
    CHECK(count_type(program, sdf_type::math_exp) == 0);
    for (auto p : test_points)
      CHECK(eval_reference(program, p) ==
            doctest::Approx(std::pow((double)p.x, n)).epsilon(1e-5));
  }
  // x^8 is three squares; x^0 is the constant 1, without an unused x.
  CHECK(count_type(parse("x^8"), sdf_type::math_square) == 3);
  CHECK(parse("x^8").nodes.size() == 4);
  CHECK(parse("x^0").nodes.size() == 1);
  CHECK(parse("x^0").nodes[0].type == sdf_type::math_const);
  // x^-2 = 1 / square(x); a folded negative exponent.
  auto inverse = parse("x^-2");
  CHECK(inverse.nodes.back().type == sdf_type::math_div);
  // x^0.5 is one sqrt.
  CHECK(parse("z^0.5").nodes.back().type == sdf_type::math_sqrt);
  CHECK(parse("z^0.5").nodes.size() == 2);
  // A general power: exp(b * ln(a)); NaN for a negative base.
  auto general = parse("x^y");
  CHECK(general.nodes.back().type == sdf_type::math_exp);
  CHECK(std::isnan(eval_reference(general, {-2, 0.5f, 0})));
  CHECK(
      eval_reference(general, {2, 0.5f, 0}) == doctest::Approx(std::sqrt(2.0)));
  CHECK(eval_reference(parse("x^1.5"), {4, 0, 0}) == doctest::Approx(8));
}

TEST_CASE("sdf_expression: folding, sharing and unused clauses") {
  // A negative number is one constant.
  auto negative = parse("-2.5");
  REQUIRE(negative.nodes.size() == 1);
  CHECK(negative.nodes[0].value == -2.5f);
  // mix uses its first argument twice: one clause, two users.
  auto mix = parse("mix(sqrt(x), y, z)");
  CHECK(count_type(mix, sdf_type::math_sqrt) == 1);
  auto users = 0;
  for (auto& node : mix.nodes) {
    auto sqrt = 1;  // the sqrt is the second node
    users += node.left == sqrt || node.right == sqrt;
  }
  CHECK(users == 2);
  // Operands come before their users, the root is last.
  for (auto i = 0; i < (int)mix.nodes.size(); i++) {
    CHECK(mix.nodes[i].left < i);
    CHECK(mix.nodes[i].right < i);
  }
}

TEST_CASE("sdf_expression: named operands") {
  auto program  = sdf_program{};
  auto shape    = sdf_node{};
  shape.type    = sdf_type::sphere;
  shape.radius  = 1;
  auto sphere   = add_node(program, shape);
  auto operands = std::vector<sdf_expression_operand>{{"ball", sphere}};
  auto root = parse_sdf_expression(program, "ball + 0.1*sin(ball)", operands);
  CHECK(operands[0].uses == 2);
  CHECK(root == root_node(program));
  // The sphere node is shared, not copied.
  CHECK(count_type(program, sdf_type::sphere) == 1);
  CHECK(program.nodes[root].left == sphere);
  // An expression that is only the operand adds nothing.
  auto alone = parse_sdf_expression(program, "(ball)", operands);
  CHECK(alone == sphere);
  CHECK(is_expression_operand_name("ball"));
  CHECK(is_expression_operand_name("s_1"));
  CHECK_FALSE(is_expression_operand_name("x"));
  CHECK_FALSE(is_expression_operand_name("pi"));
  CHECK_FALSE(is_expression_operand_name("sin"));
  CHECK_FALSE(is_expression_operand_name("1a"));
  CHECK_FALSE(is_expression_operand_name("a-b"));
  CHECK_FALSE(is_expression_operand_name(""));
}

TEST_CASE("sdf_expression: errors name the column") {
  CHECK(parse_error("max(x, y") == "column 9: expected ')'");
  CHECK(parse_error("sqrt(x*x + y*y + (z") == "column 20: expected ')'");
  CHECK(parse_error("") ==
        "column 1: expected a number, a variable, a function or '(', found "
        "the end");
  CHECK(parse_error("x +") ==
        "column 4: expected a number, a variable, a function or '(', found "
        "the end");
  CHECK(parse_error("x * * y") ==
        "column 5: expected a number, a variable, a function or '(', found "
        "'*'");
  CHECK(parse_error("2x") == "column 2: expected an operator, found \"x\"");
  CHECK(parse_error("x y") == "column 3: expected an operator, found \"y\"");
  CHECK(parse_error("x)") == "column 2: unexpected ')' (no '(' to close)");
  CHECK(parse_error("(x, y)") ==
        "column 3: ',' outside the arguments of a function");
  CHECK(parse_error("x, y") ==
        "column 2: ',' outside the arguments of a function");
  CHECK(parse_error("sqrt()") ==
        "column 6: expected a number, a variable, a function or '(', found "
        "')'");
  CHECK(parse_error("1 + sqrt(x, y)") ==
        "column 5: sqrt takes 1 argument, found 2");
  CHECK(
      parse_error("atan2(x)") == "column 1: atan2 takes 2 arguments, found 1");
  CHECK(parse_error("min(x)") ==
        "column 1: min takes at least 2 arguments, found 1");
  CHECK(parse_error("clamp(x, 1)") ==
        "column 1: clamp takes 3 arguments, found 2");
  CHECK(parse_error("2 * foo(x)") ==
        "column 5: unknown function \"foo\" (functions: sqrt, abs, sin, "
        "cos, tan, asin, acos, atan, atan2, exp, log, min, max, floor, "
        "ceil, round, mod, clamp, mix, square)");
  CHECK(parse_error("x + w") ==
        "column 5: unknown variable \"w\" (variables: x, y, z, pi)");
  CHECK(parse_error("sin + 1") ==
        "column 5: expected '(' after the function sin");
  CHECK(parse_error("x % 2") == "column 3: unexpected character '%'");
  CHECK(parse_error("x\x01") == "column 2: unexpected byte 1");
  CHECK(parse_error("1e+") == "column 1: bad number \"1e+\"");
  CHECK(parse_error("2.5ex") == "column 1: bad number \"2.5ex\"");
  CHECK(parse_error("1e39 * x") ==
        "column 1: number \"1e39\" is out of the range of 32-bit floats");
  CHECK(parse_error("x +" + std::string(40, 'a')) ==
        "column 4: unknown variable \"aaaaaaaaaaaaaaaaaaaaaaaa...\" "
        "(variables: x, y, z, pi)");
  // Named operands are listed among the variables.
  auto program  = sdf_program{};
  auto node     = sdf_node{};
  auto root     = add_node(program, node);
  auto operands = std::vector<sdf_expression_operand>{{"shape", root}};
  auto message  = std::string{};
  try {
    parse_sdf_expression(program, "shape + q", operands);
  } catch (const io_error& error) { message = error.what(); }
  CHECK(message ==
        "column 9: unknown variable \"q\" (variables: x, y, z, pi, shape)");
  // A failed parse leaves the program as it was.
  CHECK(program.nodes.size() == 1);
}

TEST_CASE("sdf_expression: hostile input") {
  // A million '(' use the parser's own stack: an error, no overflow.
  auto deep = std::string(1000000, '(');
  CHECK(parse_error(deep) ==
        "column 1000001: expected a number, a variable, a function or '(', "
        "found the end");
  CHECK(parse_error(deep + "x") == "column 1000002: expected ')'");
  // Deep but balanced nesting parses.
  auto nested = std::string(100000, '(') + "x" + std::string(100000, ')');
  CHECK(parse(nested).nodes.size() == 1);
  auto calls = std::string{};
  for (auto i = 0; i < 20000; i++) calls += "sin(";
  calls += "x" + std::string(20000, ')');
  CHECK(parse(calls).nodes.size() == 20001);
  // The clause limit: one clause more than allowed is refused.
  auto many = std::string{"x"};
  many.reserve(4 * sdf_max_clauses);
  for (auto i = 0; i < sdf_max_clauses / 2; i++) many += "+x";
  auto error = parse_error(many);
  CHECK(error.find(": more than 1048576 clauses (the most one expression may "
                   "hold)") != std::string::npos);
  CHECK(error.rfind("column ", 0) == 0);
}
