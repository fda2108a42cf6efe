// # implicit: interval arithmetic
//
// Sound bounds of the expression clauses of IMPLICIT_SDF_MATH over boxes
// (Moore 1966), for per-cell tape simplification (Keeter 2020) and root
// isolation along rays (Knoll et al. 2009, "Fast Ray Tracing of Arbitrary
// Implicit Surfaces with Interval and Affine Arithmetic"). Each clause has one
// point formula here, math_<clause>(float...), which is the one the tape
// evaluates at points, and beside it the interval formula that encloses that
// point formula at every point of its argument boxes. Code written once over
// both value types (dual.h, the tape) uses the overloads and the predicates
// at the end of this file.
//
// Rounding: outward, one ulp per IEEE operation and `interval_libm_ulps` per
// libm call. + - * / and sqrt are correctly rounded, so the exact result lies
// within half an ulp of the rounded one, and rounding is monotone, so moving
// each endpoint out by one float encloses both the real result and every
// float result of points in the box (rounding to nearest alone would keep
// the float results in, but not the real ones that Lipschitz bounds and root
// isolation reason about). libm's float functions are neither
// correctly rounded (glibc documents up to 1-2 ulps for these) nor
// guaranteed monotone, hence the wider margin. This is pbrt-v4's choice
// (util/float.h NextFloatUp/NextFloatDown behind its Interval class) rather
// than switching the rounding mode with fesetround: the compiler may move
// arithmetic across that call, libm ignores it, and it costs a pipeline
// flush per switch.
//
// NaN: a point value NaN counts as outside wherever a sign is taken. An
// interval holds no NaN: where the value may be NaN it is [-inf, +inf]
// (entire_interval). Every clause whose point formula gives NaN for a NaN
// argument gives entire for an entire argument, and any NaN met while
// computing an endpoint (0 * inf, inf - inf) gives entire, so the rule holds
// through whole expressions. The price: an interval that is entire without
// any NaN (tan over a pole) is treated as possibly NaN downstream.
#pragma once

#include <cstdint>
#include <cstring>
#include <utility>

#include "math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// POINT CLAUSES (the tape's formulas at points)
// -----------------------------------------------------------------------------

inline constexpr float flt_nan = std::numeric_limits<float>::quiet_NaN();

inline float math_neg(float a) { return -a; }
inline float math_abs(float a) { return std::abs(a); }
inline float math_square(float a) { return a * a; }
inline float math_sqrt(float a) { return std::sqrt(a); }
inline float math_exp(float a) { return std::exp(a); }
inline float math_log(float a) { return std::log(a); }
inline float math_sin(float a) { return std::sin(a); }
inline float math_cos(float a) { return std::cos(a); }
inline float math_tan(float a) { return std::tan(a); }
inline float math_asin(float a) { return std::asin(a); }
inline float math_acos(float a) { return std::acos(a); }
inline float math_atan(float a) { return std::atan(a); }
inline float math_floor(float a) { return std::floor(a); }
inline float math_ceil(float a) { return std::ceil(a); }
// Nearest integer, halves away from zero.
inline float math_round(float a) { return std::round(a); }
// 1 if a == 0, else 0 (NaN gives 0).
inline float math_not(float a) { return a == 0 ? 1.0f : 0.0f; }
inline float math_add(float a, float b) { return a + b; }
inline float math_sub(float a, float b) { return a - b; }
inline float math_mul(float a, float b) { return a * b; }
inline float math_div(float a, float b) { return a / b; }
// NaN if either is NaN (std::min would return one operand or the other).
inline float math_min(float a, float b) { return (a < b || a != a) ? a : b; }
inline float math_max(float a, float b) { return (a > b || a != a) ? a : b; }
// atan2(y, x): the angle of (x, y).
inline float math_atan2(float y, float x) { return std::atan2(y, x); }
// Remainder of a / b in [0, |b|] (Rust's rem_euclid, fidget's `mod`; the sum
// may round up to |b| when the remainder is a tiny negative number).
inline float math_mod(float a, float b) {
  auto r = std::fmod(a, b);
  return r < 0 ? r + std::abs(b) : r;
}
// -1, 0 or 1 as a <, ==, > b; NaN if either is NaN.
inline float math_compare(float a, float b) {
  return a < b ? -1.0f : a > b ? 1.0f : a == b ? 0.0f : a + b;
}
// a if a == 0, else b.
inline float math_and(float a, float b) { return a == 0 ? a : b; }
// a if a != 0 (NaN included), else b.
inline float math_or(float a, float b) { return a != 0 ? a : b; }

