// Tests of dual.h: dual<float> derivatives against central differences of the
// point formulas, dual<interval> enclosing dual<float> (value and partials)
// at random points of random boxes, and gradient_bound as a Lipschitz bound.

#include "dual.h"

#include <doctest/doctest.h>

#include <sstream>
#include <string>

#include "random.h"

namespace implicit {
namespace {

// The clause's operands as functions of the point, with derivatives: an
// affine-plus-product map of p into [c - 1.5 s, c + 1.5 s] for p in [-1,1]^3,
// so that each operand depends on all three coordinates.
struct operand_map {
  float c = 0, s = 1, k = 0.5f;
};
template <class T>
dual<T> eval_operand(const operand_map& m, const dual<T> p[3]) {
  auto c = make_dual_constant(T(m.c)), s = make_dual_constant(T(m.s));
  auto k = make_dual_constant(T(m.k));
  return c + s * (p[0] + k * p[1] * p[2]);
}
inline float eval_operand(const operand_map& m, vec3f p) {
  return m.c + m.s * (p.x + m.k * p.y * p.z);
}

template <class Clause>
void check_unary_derivatives(const char* name, Clause clause, operand_map m) {
  auto rng     = make_rng(3);
  auto checked = 0, skipped = 0, misses = 0;
  auto first = std::string{};
  for (auto n = 0; n < 2000; n++) {
    auto        x = 2 * rand1f(rng) - 1, y = 2 * rand1f(rng) - 1;
    auto        z     = 2 * rand1f(rng) - 1;
    auto        p     = vec3f{x, y, z};
    dual<float> dp[3] = {make_dual_variable(x, 0), make_dual_variable(y, 1),
        make_dual_variable(z, 2)};
    auto        d     = clause(eval_operand(m, dp));
    CHECK(d.v == clause(eval_operand(m, p)));
    for (auto axis = 0; axis < 3; axis++) {
      // Central differences at two steps: where they disagree a kink or a
      // jump lies within a step, and the point is skipped.
      auto fd = [&](float h) {
        auto pp = p, pm = p;
        at(pp, axis) += h;
        at(pm, axis) -= h;
        return (clause(eval_operand(m, pp)) - clause(eval_operand(m, pm))) /
               (at(pp, axis) - at(pm, axis));
      };
      auto f1 = fd(1e-3f), f2 = fd(2.5e-4f);
      auto scale = std::max(1.0f, std::abs(f2));
      if (std::abs(f1 - f2) > 2e-3f * scale) {
        skipped++;
        continue;
      }
      checked++;
      if (std::abs(d.d[axis] - f2) <= 5e-3f * scale) continue;
      if (misses++ == 0) {
        auto stream = std::ostringstream{};
        stream << "at (" << x << ", " << y << ", " << z << ") axis " << axis
               << ": derivative " << d.d[axis] << ", differences " << f2;
        first = stream.str();
      }
    }
  }
  CHECK_MESSAGE(misses == 0, name, ": ", misses, " of ", checked,
      " partials differ from central differences; ", first);
  // The kinks and jumps of the clause lie on a few surfaces only.
  CHECK_MESSAGE(skipped < checked / 10, name, ": ", skipped, " skipped");
}

template <class Clause>
void check_binary_derivatives(
    const char* name, Clause clause, operand_map ma, operand_map mb) {
  auto rng     = make_rng(5);
  auto checked = 0, skipped = 0, misses = 0;
  auto first  = std::string{};
  auto eval_f = [&](vec3f q) {
    // b swaps the roles of the coordinates so that a and b differ.
    return clause(eval_operand(ma, q), eval_operand(mb, vec3f{q.z, q.x, q.y}));
  };
  for (auto n = 0; n < 2000; n++) {
    auto        x = 2 * rand1f(rng) - 1, y = 2 * rand1f(rng) - 1;
    auto        z     = 2 * rand1f(rng) - 1;
    auto        p     = vec3f{x, y, z};
    dual<float> dp[3] = {make_dual_variable(x, 0), make_dual_variable(y, 1),
        make_dual_variable(z, 2)};
    dual<float> dq[3] = {dp[2], dp[0], dp[1]};
    auto        d     = clause(eval_operand(ma, dp), eval_operand(mb, dq));
    CHECK(d.v == eval_f(p));
    for (auto axis = 0; axis < 3; axis++) {
      auto fd = [&](float h) {
        auto pp = p, pm = p;
        at(pp, axis) += h;
        at(pm, axis) -= h;
        return (eval_f(pp) - eval_f(pm)) / (at(pp, axis) - at(pm, axis));
      };
      auto f1 = fd(1e-3f), f2 = fd(2.5e-4f);
      auto scale = std::max(1.0f, std::abs(f2));
      if (std::abs(f1 - f2) > 2e-3f * scale) {
        skipped++;
        continue;
      }
      checked++;
      if (std::abs(d.d[axis] - f2) <= 5e-3f * scale) continue;
      if (misses++ == 0) {
        auto stream = std::ostringstream{};
        stream << "at (" << x << ", " << y << ", " << z << ") axis " << axis
               << ": derivative " << d.d[axis] << ", differences " << f2;
        first = stream.str();
      }
    }
  }
  CHECK_MESSAGE(misses == 0, name, ": ", misses, " of ", checked,
      " partials differ from central differences; ", first);
  CHECK_MESSAGE(skipped < checked / 10, name, ": ", skipped, " skipped");
}

// Operand maps: values in [-4.5, 4.5] unless the domain is smaller.
constexpr auto wide     = operand_map{0, 3, 0.5f};
constexpr auto positive = operand_map{2, 1, 0.5f};
constexpr auto unit     = operand_map{0, 0.6f, 0.5f};
constexpr auto branch   = operand_map{0, 0.9f, 0.5f};
constexpr auto other    = operand_map{0.5f, 2, -0.7f};
constexpr auto divisor  = operand_map{3, 1, 0.5f};
constexpr auto negative = operand_map{-3, 1, 0.5f};

#define CHECK_UNARY_DERIVATIVES(clause, map) \
  check_unary_derivatives(                   \
      #clause, [](const auto& a) { return clause(a); }, map);
#define CHECK_BINARY_DERIVATIVES(clause, map_a, map_b)                    \
  check_binary_derivatives(                                               \
      #clause, [](const auto& a, const auto& b) { return clause(a, b); }, \
      map_a, map_b);

TEST_CASE("dual: derivatives of every clause match central differences") {
  CHECK_UNARY_DERIVATIVES(math_neg, wide)
  CHECK_UNARY_DERIVATIVES(math_abs, wide)
  CHECK_UNARY_DERIVATIVES(math_square, wide)
  CHECK_UNARY_DERIVATIVES(math_sqrt, positive)
  CHECK_UNARY_DERIVATIVES(math_exp, wide)
  CHECK_UNARY_DERIVATIVES(math_log, positive)
  CHECK_UNARY_DERIVATIVES(math_sin, wide)
  CHECK_UNARY_DERIVATIVES(math_cos, wide)
  CHECK_UNARY_DERIVATIVES(math_tan, branch)
  CHECK_UNARY_DERIVATIVES(math_asin, unit)
  CHECK_UNARY_DERIVATIVES(math_acos, unit)
  CHECK_UNARY_DERIVATIVES(math_atan, wide)
  CHECK_UNARY_DERIVATIVES(math_floor, wide)
  CHECK_UNARY_DERIVATIVES(math_ceil, wide)
  CHECK_UNARY_DERIVATIVES(math_round, wide)
  CHECK_UNARY_DERIVATIVES(math_not, wide)
  CHECK_BINARY_DERIVATIVES(math_add, wide, other)
  CHECK_BINARY_DERIVATIVES(math_sub, wide, other)
  CHECK_BINARY_DERIVATIVES(math_mul, wide, other)
  CHECK_BINARY_DERIVATIVES(math_div, wide, divisor)
  CHECK_BINARY_DERIVATIVES(math_min, wide, other)
  CHECK_BINARY_DERIVATIVES(math_max, wide, other)
  CHECK_BINARY_DERIVATIVES(math_atan2, wide, other)
  CHECK_BINARY_DERIVATIVES(math_mod, wide, divisor)
  CHECK_BINARY_DERIVATIVES(math_mod, wide, negative)
  CHECK_BINARY_DERIVATIVES(math_compare, wide, other)
  CHECK_BINARY_DERIVATIVES(math_and, wide, other)
  CHECK_BINARY_DERIVATIVES(math_or, wide, other)
}

// Whether every part of the point dual lies in the box dual, and a box
// value that may be NaN has unknown derivatives.
bool encloses(const dual<interval>& box, const dual<float>& point) {
  for (auto i = 0; i < 3; i++) {
    if (!contains(box.d[i], point.d[i])) return false;
    if (is_entire(box.v) && !is_entire(box.d[i])) return false;
  }
  return contains(box.v, point.v);
}

std::string describe(const dual<interval>& a) {
  auto stream = std::ostringstream{};
  stream.precision(9);
  stream << "[" << a.v.lo << ", " << a.v.hi << "]";
  for (auto i = 0; i < 3; i++)
    stream << " d" << i << " [" << a.d[i].lo << ", " << a.d[i].hi << "]";
  return stream.str();
}
std::string describe(const dual<float>& a) {
  auto stream = std::ostringstream{};
  stream.precision(9);
  stream << a.v << " d (" << a.d[0] << ", " << a.d[1] << ", " << a.d[2] << ")";
  return stream.str();
}

// A random box of [-1,1]^3 (sides from 1e-4 to 2) or of a wider cube that
// takes the operands out of their domains, and a point in it.
struct box3 {
  interval x[3];
};
box3 random_box3(rng_state& rng) {
  const float sides[] = {1e-4f, 1e-2f, 0.3f, 2};
  auto        extent  = rand1i(rng, 4) == 0 ? 4.0f : 1.0f;
  auto        box     = box3{};
  for (auto& x : box.x) {
    auto side = std::min(sides[rand1i(rng, 4)], 2 * extent);
    auto lo   = -extent + (2 * extent - side) * rand1f(rng);
    x         = {lo, lo + side};
  }
  return box;
}
vec3f random_point3(rng_state& rng, const box3& box) {
  auto p = vec3f{};
  for (auto i = 0; i < 3; i++) {
    auto u   = rand1f(rng);
    at(p, i) = std::min(box.x[i].lo + width(box.x[i]) * u, box.x[i].hi);
  }
  return p;
}

// Count the points where dual<interval> over a box misses dual<float>.
template <class Clause>
int count_dual_misses(Clause clause, std::string& first) {
  auto rng    = make_rng(13);
  auto misses = 0;
  for (auto n = 0; n < 3000; n++) {
    auto           box   = random_box3(rng);
    dual<interval> bp[3] = {make_dual_variable(box.x[0], 0),
        make_dual_variable(box.x[1], 1), make_dual_variable(box.x[2], 2)};
    auto           r     = clause(bp);
    for (auto k = 0; k < 8; k++) {
      auto        p     = random_point3(rng, box);
      dual<float> dp[3] = {make_dual_variable(p.x, 0),
          make_dual_variable(p.y, 1), make_dual_variable(p.z, 2)};
      auto        d     = clause(dp);
      if (encloses(r, d)) continue;
      if (misses++ == 0) {
        auto stream = std::ostringstream{};
        stream << "at (" << p.x << ", " << p.y << ", " << p.z
               << "): " << describe(r) << " misses " << describe(d);
        first = stream.str();
      }
    }
  }
  return misses;
}

#define CHECK_DUAL_UNARY(clause, map)                                       \
  SUBCASE(#clause) {                                                        \
    auto first  = std::string{};                                            \
    auto misses = count_dual_misses(                                        \
        [](const auto* p) { return clause(eval_operand(map, p)); }, first); \
    CHECK_MESSAGE(misses == 0, #clause ": ", first);                        \
  }
#define CHECK_DUAL_BINARY(clause, map_a, map_b)                          \
  SUBCASE(#clause) {                                                     \
    auto first  = std::string{};                                         \
    auto misses = count_dual_misses(                                     \
        [](const auto* p) {                                              \
          using value_t = std::decay_t<decltype(p[0])>;                  \
          value_t q[3]  = {p[2], p[0], p[1]};                            \
          return clause(eval_operand(map_a, p), eval_operand(map_b, q)); \
        },                                                               \
        first);                                                          \
    CHECK_MESSAGE(misses == 0, #clause ": ", first);                     \
  }

TEST_CASE("dual: dual<interval> encloses dual<float> for every clause"){
    // The wide maps cross kinks, jumps, poles and domain edges in most boxes.
    CHECK_DUAL_UNARY(math_neg, wide) CHECK_DUAL_UNARY(math_abs,
        wide) CHECK_DUAL_UNARY(math_square, wide) CHECK_DUAL_UNARY(math_sqrt,
        wide) CHECK_DUAL_UNARY(math_sqrt, positive) CHECK_DUAL_UNARY(math_exp,
        wide) CHECK_DUAL_UNARY(math_log, wide) CHECK_DUAL_UNARY(math_log,
        positive) CHECK_DUAL_UNARY(math_sin, wide) CHECK_DUAL_UNARY(math_cos,
        wide) CHECK_DUAL_UNARY(math_tan, wide) CHECK_DUAL_UNARY(math_asin, wide)
        CHECK_DUAL_UNARY(math_asin, unit) CHECK_DUAL_UNARY(math_acos,
            unit) CHECK_DUAL_UNARY(math_atan, wide) CHECK_DUAL_UNARY(math_floor,
            wide) CHECK_DUAL_UNARY(math_ceil, wide) CHECK_DUAL_UNARY(math_round,
            wide) CHECK_DUAL_UNARY(math_not, wide) CHECK_DUAL_BINARY(math_add,
            wide, other) CHECK_DUAL_BINARY(math_sub, wide, other)
            CHECK_DUAL_BINARY(math_mul, wide, other) CHECK_DUAL_BINARY(
                math_div, wide, other) CHECK_DUAL_BINARY(math_min, wide, other)
                CHECK_DUAL_BINARY(math_max, wide, other)
                    CHECK_DUAL_BINARY(math_atan2, wide, other)
                        CHECK_DUAL_BINARY(math_mod, wide, other)
                            CHECK_DUAL_BINARY(math_compare, wide, other)
                                CHECK_DUAL_BINARY(math_and, wide, other)
                                    CHECK_DUAL_BINARY(math_or, wide, other)}

TEST_CASE("dual: jumps and singularities give unbounded box derivatives") {
  auto x = make_dual_variable(interval{0.5f, 1.5f}, 0);
  CHECK(is_entire(math_floor(x).d[0]));
  CHECK(math_floor(make_dual_variable(interval{0.25f, 0.75f}, 0)).d[0] ==
        interval{0, 0});
  CHECK(is_entire(math_sqrt(make_dual_variable(interval{0, 1}, 0)).d[0]));
  CHECK(gradient_bound(math_floor(x)) == flt_inf);
  // NaN everywhere (ln of a negative): no slope is known.
  CHECK(gradient_bound(math_log(make_dual_variable(interval{-2, -1}, 0))) ==
        flt_inf);
  // A point derivative of floor is 0 even on the jump.
  CHECK(math_floor(make_dual_variable(1.0f, 0)).d[0] == 0);
  // Kinks: |x| over a box holding 0 has slopes in [-1, 1].
  auto a = math_abs(make_dual_variable(interval{-1, 2}, 0));
  CHECK(a.d[0] == interval{-1, 1});
}

TEST_CASE("dual: gradient_bound bounds the slope between points of the box") {
  // f = sin(3 x y) + exp(z) / (2 + x) - atan2(y, x + 3)
  auto f = [](const auto* p) {
    using value = std::decay_t<decltype(p[0].v)>;
    auto k      = [](float c) { return make_dual_constant(value(c)); };
    return math_sin(k(3) * p[0] * p[1]) + math_exp(p[2]) / (k(2) + p[0]) -
           math_atan2(p[1], p[0] + k(3));
  };
  auto rng = make_rng(17);
  for (auto n = 0; n < 500; n++) {
    auto           box   = random_box3(rng);
    dual<interval> bp[3] = {make_dual_variable(box.x[0], 0),
        make_dual_variable(box.x[1], 1), make_dual_variable(box.x[2], 2)};
    auto           bound = gradient_bound(f(bp));
    for (auto k = 0; k < 8; k++) {
      auto        p     = random_point3(rng, box);
      auto        q     = random_point3(rng, box);
      dual<float> dp[3] = {make_dual_variable(p.x, 0),
          make_dual_variable(p.y, 1), make_dual_variable(p.z, 2)};
      dual<float> dq[3] = {make_dual_variable(q.x, 0),
          make_dual_variable(q.y, 1), make_dual_variable(q.z, 2)};
      auto        slope = std::abs(f(dp).v - f(dq).v);
      // Float rounding of the two values: a few ulps of their size.
      auto noise = 1e-5f * (1 + std::abs(f(dp).v));
      CHECK(slope <= bound * distance(p, q) + noise);
      CHECK(length(gradient(f(dp))) <= bound);
    }
  }
}

}  // namespace
}  // namespace implicit
