// Tests of sdf_zero_bounds.h on closed forms: the box found holds the zero
// set and is close to it at any scale of the value or of the shape;
// unbounded sets (a gyroid, a cylinder, a half-space of NaN) are reported;
// a function without zeros gives an empty box.

#include "sdf_zero_bounds.h"

#include <doctest/doctest.h>

#include "../math/dual.h"

namespace implicit {
namespace {

inline dual<interval> constant_like(const dual<interval>&, float c) {
  return make_dual_constant(interval{c});
}
inline float constant_like(float, float c) { return c; }

// Ranges over boxes: the natural interval extension, narrowed by the mean
// value form f(centre) + gradient range * (box - centre) where that is
// finite (it removes the dependency problem of x - x).
template <class Shape>
struct shape_range {
  Shape    shape = {};
  interval operator()(const bbox3f& box) const {
    auto x = make_dual_variable(interval{box.min.x, box.max.x}, 0);
    auto y = make_dual_variable(interval{box.min.y, box.max.y}, 1);
    auto z = make_dual_variable(interval{box.min.z, box.max.z}, 2);
    auto f = shape(x, y, z);
    auto c = center(box);
    auto r = interval{shape(c.x, c.y, c.z)};
    for (auto a = 0; a < 3; a++) {
      auto side =
          interval{at(box.min, a) - at(c, a), at(box.max, a) - at(c, a)};
      r = r + f.d[a] * side;
    }
    if (is_entire(f.v) || is_entire(r)) return f.v;
    return {std::max(f.v.lo, r.lo), std::min(f.v.hi, r.hi)};
  }
};
template <class Shape>
zero_bounds_result find(const Shape& shape) {
  return find_zero_bounds(shape_range<Shape>{shape});
}

// A sphere of `radius` about `c`, its value times `scale`.
struct sphere {
  vec3f c      = {0, 0, 0};
  float radius = 1, scale = 1;
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k  = [&](float v) { return constant_like(x, v); };
    auto dx = x - k(c.x), dy = y - k(c.y), dz = z - k(c.z);
    return k(scale) * (dx * dx + dy * dy + dz * dz - k(radius * radius));
  }
};
struct tangle {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k    = [&](float v) { return constant_like(x, v); };
    auto term = [&](const V& a) {
      auto a2 = math_square(a);
      return math_square(a2) - k(5) * a2;
    };
    return term(x) + term(y) + term(z) + k(11.8f);
  }
};
struct gyroid {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    return math_sin(x) * math_cos(y) + math_sin(y) * math_cos(z) +
           math_sin(z) * math_cos(x);
  }
};
struct cylinder {
  template <class V>
  V operator()(const V& x, const V& y, const V&) const {
    auto k = [&](float v) { return constant_like(x, v); };
    return x * x + y * y - k(1);
  }
};
struct nan_half_sphere {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k = [&](float v) { return constant_like(x, v); };
    return x * x + y * y + z * z - k(1) + k(0) * math_log(x);
  }
};
struct no_zero {
  template <class V>
  V operator()(const V& x, const V&, const V&) const {
    auto k = [&](float v) { return constant_like(x, v); };
    return x - x + k(1);
  }
};

// Whether `found` holds `expected` and exceeds it by at most `slack` of
// its size on each side.
bool close_box(const bbox3f& found, const bbox3f& expected, float slack) {
  auto margin = max(size(expected)) * slack;
  for (auto a = 0; a < 3; a++) {
    if (at(found.min, a) > at(expected.min, a)) return false;
    if (at(found.max, a) < at(expected.max, a)) return false;
    if (at(found.min, a) < at(expected.min, a) - margin) return false;
    if (at(found.max, a) > at(expected.max, a) + margin) return false;
  }
  return true;
}

TEST_CASE("zero bounds: boxes of bounded zero sets at any scale") {
  auto unit = bbox3f{{-1, -1, -1}, {1, 1, 1}};
  for (auto scale : {1.0f, 1000.0f, 0.001f}) {
    auto found = find(sphere{{0, 0, 0}, 1, scale});
    CHECK(!found.unbounded);
    CHECK(close_box(found.bounds, unit, 0.1f));
  }
  // Small and far from the origin, large.
  auto small = find(sphere{{100, 50, -3}, 0.01f, 1});
  CHECK(!small.unbounded);
  CHECK(close_box(small.bounds,
      {{99.99f, 49.99f, -3.01f}, {100.01f, 50.01f, -2.99f}}, 0.1f));
  auto large = find(sphere{{0, 0, 0}, 500, 1});
  CHECK(close_box(large.bounds, {{-500, -500, -500}, {500, 500, 500}}, 0.1f));
  // The tangle cube reaches farthest along x where y^4 - 5 y^2 and z^4 -
  // 5 z^2 are least (-6.25): x^4 - 5 x^2 = 0.7.
  auto t = find(tangle{});
  CHECK(!t.unbounded);
  auto r = std::sqrt((5 + std::sqrt(25 + 4 * 0.7f)) / 2);
  // Its large lobes cost many cells: the budget stops the rounds before the
  // box is as close as for the sphere.
  CHECK(close_box(t.bounds, {{-r, -r, -r}, {r, r, r}}, 0.5f));
}

TEST_CASE("zero bounds: unbounded and empty zero sets") {
  CHECK(find(gyroid{}).unbounded);
  CHECK(find(cylinder{}).unbounded);
  CHECK(find(nan_half_sphere{}).unbounded);
  auto none = find(no_zero{});
  CHECK(!none.unbounded);
  CHECK(is_empty(none.bounds));
}

}  // namespace
}  // namespace implicit