// -----------------------------------------------------------------------------
// ROUNDING
// -----------------------------------------------------------------------------

// Margin of libm results, in ulps (see the top of the file).
inline constexpr int32_t interval_libm_ulps = 4;

// Order-preserving map of floats to integers (both zeros to 0): moving a
// float by n ulps is adding n.
inline int32_t float_order(float x) {
  auto bits = uint32_t{0};
  std::memcpy(&bits, &x, sizeof(bits));
  return (bits & 0x80000000u) ? -(int32_t)(bits & 0x7fffffffu) : (int32_t)bits;
}
inline float order_float(int32_t order) {
  auto bits = order >= 0 ? (uint32_t)order : 0x80000000u | (uint32_t)-order;
  auto x    = 0.0f;
  std::memcpy(&x, &bits, sizeof(x));
  return x;
}
inline constexpr int32_t float_order_inf = 0x7f800000;  // order of +inf

// x moved up by `ulps` floats, stopping at +inf (NaN stays NaN).
inline float float_up(float x, int32_t ulps) {
  if (x != x) return x;
  auto order = float_order(x);
  return order_float(
      order > float_order_inf - ulps ? float_order_inf : order + ulps);
}
// x moved down by `ulps` floats, stopping at -inf (NaN stays NaN). +inf
// moves to the largest floats: an overflowed lower bound stays below the
// point results, which are +inf.
inline float float_down(float x, int32_t ulps) {
  if (x != x) return x;
  auto order = float_order(x);
  return order_float(
      order < -float_order_inf + ulps ? -float_order_inf : order - ulps);
}

// -----------------------------------------------------------------------------
// INTERVALS
// -----------------------------------------------------------------------------

// The closed set of floats [lo, hi], lo <= hi, never NaN; [-inf, +inf]
// also stands for "may be NaN". A float converts to the one-point interval
// (NaN to entire), so constants mix with intervals.
struct interval {
  float lo = 0, hi = 0;

  interval() = default;
  constexpr interval(float value)
      : lo{value == value ? value : -flt_inf},
        hi{value == value ? value : flt_inf} {}
  constexpr interval(float low, float high) : lo{low}, hi{high} {}
};

inline constexpr interval entire_interval = {-flt_inf, flt_inf};

inline bool operator==(interval a, interval b) {
  return a.lo == b.lo && a.hi == b.hi;
}
inline bool operator!=(interval a, interval b) { return !(a == b); }

// Whether the interval is [-inf, +inf] (the value may be NaN).
inline bool is_entire(interval a) {
  return a.lo == -flt_inf && a.hi == flt_inf;
}
// Whether the point value lies in the interval; NaN lies only in entire.
inline bool contains(interval a, float value) {
  return value == value ? a.lo <= value && value <= a.hi : is_entire(a);
}
// Smallest interval holding both.
inline interval hull(interval a, interval b) {
  return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
}
// Largest magnitude, max(|lo|, |hi|).
inline float mag(interval a) { return std::max(-a.lo, a.hi); }
inline float width(interval a) { return a.hi - a.lo; }

// [lo, hi] moved out by `ulps` floats; entire if an endpoint is NaN.
inline interval outward(float lo, float hi, int32_t ulps) {
  if (!(lo <= hi)) return entire_interval;
  return {float_down(lo, ulps), float_up(hi, ulps)};
}
// [lo, hi] as computed (exact endpoints); entire if an endpoint is NaN.
inline interval checked(float lo, float hi) {
  if (!(lo <= hi)) return entire_interval;
  return {lo, hi};
}

inline interval math_neg(interval a) { return {-a.hi, -a.lo}; }
// Sums, differences, products and quotients rounded down and up. A result
// that cannot be inexact stays put: an operand 0 (x + 0, 0 * x, 0 / x) or a
// sum of 0 (x - x; with subnormals a nonzero sum never rounds to 0). So
// [0, 1] + [0, 1] starts at 0, not at -2^-149, which ln or sqrt would take
// for a possible negative.
inline float add_down(float a, float b) {
  auto s = a + b;
  return a == 0 || b == 0 || s == 0 ? s : float_down(s, 1);
}
inline float add_up(float a, float b) {
  auto s = a + b;
  return a == 0 || b == 0 || s == 0 ? s : float_up(s, 1);
}
inline float mul_down(float a, float b) {
  auto p = a * b;
  return a == 0 || b == 0 ? p : float_down(p, 1);
}
inline float mul_up(float a, float b) {
  auto p = a * b;
  return a == 0 || b == 0 ? p : float_up(p, 1);
}
inline float div_down(float a, float b) {
  auto q = a / b;
  return a == 0 ? q : float_down(q, 1);
}
inline float div_up(float a, float b) {
  auto q = a / b;
  return a == 0 ? q : float_up(q, 1);
}

