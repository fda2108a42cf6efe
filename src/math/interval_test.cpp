// Property tests of interval.h: every clause's interval encloses its point
// formula at random points of random boxes, edge cases included (0 in a
// divisor, domain edges, infinities, huge arguments to sin, single points),
// NaN points only inside entire intervals; and exact results where the
// rules decide them.

#include "interval.h"

#include <doctest/doctest.h>

#include <sstream>
#include <string>

#include "random.h"

namespace implicit {
namespace {

// Endpoints that sit on the edges of some clause's domain or behaviour.
const float special_values[] = {0.0f, -0.0f, 1, -1, 0.5f, -0.5f, 2, -2, pif / 2,
    -pif / 2, pif, -pif, 2 * pif, -2 * pif, 1e-30f, -1e-30f, 1e-40f, -1e-40f,
    0.99999994f, -0.99999994f, 1.0000001f, -1.0000001f, 3, 100.5f, -100.5f,
    1e4f, -1e4f, 1e8f, -1e8f, 1e30f, -1e30f, flt_max, flt_lowest, flt_inf,
    -flt_inf};

float random_special(rng_state& rng) {
  return special_values[rand1i(
      rng, (int)(sizeof(special_values) / sizeof(special_values[0])))];
}

// A float drawn uniformly among the floats of [lo, hi] (every scale alike).
float random_float_order(rng_state& rng, float lo, float hi) {
  auto a = (double)float_order(lo), b = (double)float_order(hi);
  auto o = (int32_t)std::floor(a + (b - a + 1) * (double)rand1f(rng));
  return std::min(std::max(order_float(o), lo), hi);
}

// A random box: two special ends, a centred box at some scale, a single
// point, or a special end and a random one.
interval random_box(rng_state& rng) {
  auto mode = rand1i(rng, 5);
  if (mode == 0) {
    auto a = random_special(rng);
    auto b = random_special(rng);
    return {std::min(a, b), std::max(a, b)};
  } else if (mode == 1 || mode == 2) {
    const float scales[] = {1e-3f, 1, 10, 1e3f, 1e6f, 1e9f};
    const float widths[] = {0, 1e-6f, 1e-3f, 0.1f, 1, 3};
    auto        scale    = scales[rand1i(rng, 6)];
    auto        w        = scale * widths[rand1i(rng, 6)];
    auto        c        = scale * (2 * rand1f(rng) - 1);
    auto        u1       = rand1f(rng);
    auto        u2       = rand1f(rng);
    return {c - w * u1, c + w * u2};
  } else if (mode == 3) {
    auto a = rand1i(rng, 2) ? random_special(rng)
                            : random_float_order(rng, -1e6f, 1e6f);
    return {a, a};
  } else {
    auto a = random_special(rng);
    auto b = random_float_order(rng, -1e3f, 1e3f);
    return {std::min(a, b), std::max(a, b)};
  }
}

// A random point of the box: an end, 0, a uniform real or a uniform float.
float random_point(rng_state& rng, interval box) {
  auto mode = rand1i(rng, 6);
  if (mode == 0) return box.lo;
  if (mode == 1) return box.hi;
  if (mode == 2 && box.lo <= 0 && box.hi >= 0) return 0.0f;
  if (mode <= 3) {
    auto x = box.lo + (box.hi - box.lo) * rand1f(rng);
    if (std::isfinite(x)) return std::min(std::max(x, box.lo), box.hi);
  }
  return random_float_order(rng, box.lo, box.hi);
}

std::string describe(interval a) {
  auto stream = std::ostringstream{};
  stream.precision(9);
  stream << "[" << a.lo << ", " << a.hi << "]";
  return stream.str();
}

// Boxes and points per clause.
constexpr int boxes_per_clause  = 20000;
constexpr int points_per_box    = 8;
constexpr int points_per_clause = boxes_per_clause * points_per_box;

// Count the points where the unary clause's interval misses the point value;
// `first` tells the first miss.
template <class Clause>
int count_unary_misses(Clause clause, std::string& first) {
  auto rng    = make_rng(7);
  auto misses = 0;
  for (auto b = 0; b < boxes_per_clause; b++) {
    auto box    = random_box(rng);
    auto result = clause(box);
    if (!(result.lo <= result.hi)) misses++;
    for (auto k = 0; k < points_per_box; k++) {
      auto x = random_point(rng, box);
      auto v = clause(x);
      if (contains(result, v)) continue;
      if (misses++ == 0) {
        auto stream = std::ostringstream{};
        stream.precision(9);
        stream << "box " << describe(box) << " -> " << describe(result)
               << " misses f(" << x << ") = " << v;
        first = stream.str();
      }
    }
  }
  return misses;
}

template <class Clause>
int count_binary_misses(Clause clause, std::string& first) {
  auto rng    = make_rng(11);
  auto misses = 0;
  for (auto b = 0; b < boxes_per_clause; b++) {
    auto box_a  = random_box(rng);
    auto box_b  = random_box(rng);
    auto result = clause(box_a, box_b);
    if (!(result.lo <= result.hi)) misses++;
    for (auto k = 0; k < points_per_box; k++) {
      auto x = random_point(rng, box_a);
      auto y = random_point(rng, box_b);
      auto v = clause(x, y);
      if (contains(result, v)) continue;
      if (misses++ == 0) {
        auto stream = std::ostringstream{};
        stream.precision(9);
        stream << "boxes " << describe(box_a) << ", " << describe(box_b)
               << " -> " << describe(result) << " misses f(" << x << ", " << y
               << ") = " << v;
        first = stream.str();
      }
    }
  }
  return misses;
}

#define CHECK_UNARY_CLAUSE(clause)                                             \
  SUBCASE(#clause) {                                                           \
    auto first  = std::string{};                                               \
    auto misses = count_unary_misses([](auto a) { return clause(a); }, first); \
    CHECK_MESSAGE(misses == 0, #clause ": ", misses, " of ",                   \
        points_per_clause, " points outside their box's interval; ", first);   \
  }
#define CHECK_BINARY_CLAUSE(clause)                                          \
  SUBCASE(#clause) {                                                         \
    auto first  = std::string{};                                             \
    auto misses = count_binary_misses(                                       \
        [](auto a, auto b) { return clause(a, b); }, first);                 \
    CHECK_MESSAGE(misses == 0, #clause ": ", misses, " of ",                 \
        points_per_clause, " points outside their box's interval; ", first); \
  }

TEST_CASE("interval: every unary clause encloses its point formula"){
    CHECK_UNARY_CLAUSE(math_neg) CHECK_UNARY_CLAUSE(
        math_abs) CHECK_UNARY_CLAUSE(math_square) CHECK_UNARY_CLAUSE(math_sqrt)
        CHECK_UNARY_CLAUSE(math_exp) CHECK_UNARY_CLAUSE(
            math_log) CHECK_UNARY_CLAUSE(math_sin) CHECK_UNARY_CLAUSE(math_cos)
            CHECK_UNARY_CLAUSE(math_tan) CHECK_UNARY_CLAUSE(math_asin)
                CHECK_UNARY_CLAUSE(math_acos) CHECK_UNARY_CLAUSE(math_atan)
                    CHECK_UNARY_CLAUSE(math_floor) CHECK_UNARY_CLAUSE(math_ceil)
                        CHECK_UNARY_CLAUSE(math_round)
                            CHECK_UNARY_CLAUSE(math_not)}

TEST_CASE("interval: every binary clause encloses its point formula") {
  CHECK_BINARY_CLAUSE(math_add)
  CHECK_BINARY_CLAUSE(math_sub)
  CHECK_BINARY_CLAUSE(math_mul)
  CHECK_BINARY_CLAUSE(math_div)
  CHECK_BINARY_CLAUSE(math_min)
  CHECK_BINARY_CLAUSE(math_max)
  CHECK_BINARY_CLAUSE(math_atan2)
  CHECK_BINARY_CLAUSE(math_mod)
  CHECK_BINARY_CLAUSE(math_compare)
  CHECK_BINARY_CLAUSE(math_and)
  CHECK_BINARY_CLAUSE(math_or)
}

// Count the points where the clause's interval misses the real result, the
// double-precision reference at the float points (finite results only).
template <class Clause, class Reference>
int count_real_misses(Clause clause, Reference reference, int arity) {
  auto rng    = make_rng(19);
  auto misses = 0;
  for (auto b = 0; b < boxes_per_clause; b++) {
    auto box_a  = random_box(rng);
    auto box_b  = arity == 2 ? random_box(rng) : interval{1, 1};
    auto result = clause(box_a, box_b);
    for (auto k = 0; k < points_per_box; k++) {
      auto x   = random_point(rng, box_a);
      auto y   = random_point(rng, box_b);
      auto ref = reference((double)x, (double)y);
      if (!std::isfinite(ref) || std::abs(ref) > flt_max) continue;
      if (!((double)result.lo <= ref && ref <= (double)result.hi)) misses++;
    }
  }
  return misses;
}

TEST_CASE("interval: clauses enclose the real result, not only the float") {
  // Rounding to nearest is monotone, so unwidened ends would still hold the
  // float results; the real result needs the outward rounding.
  auto add = [](auto a, auto b) { return math_add(a, b); };
  auto sub = [](auto a, auto b) { return math_sub(a, b); };
  auto mul = [](auto a, auto b) { return math_mul(a, b); };
  auto div = [](auto a, auto b) { return math_div(a, b); };
  CHECK(count_real_misses(
            add, [](double a, double b) { return a + b; }, 2) == 0);
  CHECK(count_real_misses(
            sub, [](double a, double b) { return a - b; }, 2) == 0);
  CHECK(count_real_misses(
            mul, [](double a, double b) { return a * b; }, 2) == 0);
  CHECK(count_real_misses(
            div, [](double a, double b) { return a / b; }, 2) == 0);
  CHECK(count_real_misses([](auto a, auto) { return math_sqrt(a); },
            [](double a, double) { return std::sqrt(a); }, 1) == 0);
  CHECK(count_real_misses([](auto a, auto) { return math_exp(a); },
            [](double a, double) { return std::exp(a); }, 1) == 0);
  CHECK(count_real_misses([](auto a, auto) { return math_log(a); },
            [](double a, double) { return std::log(a); }, 1) == 0);
  CHECK(count_real_misses([](auto a, auto) { return math_sin(a); },
            [](double a, double) { return std::sin(a); }, 1) == 0);
  CHECK(count_real_misses([](auto a, auto) { return math_tan(a); },
            [](double a, double) { return std::tan(a); }, 1) == 0);
  CHECK(count_real_misses([](auto a, auto b) { return math_atan2(a, b); },
            [](double a, double b) { return std::atan2(a, b); }, 2) == 0);
}

TEST_CASE("interval: sin and cos find extrema at large arguments") {
  // Boxes a few floats wide around x0 = k pi/2 (|k| up to 1e6), where sin
  // (k odd) or cos (k even) is 1 or -1: a box that holds x0 (checked in
  // double) must reach it, since the real function does; x0 is often within
  // the rounding error of (x - phase) / period from an end.
  auto rng    = make_rng(23);
  auto misses = 0, held = 0;
  for (auto n = 0; n < 200000; n++) {
    auto k  = rand1i(rng, 2000000) - 1000000;
    auto x0 = k * 1.5707963267948966;
    auto c  = (float)x0;
    auto box =
        interval{float_down(c, rand1i(rng, 3)), float_up(c, rand1i(rng, 3))};
    if (!((double)box.lo <= x0 && x0 <= (double)box.hi)) continue;
    held++;
    auto turn  = ((k % 4) + 4) % 4;  // x0 = pi/2 turn (mod 2 pi)
    auto range = turn % 2 ? math_sin(box) : math_cos(box);
    auto peak  = turn == 0 || turn == 1;
    if (peak ? range.hi != 1 : range.lo != -1) misses++;
  }
  CHECK(held > 50000);
  CHECK(misses == 0);
}

TEST_CASE("interval: the NaN rule on domain edges and entire arguments") {
  auto e = entire_interval;
  // A divisor holding 0 (either zero, or inside) gives entire.
  CHECK(is_entire(math_div(interval{1, 2}, interval{0, 1})));
  CHECK(is_entire(math_div(interval{1, 2}, interval{-1, 0})));
  CHECK(is_entire(math_div(interval{1, 2}, interval{0, 0})));
  CHECK(!is_entire(math_div(interval{1, 2}, interval{0.5f, 1})));
  // Domain edges: a negative under sqrt or log, asin beyond 1.
  CHECK(is_entire(math_sqrt(interval{-1e-30f, 4})));
  CHECK(math_sqrt(interval{0, 4}).lo == 0);
  CHECK(math_log(interval{0, 1}).lo == -flt_inf);
  CHECK(is_entire(math_log(interval{-1, 1})));
  CHECK(is_entire(math_asin(interval{0, 1.0000001f})));
  CHECK(!is_entire(math_acos(interval{-1, 1})));
  CHECK(is_entire(math_mod(interval{1, 2}, interval{-1, 1})));
  CHECK(is_entire(math_mod(interval{1, flt_inf}, interval{2, 2})));
  // 0 * inf and inf - inf are NaN.
  CHECK(is_entire(math_mul(interval{0, 1}, interval{1, flt_inf})));
  CHECK(is_entire(math_sub(interval{flt_inf, flt_inf}, interval{1, flt_inf})));
  // An entire argument stays entire where NaN propagates.
  CHECK(is_entire(math_exp(e)));
  CHECK(is_entire(math_atan(e)));
  CHECK(is_entire(math_abs(e)));
  CHECK(is_entire(math_square(e)));
  CHECK(is_entire(math_sin(e)));
  CHECK(is_entire(math_min(e, interval{0, 1})));
  CHECK(is_entire(math_max(interval{0, 1}, e)));
  CHECK(is_entire(math_compare(e, interval{0, 1})));
  CHECK(is_entire(math_atan2(interval{0, 1}, e)));
  CHECK(is_entire(math_or(e, interval{2, 3})));
  // ... but not where the point formula drops a NaN.
  CHECK(math_not(e) == interval{0, 1});
  CHECK(math_and(e, interval{2, 3}) == interval{0, 3});
  // sin(inf) is NaN.
  CHECK(is_entire(math_sin(interval{0, flt_inf})));
  CHECK(is_entire(math_cos(interval{-flt_inf, 0})));
  // A NaN constant is entire.
  CHECK(is_entire(interval{flt_nan}));
}

TEST_CASE("interval: bounds are tight where they can be") {
  // Outward rounding costs an ulp per operation, no more.
  auto sum = math_add(interval{1, 1}, interval{2, 2});
  CHECK(sum.lo == float_down(3, 1));
  CHECK(sum.hi == float_up(3, 1));
  // Exact results stay put: a sum or product from 0 starts at 0, so ln and
  // sqrt of sums of squares and exponentials see no negative.
  CHECK(math_add(interval{0, 1}, interval{0, 1}).lo == 0);
  CHECK(math_sub(interval{2, 3}, interval{2, 2}).lo == 0);
  CHECK(math_mul(interval{0, 1}, interval{0, 1}).lo == 0);
  auto tiny = interval{0, 1e-44f};
  CHECK(!is_entire(math_log(math_add(tiny, tiny))));
  auto square = math_square(interval{-1, 1});
  CHECK(!is_entire(math_sqrt(math_add(square, square))));
  CHECK(math_floor(interval{1.2f, 1.7f}) == interval{1, 1});
  CHECK(math_compare(interval{0, 1}, interval{2, 3}) == interval{-1, -1});
  CHECK(math_compare(interval{0, 2}, interval{2, 3}) == interval{-1, 0});
  CHECK(math_compare(interval{2, 2}, interval{2, 2}) == interval{0, 0});
  // Periodic functions: monotone pieces stay narrow, extrema are found.
  auto s = math_sin(interval{0.1f, 0.2f});
  CHECK(s.lo <= std::sin(0.1f));
  CHECK(s.hi >= std::sin(0.2f));
  CHECK(width(s) < 0.1f);
  CHECK(math_sin(interval{1.5f, 1.6f}).hi == 1);
  CHECK(math_cos(interval{3, 3.2f}).lo == -1);
  CHECK(math_cos(interval{-0.1f, 0.1f}).hi == 1);
  CHECK(math_sin(interval{0, 7}) == interval{-1, 1});
  // Huge arguments: a single point keeps libm's value, a box wider than a
  // period (every box, beyond 2^26) covers [-1, 1].
  auto huge = math_sin(interval{1e8f, 1e8f});
  CHECK(contains(huge, std::sin(1e8f)));
  CHECK(width(huge) < 1e-6f);
  CHECK(math_sin(interval{1e8f, float_up(1e8f, 1)}) == interval{-1, 1});
  // tan over a pole is entire, between poles increasing.
  CHECK(is_entire(math_tan(interval{1.5f, 1.6f})));
  CHECK(!is_entire(math_tan(interval{-1.5f, 1.5f})));
  // mod within a period is increasing, across a wrap covers [0, |b|].
  CHECK(math_mod(interval{2.25f, 2.75f}, interval{1, 1}) ==
        interval{0.25f, 0.75f});
  CHECK(math_mod(interval{-0.25f, 0.25f}, interval{1, 1}) == interval{0, 1});
  CHECK(math_mod(interval{0.25f, 0.5f}, interval{-1, -1}) ==
        interval{0.25f, 0.5f});
  // atan2 off the cut is bounded by the corners, on the cut [-pi, pi].
  auto angle = math_atan2(interval{1, 2}, interval{1, 2});
  CHECK(angle.lo > 0.4f);
  CHECK(angle.hi < 1.2f);
  CHECK(math_atan2(interval{-1, 1}, interval{-2, -1}).hi >= pif);
  CHECK(math_atan2(interval{0, 1}, interval{-2, -1}).lo <= -pif);
}

TEST_CASE("interval: a product by one number is the four corners' hull") {
  // mul_point's two corners give what the four of the general product
  // give, for any interval (infinite ends included) and any number.
  auto corners = [](interval a, float c) {
    auto lo = math_min(math_min(mul_down(a.lo, c), mul_down(a.hi, c)),
        math_min(mul_down(a.lo, c), mul_down(a.hi, c)));
    auto hi = math_max(math_max(mul_up(a.lo, c), mul_up(a.hi, c)),
        math_max(mul_up(a.lo, c), mul_up(a.hi, c)));
    return checked(lo, hi);
  };
  auto ends = {-flt_inf, -3.5f, -1.0f, -1e-30f, 0.0f, 2.0f, 7.25f, flt_inf};
  for (auto lo : ends)
    for (auto hi : ends) {
      if (!(lo <= hi)) continue;
      for (auto c : {-flt_inf, -2.5f, -1.0f, 0.0f, 1e-3f, 3.0f, flt_inf}) {
        auto a = interval{lo, hi};
        CHECK(mul_point(a, c) == corners(a, c));
        CHECK(math_mul(a, interval{c}) == corners(a, c));
        CHECK(math_mul(interval{c}, a) == corners(a, c));
      }
    }
  CHECK(is_entire(mul_point(interval{1, 2}, flt_nan)));
}

TEST_CASE("interval: float_up and float_down step one float, saturating") {
  CHECK(float_up(1, 1) == std::nextafter(1.0f, 2.0f));
  CHECK(float_down(1, 1) == std::nextafter(1.0f, 0.0f));
  CHECK(float_up(0.0f, 1) == std::numeric_limits<float>::denorm_min());
  CHECK(float_down(-0.0f, 1) == -std::numeric_limits<float>::denorm_min());
  CHECK(float_up(-std::numeric_limits<float>::denorm_min(), 1) == 0);
  CHECK(float_up(flt_max, 1) == flt_inf);
  CHECK(float_up(flt_inf, 4) == flt_inf);
  CHECK(float_down(flt_inf, 1) == flt_max);
  CHECK(float_down(-flt_inf, 4) == -flt_inf);
  CHECK(std::isnan(float_up(flt_nan, 1)));
}

}  // namespace
}  // namespace implicit
