// # implicit: forward-mode derivatives
//
// A dual number carries a value and N derivatives (forward-mode automatic
// differentiation, as libfive's and fidget's gradient evaluators do): the
// three partials along the local x, y and z (N = 3, the default), or one
// derivative along a direction (N = 1: a ray's d/dt, for a third of the
// work). Its clauses are written once, as templates over the value type T:
//   dual<float>     the exact gradient at a point (normals, Newton steps);
//   dual<interval>  enclosures of the partials over a box, whose largest
//                   length bounds the function's Lipschitz constant there;
//   dual<interval, 1>  an enclosure of df/dt along a ray over a piece of it
//                   (segment tracing, Galin et al. 2020).
// The templates use the clauses and predicates of interval.h on T, so a
// derivative rule is one line for both: at a kink a point takes one side's
// derivative and a box the hull of both; at a jump (floor, round, mod,
// compare, and, or, not, atan2's cut) a point takes the derivative of the
// piece it lies on and a box that may hold the jump gets an unbounded one.
// Where the value may be NaN (entire over a box) the derivatives are
// unknown too, whatever the chain rule would give.
#pragma once

#include <type_traits>

#include "interval.h"

namespace implicit {

// -----------------------------------------------------------------------------
// DUAL NUMBERS
// -----------------------------------------------------------------------------

template <class T, int N = 3>
struct dual {
  T v    = {};  // value
  T d[N] = {};  // derivatives: along x, y, z (N = 3) or a direction (N = 1)
};

// A constant (zero derivatives).
template <int N = 3, class T>
inline dual<T, N> make_dual_constant(const T& value) {
  auto a = dual<T, N>{value};
  for (auto i = 0; i < N; i++) a.d[i] = T(0);
  return a;
}
// The coordinate `axis` (0 x, 1 y, 2 z) with value `value`.
template <class T>
inline dual<T> make_dual_variable(const T& value, int axis) {
  auto a    = make_dual_constant(value);
  a.d[axis] = T(1);
  return a;
}
// A coordinate along a ray: its value and its derivative d/dt, the ray
// direction's component.
template <class T>
inline dual<T, 1> make_dual_along(const T& value, float slope) {
  return {value, {T(slope)}};
}

// A value about which nothing is known: NaN for a point, entire for a box
// (the NaN rule of interval.h).
template <class T>
inline T unknown_value();
template <>
inline float unknown_value<float>() {
  return flt_nan;
}
template <>
inline interval unknown_value<interval>() {
  return entire_interval;
}

// The derivative at a tie of two pieces (min, max, abs at 0): a point takes
// the first (a one-sided derivative, the piece its value comes from), a box
// both.
inline float    join_slopes(float a, float) { return a; }
inline interval join_slopes(interval a, interval b) { return hull(a, b); }

// value with unknown derivatives (a NaN value or a possible jump).
template <int N = 3, class T>
inline dual<T, N> with_unknown_slope(const T& value) {
  auto a = dual<T, N>{value};
  for (auto i = 0; i < N; i++) a.d[i] = unknown_value<T>();
  return a;
}
// The dual itself, or unknown derivatives where its value may be NaN: ln
// over [-2, -1] is NaN everywhere, yet its chain rule gives finite slopes,
// which a tracer would take for a Lipschitz bound.
template <class T, int N>
inline dual<T, N> nan_checked(const dual<T, N>& a) {
  return may_be_nan(a.v) ? with_unknown_slope<N>(a.v) : a;
}
// Whether a is one number with zero derivatives (a constant clause).
// Products and quotients of boxes by one take the chain rule's one term:
// the dropped term, value * 0, is 0 but for an infinite value, where the
// full rule would give unknown slopes to a * c, whose slopes are c a'.
template <class T, int N>
inline bool is_constant(const dual<T, N>& a) {
  if (!is_single(a.v)) return false;
  for (auto i = 0; i < N; i++)
    if (!(a.d[i] == T(0))) return false;
  return true;
}
// a times the constant c.
template <class T, int N>
inline dual<T, N> scaled(const dual<T, N>& a, const T& c) {
  auto r = dual<T, N>{a.v * c};
  for (auto i = 0; i < N; i++) r.d[i] = a.d[i] * c;
  return nan_checked(r);
}
// value with derivatives slope * a.d (the chain rule).
template <class T, int N>
inline dual<T, N> chain(const dual<T, N>& a, const T& value, const T& slope) {
  auto r = dual<T, N>{value};
  for (auto i = 0; i < N; i++) r.d[i] = slope * a.d[i];
  return nan_checked(r);
}
// A piecewise constant value: derivative 0 where the value is one number
// over the whole box (always, at a point), unknown where it may jump.
template <int N, class T>
inline dual<T, N> piecewise_constant(const T& value) {
  return is_single(value) ? make_dual_constant<N>(value)
                          : with_unknown_slope<N>(value);
}

// -----------------------------------------------------------------------------
// CLAUSES
// -----------------------------------------------------------------------------

template <class T, int N>
inline dual<T, N> math_neg(const dual<T, N>& a) {
  auto r = dual<T, N>{math_neg(a.v)};
  for (auto i = 0; i < N; i++) r.d[i] = math_neg(a.d[i]);
  return r;
}
template <class T, int N>
inline dual<T, N> math_add(const dual<T, N>& a, const dual<T, N>& b) {
  auto r = dual<T, N>{a.v + b.v};
  for (auto i = 0; i < N; i++) r.d[i] = a.d[i] + b.d[i];
  return nan_checked(r);
}
template <class T, int N>
inline dual<T, N> math_sub(const dual<T, N>& a, const dual<T, N>& b) {
  auto r = dual<T, N>{a.v - b.v};
  for (auto i = 0; i < N; i++) r.d[i] = a.d[i] - b.d[i];
  return nan_checked(r);
}
template <class T, int N>
inline dual<T, N> math_mul(const dual<T, N>& a, const dual<T, N>& b) {
  if constexpr (std::is_same_v<T, interval>) {
    if (is_constant(b)) return scaled(a, b.v);
    if (is_constant(a)) return scaled(b, a.v);
  }
  auto r = dual<T, N>{a.v * b.v};
  for (auto i = 0; i < N; i++) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return nan_checked(r);
}
// (a / b)' = (a' - q b') / b with q = a / b.
template <class T, int N>
inline dual<T, N> math_div(const dual<T, N>& a, const dual<T, N>& b) {
  if constexpr (std::is_same_v<T, interval>) {
    if (is_constant(b)) {
      auto r = dual<T, N>{a.v / b.v};
      for (auto i = 0; i < N; i++) r.d[i] = a.d[i] / b.v;
      return nan_checked(r);
    }
  }
  auto r   = dual<T, N>{a.v / b.v};
  auto inv = T(1) / b.v;
  for (auto i = 0; i < N; i++) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
  return nan_checked(r);
}
template <class T, int N>
inline dual<T, N> operator-(const dual<T, N>& a) {
  return math_neg(a);
}
template <class T, int N>
inline dual<T, N> operator+(const dual<T, N>& a, const dual<T, N>& b) {
  return math_add(a, b);
}
template <class T, int N>
inline dual<T, N> operator-(const dual<T, N>& a, const dual<T, N>& b) {
  return math_sub(a, b);
}
template <class T, int N>
inline dual<T, N> operator*(const dual<T, N>& a, const dual<T, N>& b) {
  return math_mul(a, b);
}
template <class T, int N>
inline dual<T, N> operator/(const dual<T, N>& a, const dual<T, N>& b) {
  return math_div(a, b);
}

// |a|: the kink at 0 gives slopes between -a' and a'.
template <class T, int N>
inline dual<T, N> math_abs(const dual<T, N>& a) {
  if (always_less(a.v, T(0))) return math_neg(a);
  if (always_less_equal(T(0), a.v)) return a;
  if (may_be_nan(a.v)) return with_unknown_slope<N>(a.v);
  auto r = dual<T, N>{math_abs(a.v)};
  for (auto i = 0; i < N; i++) r.d[i] = join_slopes(a.d[i], math_neg(a.d[i]));
  return r;
}
template <class T, int N>
inline dual<T, N> math_square(const dual<T, N>& a) {
  return chain(a, math_square(a.v), T(2) * a.v);
}
// sqrt' = 1 / (2 sqrt): unbounded at 0.
template <class T, int N>
inline dual<T, N> math_sqrt(const dual<T, N>& a) {
  auto s = math_sqrt(a.v);
  return chain(a, s, T(0.5f) / s);
}
template <class T, int N>
inline dual<T, N> math_exp(const dual<T, N>& a) {
  auto e = math_exp(a.v);
  return chain(a, e, e);
}
template <class T, int N>
inline dual<T, N> math_log(const dual<T, N>& a) {
  return chain(a, math_log(a.v), T(1) / a.v);
}
template <class T, int N>
inline dual<T, N> math_sin(const dual<T, N>& a) {
  return chain(a, math_sin(a.v), math_cos(a.v));
}
template <class T, int N>
inline dual<T, N> math_cos(const dual<T, N>& a) {
  return chain(a, math_cos(a.v), math_neg(math_sin(a.v)));
}
// tan' = 1 + tan^2.
template <class T, int N>
inline dual<T, N> math_tan(const dual<T, N>& a) {
  auto t = math_tan(a.v);
  return chain(a, t, T(1) + math_square(t));
}
// asin' = 1 / sqrt(1 - a^2), acos' its negative: unbounded at +-1.
template <class T, int N>
inline dual<T, N> math_asin(const dual<T, N>& a) {
  return chain(a, math_asin(a.v), T(1) / math_sqrt(T(1) - math_square(a.v)));
}
template <class T, int N>
inline dual<T, N> math_acos(const dual<T, N>& a) {
  return chain(a, math_acos(a.v), T(-1) / math_sqrt(T(1) - math_square(a.v)));
}
template <class T, int N>
inline dual<T, N> math_atan(const dual<T, N>& a) {
  return chain(a, math_atan(a.v), T(1) / (T(1) + math_square(a.v)));
}
template <class T, int N>
inline dual<T, N> math_floor(const dual<T, N>& a) {
  return piecewise_constant<N>(math_floor(a.v));
}
template <class T, int N>
inline dual<T, N> math_ceil(const dual<T, N>& a) {
  return piecewise_constant<N>(math_ceil(a.v));
}
template <class T, int N>
inline dual<T, N> math_round(const dual<T, N>& a) {
  return piecewise_constant<N>(math_round(a.v));
}
template <class T, int N>
inline dual<T, N> math_not(const dual<T, N>& a) {
  return piecewise_constant<N>(math_not(a.v));
}
template <class T, int N>
inline dual<T, N> math_compare(const dual<T, N>& a, const dual<T, N>& b) {
  return piecewise_constant<N>(math_compare(a.v, b.v));
}
// The smaller operand's derivative; at a tie a point takes a's, a box both.
template <class T, int N>
inline dual<T, N> math_min(const dual<T, N>& a, const dual<T, N>& b) {
  if (may_be_nan(a.v) || may_be_nan(b.v))
    return with_unknown_slope<N>(math_min(a.v, b.v));
  if (always_less(b.v, a.v)) return b;
  if (always_less_equal(a.v, b.v)) return a;
  auto r = dual<T, N>{math_min(a.v, b.v)};
  for (auto i = 0; i < N; i++) r.d[i] = join_slopes(a.d[i], b.d[i]);
  return r;
}
template <class T, int N>
inline dual<T, N> math_max(const dual<T, N>& a, const dual<T, N>& b) {
  if (may_be_nan(a.v) || may_be_nan(b.v))
    return with_unknown_slope<N>(math_max(a.v, b.v));
  if (always_less(a.v, b.v)) return b;
  if (always_less_equal(b.v, a.v)) return a;
  auto r = dual<T, N>{math_max(a.v, b.v)};
  for (auto i = 0; i < N; i++) r.d[i] = join_slopes(a.d[i], b.d[i]);
  return r;
}
// atan2(y, x)' = (x y' - y x') / (x^2 + y^2); a box that may cross the cut
// may jump by 2 pi.
template <class T, int N>
inline dual<T, N> math_atan2(const dual<T, N>& y, const dual<T, N>& x) {
  auto value = math_atan2(y.v, x.v);
  if (may_cross_atan2_cut(y.v, x.v)) return with_unknown_slope<N>(value);
  auto r   = dual<T, N>{value};
  auto inv = T(1) / (math_square(x.v) + math_square(y.v));
  for (auto i = 0; i < N; i++) r.d[i] = (x.v * y.d[i] - y.v * x.d[i]) * inv;
  return r;
}
// mod(a, b) = a - |b| floor(a / |b|): derivative a' - floor(a / |b|) |b|'
// where that floor is one number, unknown where it may jump.
template <class T, int N>
inline dual<T, N> math_mod(const dual<T, N>& a, const dual<T, N>& b) {
  auto value = math_mod(a.v, b.v);
  auto m     = math_abs(b);
  auto turns = math_floor(a.v / m.v);
  if (may_be_nan(value) || !is_single(turns))
    return with_unknown_slope<N>(value);
  auto r = dual<T, N>{value};
  for (auto i = 0; i < N; i++) r.d[i] = a.d[i] - turns * m.d[i];
  return r;
}
// a if a == 0, else b; a box where a may be 0 but is not always may jump.
template <class T, int N>
inline dual<T, N> math_and(const dual<T, N>& a, const dual<T, N>& b) {
  if (always_zero(a.v)) return a;
  if (!may_be_zero(a.v)) return b;
  return with_unknown_slope<N>(math_and(a.v, b.v));
}
// a if a != 0, else b.
template <class T, int N>
inline dual<T, N> math_or(const dual<T, N>& a, const dual<T, N>& b) {
  if (!may_be_zero(a.v)) return a;
  if (always_zero(a.v)) return b;
  return with_unknown_slope<N>(math_or(a.v, b.v));
}

// -----------------------------------------------------------------------------
// QUERIES
// -----------------------------------------------------------------------------

// The gradient at a point.
inline vec3f gradient(const dual<float>& a) { return {a.d[0], a.d[1], a.d[2]}; }

// Bound on the gradient's length over the box the derivatives enclose: a
// Lipschitz bound of the function there; +inf when a partial is unbounded
// (a possible jump, NaN or an overflow).
inline float gradient_bound(const dual<interval>& a) {
  auto sum = 0.0f;
  for (auto i = 0; i < 3; i++) {
    auto m = mag(a.d[i]);
    sum    = float_up(sum + float_up(m * m, 1), 1);
  }
  auto bound = float_up(std::sqrt(sum), 1);
  return bound == bound ? bound : flt_inf;
}

}  // namespace implicit