inline interval math_add(interval a, interval b) {
  return checked(add_down(a.lo, b.lo), add_up(a.hi, b.hi));
}
inline interval math_sub(interval a, interval b) {
  return checked(add_down(a.lo, -b.hi), add_up(a.hi, -b.lo));
}
// A quotient by one number c: two corners, the other two are the same
// quotients (the same bounds as four corners).
inline interval div_point(interval a, float c) {
  return c > 0 ? checked(div_down(a.lo, c), div_up(a.hi, c))
               : checked(div_down(a.hi, c), div_up(a.lo, c));
}
// a * b for a finite a >= 0 and a finite b: for each value of b the
// smallest product takes a.lo (b >= 0) or a.hi (b < 0), the largest the
// other way.
inline interval mul_one_sign(interval a, interval b) {
  return {mul_down(b.lo >= 0 ? a.lo : a.hi, b.lo),
      mul_up(b.hi <= 0 ? a.lo : a.hi, b.hi)};
}
// a * c for one number c: two corners, the other two are the same
// products (the same bounds as four corners; NaN gives entire).
inline interval mul_point(interval a, float c) {
  return c >= 0 ? checked(mul_down(a.lo, c), mul_up(a.hi, c))
                : checked(mul_down(a.hi, c), mul_up(a.lo, c));
}
// Products of the corners; math_min/max keep a NaN corner (0 * inf).
inline interval math_mul(interval a, interval b) {
  // By a constant (most products of a tape): two corners.
  if (b.lo == b.hi) return mul_point(a, b.lo);
  if (a.lo == a.hi) return mul_point(b, a.lo);
  // A finite operand of one sign: the smallest and largest products are
  // known corners. Most products in a tape are by a constant (a one-point
  // interval) or of a slope and a derivative.
  auto finite =
      -flt_inf < a.lo && a.hi < flt_inf && -flt_inf < b.lo && b.hi < flt_inf;
  if (finite && (a.lo >= 0 || a.hi <= 0 || b.lo >= 0 || b.hi <= 0)) {
    if (a.lo < 0 && a.hi > 0) std::swap(a, b);  // a has one sign
    if (a.hi <= 0) return math_neg(mul_one_sign(math_neg(a), b));
    return mul_one_sign(a, b);
  }
  return checked(math_min(math_min(mul_down(a.lo, b.lo), mul_down(a.lo, b.hi)),
                     math_min(mul_down(a.hi, b.lo), mul_down(a.hi, b.hi))),
      math_max(math_max(mul_up(a.lo, b.lo), mul_up(a.lo, b.hi)),
          math_max(mul_up(a.hi, b.lo), mul_up(a.hi, b.hi))));
}
// A divisor that may be 0 gives entire: x / +0 and x / -0 are infinities of
// opposite signs and 0 / 0 is NaN, and an interval cannot tell -0 from +0.
inline interval math_div(interval a, interval b) {
  if (b.lo <= 0 && b.hi >= 0) return entire_interval;
  if (b.lo == b.hi) return div_point(a, b.lo);
  return checked(math_min(math_min(div_down(a.lo, b.lo), div_down(a.lo, b.hi)),
                     math_min(div_down(a.hi, b.lo), div_down(a.hi, b.hi))),
      math_max(math_max(div_up(a.lo, b.lo), div_up(a.lo, b.hi)),
          math_max(div_up(a.hi, b.lo), div_up(a.hi, b.hi))));
}
inline interval operator-(interval a) { return math_neg(a); }
inline interval operator+(interval a, interval b) { return math_add(a, b); }
inline interval operator-(interval a, interval b) { return math_sub(a, b); }
inline interval operator*(interval a, interval b) { return math_mul(a, b); }
inline interval operator/(interval a, interval b) { return math_div(a, b); }

inline interval math_abs(interval a) {
  if (is_entire(a)) return a;
  if (a.lo >= 0) return a;
  if (a.hi <= 0) return math_neg(a);
  return {0, std::max(-a.lo, a.hi)};
}
inline interval math_square(interval a) {
  if (is_entire(a)) return a;
  auto m = math_abs(a);
  return {std::max(0.0f, mul_down(m.lo, m.lo)), mul_up(m.hi, m.hi)};
}
// sqrt of a negative is NaN.
inline interval math_sqrt(interval a) {
  if (a.lo < 0) return entire_interval;
  return {std::max(0.0f, float_down(std::sqrt(a.lo), 1)),
      float_up(std::sqrt(a.hi), 1)};
}
inline interval math_exp(interval a) {
  if (is_entire(a)) return a;
  return {std::max(0.0f, float_down(std::exp(a.lo), interval_libm_ulps)),
      float_up(std::exp(a.hi), interval_libm_ulps)};
}
// ln of a negative is NaN; ln 0 = -inf.
inline interval math_log(interval a) {
  if (a.lo < 0) return entire_interval;
  return outward(std::log(a.lo), std::log(a.hi), interval_libm_ulps);
}

// Slack of the float computation of (x - phase) / period for |period| >=
// pi and |phase| <= pi: a few ulps of x over the period, and a few of 1
// (the rounding of phase, period and the quotient).
inline float turns_slack(float x) {
  return 4 * flt_eps * (1 + std::abs(x) * (1 / pif));
}
// Whether [lo, hi] may hold phase + period * k for an integer k. Never false
// when it does (the slack covers the rounding); may be true when it does
// not, near such a point, which only loosens a bound.
inline bool may_hold_phase(float lo, float hi, float phase, float period) {
  auto t_lo = (lo - phase) / period, t_hi = (hi - phase) / period;
  return std::floor(t_hi + turns_slack(hi)) >=
         std::ceil(t_lo - turns_slack(lo));
}
// Range over `a` of a function of period 2 pi that peaks at `peak` + 2 pi k,
// bottoms out half a period away and is monotone between (sin: pi/2, cos:
// 0), from its values `f_lo`, `f_hi` at the ends. Infinite ends give entire
// (sin(inf) is NaN); a single point keeps its value.
inline interval periodic_range(interval a, float f_lo, float f_hi, float peak) {
  if (!std::isfinite(a.lo) || !std::isfinite(a.hi)) return entire_interval;
  auto lo = math_min(f_lo, f_hi), hi = math_max(f_lo, f_hi);
  auto r = outward(lo, hi, interval_libm_ulps);
  if (a.lo != a.hi) {
    if (a.hi - a.lo >= 2 * pif) return {-1, 1};
    if (may_hold_phase(a.lo, a.hi, peak, 2 * pif)) r.hi = 1;
    if (may_hold_phase(a.lo, a.hi, peak + pif, 2 * pif)) r.lo = -1;
  }
  return {std::max(r.lo, -1.0f), std::min(r.hi, 1.0f)};
}
inline interval math_sin(interval a) {
  return periodic_range(a, std::sin(a.lo), std::sin(a.hi), pif / 2);
}
inline interval math_cos(interval a) {
  return periodic_range(a, std::cos(a.lo), std::cos(a.hi), 0);
}
// tan is increasing between its poles at pi/2 + pi k; an interval that may
// hold a pole is entire.
inline interval math_tan(interval a) {
  if (!std::isfinite(a.lo) || !std::isfinite(a.hi)) return entire_interval;
  if (a.hi - a.lo >= pif || may_hold_phase(a.lo, a.hi, pif / 2, pif))
    return entire_interval;
  return outward(std::tan(a.lo), std::tan(a.hi), interval_libm_ulps);
}
// asin and acos are NaN outside [-1, 1].
inline interval math_asin(interval a) {
  if (a.lo < -1 || a.hi > 1) return entire_interval;
  return outward(std::asin(a.lo), std::asin(a.hi), interval_libm_ulps);
}
inline interval math_acos(interval a) {
  if (a.lo < -1 || a.hi > 1) return entire_interval;
  return outward(std::acos(a.hi), std::acos(a.lo), interval_libm_ulps);
}
inline interval math_atan(interval a) {
  if (is_entire(a)) return a;
  return outward(std::atan(a.lo), std::atan(a.hi), interval_libm_ulps);
}
// floor, ceil and round are exact and monotone.
inline interval math_floor(interval a) {
  return checked(std::floor(a.lo), std::floor(a.hi));
}
inline interval math_ceil(interval a) {
  return checked(std::ceil(a.lo), std::ceil(a.hi));
}
inline interval math_round(interval a) {
  return checked(std::round(a.lo), std::round(a.hi));
}
// NaN gives 0 and entire holds 0, so entire gives [0, 1].
inline interval math_not(interval a) {
  if (a.lo == 0 && a.hi == 0) return {1, 1};
  if (a.lo <= 0 && a.hi >= 0) return {0, 1};
  return {0, 0};
}
inline interval math_min(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  return {std::min(a.lo, b.lo), std::min(a.hi, b.hi)};
}
inline interval math_max(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  return {std::max(a.lo, b.lo), std::max(a.hi, b.hi)};
}
// Whether the box y x x may cross atan2's cut (the ray x <= 0, y = 0, where
// the angle jumps from pi to -pi; -0 and +0 are both in any interval
// holding 0) or hold the origin.
inline bool may_cross_atan2_cut(interval y, interval x) {
  return y.lo <= 0 && y.hi >= 0 && x.lo <= 0;
}
inline bool may_cross_atan2_cut(float, float) { return false; }
// Off the cut, the angle over a box is extreme at its corners (its level
// sets are rays from the origin).
inline interval math_atan2(interval y, interval x) {
  if (is_entire(y) || is_entire(x)) return entire_interval;
  if (may_cross_atan2_cut(y, x)) return outward(-pif, pif, interval_libm_ulps);
  auto a0 = std::atan2(y.lo, x.lo), a1 = std::atan2(y.lo, x.hi);
  auto a2 = std::atan2(y.hi, x.lo), a3 = std::atan2(y.hi, x.hi);
  return outward(std::min(std::min(a0, a1), std::min(a2, a3)),
      std::max(std::max(a0, a1), std::max(a2, a3)), interval_libm_ulps);
}
// math_mod is NaN where a is infinite or b holds 0. Over one period of a
// (width below |b|, b a single value, no wrap between the ends) it increases
// with a; otherwise it lies in [0, max |b|] (closed: see math_mod).
inline interval math_mod(interval a, interval b) {
  if (!std::isfinite(a.lo) || !std::isfinite(a.hi)) return entire_interval;
  if (b.lo <= 0 && b.hi >= 0) return entire_interval;
  auto m = math_abs(b);
  if (a.lo >= 0 && a.hi < m.lo) return a;
  if (b.lo == b.hi && a.hi - a.lo < m.lo) {
    // Strictly increasing between the ends means no wrap: a wrap drops the
    // remainder by |b| - width > 0, which rounding may turn into a tie.
    auto r_lo = math_mod(a.lo, b.lo), r_hi = math_mod(a.hi, b.lo);
    if (r_lo < r_hi || a.lo == a.hi) return {r_lo, r_hi};
  }
  return {0, m.hi};
}
inline interval math_compare(interval a, interval b) {
  if (is_entire(a) || is_entire(b)) return entire_interval;
  if (a.hi < b.lo) return {-1, -1};
  if (a.lo > b.hi) return {1, 1};
  if (a.lo == a.hi && b.lo == b.hi) return {0, 0};
  if (a.hi <= b.lo) return {-1, 0};
  if (a.lo >= b.hi) return {0, 1};
  return {-1, 1};
}
// a if a == 0 (entire holds 0 and NaN != 0 picks b), else b.
inline interval math_and(interval a, interval b) {
  if (a.lo == 0 && a.hi == 0) return {0, 0};
  if (a.lo <= 0 && a.hi >= 0) return hull({0, 0}, b);
  return b;
}
// a if a != 0 (NaN included), else b.
inline interval math_or(interval a, interval b) {
  if (is_entire(a)) return a;
  if (a.lo == 0 && a.hi == 0) return b;
  if (a.lo <= 0 && a.hi >= 0) return hull(a, b);
  return a;
}

// -----------------------------------------------------------------------------
// PREDICATES (for code written once over float and interval)
// -----------------------------------------------------------------------------

// A point is always one value; a box is when its interval is one float.
inline bool is_single(float) { return true; }
inline bool is_single(interval a) { return a.lo == a.hi; }
// Whether the value may be NaN.
inline bool may_be_nan(float a) { return a != a; }
inline bool may_be_nan(interval a) { return is_entire(a); }
// Whether a < b (a <= b) at every point (false if either may be NaN).
inline bool always_less(float a, float b) { return a < b; }
inline bool always_less(interval a, interval b) {
  return !is_entire(a) && !is_entire(b) && a.hi < b.lo;
}
inline bool always_less_equal(float a, float b) { return a <= b; }
inline bool always_less_equal(interval a, interval b) {
  return !is_entire(a) && !is_entire(b) && a.hi <= b.lo;
}
// Whether the value is 0 at every point, or at some.
inline bool always_zero(float a) { return a == 0; }
inline bool always_zero(interval a) { return a.lo == 0 && a.hi == 0; }
inline bool may_be_zero(float a) { return a == 0; }
inline bool may_be_zero(interval a) { return a.lo <= 0 && a.hi >= 0; }

// Clamp written once over floats, intervals and duals (NaN stays NaN).
template <class T>
inline T math_clamp(const T& a, const T& lo, const T& hi) {
  return math_min(math_max(a, lo), hi);
}

}  // namespace implicit
