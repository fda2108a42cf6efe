// Tests of segment_trace.h on closed forms that are no distance bounds: the
// first hit along random rays against a dense-sampling reference written
// here (no Lipschitz bound: signs at many points, then bisection), for
// functions at scales 1000 and 0.001, a quartic, an exp/ln blend with sqrt
// at 0, jumps and NaN regions; the march never exceeds its budget.

#include "segment_trace.h"

#include <doctest/doctest.h>

#include <sstream>
#include <string>

#include "../math/random.h"

namespace implicit {
namespace {

// A constant of the same kind as `like` (point, box or dual).
inline float    constant_like(float, float c) { return c; }
inline interval constant_like(interval, float c) { return interval{c}; }
template <class T>
inline dual<T> constant_like(const dual<T>&, float c) {
  return make_dual_constant(T(c));
}

// A closed form along a ray, over its box cut into cells x cells x cells
// regions (1: the whole box, as the reference mode), each with its range and
// slope bound from dual<interval> over its box.
template <class Shape>
struct closed_form_ray {
  Shape  shape = {};
  ray3f  ray   = {};
  bbox3f box   = {};
  int    cells = 1;
  // Whether regions let the march bound segments ahead (as the whole tape
  // does; an octree's leaves do not), and the bounds over pieces asked.
  bool        local_bounds = true;
  mutable int bounds       = 0;

  bbox3f cell_box(int index) const {
    auto cell =
        vec3i{index % cells, (index / cells) % cells, index / (cells * cells)};
    auto h  = size(box) / (float)cells;
    auto lo = box.min + h * vec3f{(float)cell.x, (float)cell.y, (float)cell.z};
    return {lo, lo + h};
  }
  segment_bound bound_box(const bbox3f& b) const {
    auto x = make_dual_variable(interval{b.min.x, b.max.x}, 0);
    auto y = make_dual_variable(interval{b.min.y, b.max.y}, 1);
    auto z = make_dual_variable(interval{b.min.z, b.max.z}, 2);
    auto f = shape(x, y, z);
    auto s = f.d[0] * interval{ray.d.x} + f.d[1] * interval{ray.d.y} +
             f.d[2] * interval{ray.d.z};
    return {f.v, s};
  }
  segment_region locate(float t) const {
    auto p     = ray_point(ray, t);
    auto index = 0, stride = 1;
    for (auto a = 0; a < 3; a++) {
      auto h = (at(box.max, a) - at(box.min, a)) / (float)cells;
      auto u = (at(p, a) - at(box.min, a)) / h;
      auto i = (int)std::floor(u);
      if ((float)i == u && at(ray.d, a) < 0) i--;
      index += clamp(i, 0, cells - 1) * stride;
      stride *= cells;
    }
    auto b    = cell_box(index);
    auto exit = flt_max;
    for (auto a = 0; a < 3; a++) {
      auto d = at(ray.d, a);
      if (d == 0) continue;
      auto plane = d > 0 ? at(b.max, a) : at(b.min, a);
      exit       = std::min(exit, (plane - at(ray.o, a)) / d);
    }
    auto bound = bound_box(b);
    return {index, exit, bound.range, bound.derivative, local_bounds};
  }
  float value(int, float t) const {
    auto p = ray_point(ray, t);
    return shape(p.x, p.y, p.z);
  }
  void values(int, const float* t, float* f, int count) const {
    for (auto k = 0; k < count; k++) {
      auto p = ray_point(ray, t[k]);
      f[k]   = shape(p.x, p.y, p.z);
    }
  }
  vec2f value_slope(int, float t) const {
    auto p = ray_point(ray, t);
    auto f = shape(make_dual_variable(p.x, 0), make_dual_variable(p.y, 1),
        make_dual_variable(p.z, 2));
    return {f.v, dot(gradient(f), ray.d)};
  }
  float         split(int, float, float) const { return flt_nan; }
  segment_bound bound(int, float t0, float t1) const {
    bounds++;
    auto a = ray_point(ray, t0), b = ray_point(ray, t1);
    return bound_box({min(a, b), max(a, b)});
  }
};

template <class Shape>
float shape_value(const Shape& shape, vec3f p) {
  return shape(p.x, p.y, p.z);
}

// The reference: the sign of f at `samples` points of [t0, t1], the first
// change of side (f < 0 inside, NaN outside) bisected to float precision.
template <class Shape>
bool dense_first_hit(const closed_form_ray<Shape>& f, float t0, float t1,
    int samples, float& hit) {
  auto inside = [&](double t) {
    auto p = ray_point(f.ray, (float)t);
    return shape_value(f.shape, p) < 0;
  };
  auto start = inside(t0);
  auto prev  = (double)t0;
  for (auto k = 1; k <= samples; k++) {
    auto t = t0 + (t1 - t0) * (double)k / samples;
    if (inside(t) != start) {
      auto lo = prev, hi = t;
      for (auto i = 0; i < 60; i++) {
        auto mid                         = 0.5 * (lo + hi);
        (inside(mid) == start ? lo : hi) = mid;
      }
      hit = (float)lo;
      return true;
    }
    prev = t;
  }
  return false;
}

// Trace `rays` random rays at the box (from outside, a fifth from inside
// it) with `cells` regions per axis; count the rays whose hit (or miss)
// differs from the reference.
template <class Shape>
int count_disagreements(const Shape& shape, const bbox3f& box, int cells,
    int rays, std::string& first, int* max_evaluations = nullptr,
    int* total_evaluations = nullptr, bool local_bounds = true,
    int* bounds = nullptr) {
  auto rng    = make_rng(29);
  auto params = march_params{};
  auto extent = length(size(box));
  auto misses = 0;
  for (auto n = 0; n < rays; n++) {
    auto target =
        box.min + size(box) * vec3f{rand1f(rng), rand1f(rng), rand1f(rng)};
    auto origin = vec3f{};
    if (n % 5 == 4) {
      origin = center(box) + (target - center(box)) * 0.3f;
      target =
          box.min + size(box) * vec3f{rand1f(rng), rand1f(rng), rand1f(rng)};
    } else {
      auto u = rand1f(rng), v = rand1f(rng);
      auto phi = 2 * pif * u, cos_theta = 2 * v - 1;
      auto sin_theta = std::sqrt(std::max(0.0f, 1 - cos_theta * cos_theta));
      origin         = center(box) + 2 * extent *
                                 vec3f{sin_theta * std::cos(phi),
                                     sin_theta * std::sin(phi), cos_theta};
    }
    auto ray = closed_form_ray<Shape>{shape,
        ray3f{origin, normalize(target - origin), 0, flt_max}, box, cells,
        local_bounds};
    auto t0 = 0.0f, t1 = 0.0f;
    if (!intersect_bbox(ray.ray, box, t0, t1)) continue;
    auto hit_min = 1e-6f * extent;
    auto march   = segment_trace(ray, t0, t1, flt_max, params, hit_min);
    if (max_evaluations)
      *max_evaluations = std::max(*max_evaluations, march.evaluations);
    if (total_evaluations) *total_evaluations += march.evaluations;
    if (bounds) *bounds += ray.bounds;
    auto expected = 0.0f;
    auto hit      = dense_first_hit(ray, t0, t1, 20000, expected);
    auto agree =
        march.hit == hit && (!hit || std::abs(march.distance - expected) <=
                                         1e-4f * extent + 2 * march.epsilon);
    if (agree) continue;
    if (misses++ == 0) {
      auto stream = std::ostringstream{};
      stream.precision(8);
      stream << "ray " << n << " from (" << origin.x << ", " << origin.y << ", "
             << origin.z << "): march " << march.hit << " at " << march.distance
             << " (" << march.evaluations << " evaluations), reference " << hit
             << " at " << expected;
      first = stream.str();
    }
  }
  return misses;
}

#define CHECK_AGAINST_REFERENCE(shape, box, cells, rays)                   \
  {                                                                        \
    auto first  = std::string{};                                           \
    auto misses = count_disagreements(shape, box, cells, rays, first);     \
    CHECK_MESSAGE(misses == 0, misses, " of ", rays, " rays differ with ", \
        cells, " cells; ", first);                                         \
  }

const auto unit_box   = bbox3f{{-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}};
const auto tangle_box = bbox3f{{-3, -3, -3}, {3, 3, 3}};

// x^2 + y^2 + z^2 - 1 times `scale`: the value's scale must not matter.
struct scaled_sphere {
  float scale = 1;
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k = [&](float c) { return constant_like(x, c); };
    return k(scale) * (x * x + y * y + z * z - k(1));
  }
};

// A tangle cube: x^4 - 5 x^2 + y^4 - 5 y^2 + z^4 - 5 z^2 + 11.8.
struct tangle_cube {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k    = [&](float c) { return constant_like(x, c); };
    auto term = [&](const V& a) {
      auto a2 = math_square(a);
      return math_square(a2) - k(5) * a2;
    };
    return term(x) + term(y) + term(z) + k(11.8f);
  }
};

// Two spheres blended by -ln(exp(-8 a) + exp(-8 b)) / 8 (sqrt at 0 at
// their centres: regions there have no finite slope bound).
struct exp_log_blend {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k      = [&](float c) { return constant_like(x, c); };
    auto sphere = [&](float cx, float r) {
      return math_sqrt(math_square(x - k(cx)) + y * y + z * z) - k(r);
    };
    auto a = sphere(-0.4f, 0.5f), b = sphere(0.45f, 0.4f);
    return math_neg(math_log(math_exp(k(-8) * a) + math_exp(k(-8) * b))) / k(8);
  }
};

// A gyroid sheet: |sin 4x cos 4y + sin 4y cos 4z + sin 4z cos 4x| - 0.3,
// whose slope changes sign often along a ray.
struct gyroid_sheet {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k  = [&](float c) { return constant_like(x, c); };
    auto sc = [&](const V& a, const V& b) {
      return math_sin(k(4) * a) * math_cos(k(4) * b);
    };
    return math_abs(sc(x, y) + sc(y, z) + sc(z, x)) - k(0.3f);
  }
};

// A staircase: floor(4 x) / 4 + y^2 + z^2 - 0.5 (jumps cross zero).
struct staircase {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k = [&](float c) { return constant_like(x, c); };
    return math_floor(k(4) * x) / k(4) + y * y + z * z - k(0.5f);
  }
};

// The unit sphere where x > -0.3, NaN elsewhere (ln of a negative).
struct half_nan_sphere {
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k = [&](float c) { return constant_like(x, c); };
    return x * x + y * y + z * z - k(1) + k(0) * math_log(x + k(0.3f));
  }
};

// NaN everywhere.
struct all_nan {
  template <class V>
  V operator()(const V& x, const V&, const V&) const {
    auto k = [&](float c) { return constant_like(x, c); };
    return math_log(k(-1) - x * x);
  }
};

TEST_CASE("segment trace: a sphere scaled by 1000 and by 0.001") {
  for (auto cells : {1, 4, 8}) {
    CHECK_AGAINST_REFERENCE(scaled_sphere{1000}, unit_box, cells, 300)
    CHECK_AGAINST_REFERENCE(scaled_sphere{0.001f}, unit_box, cells, 300)
  }
}

TEST_CASE("segment trace: a tangle cube and an exp/ln blend") {
  for (auto cells : {1, 4, 8}) {
    CHECK_AGAINST_REFERENCE(tangle_cube{}, tangle_box, cells, 300)
    CHECK_AGAINST_REFERENCE(exp_log_blend{}, unit_box, cells, 300)
  }
}

TEST_CASE("segment trace: jumps and NaN regions") {
  for (auto cells : {1, 4, 8}) {
    CHECK_AGAINST_REFERENCE(staircase{}, unit_box, cells, 300)
    CHECK_AGAINST_REFERENCE(half_nan_sphere{}, unit_box, cells, 300)
  }
  // NaN everywhere: never a hit, and the march stops within its budget.
  auto first       = std::string{};
  auto evaluations = 0;
  CHECK(count_disagreements(all_nan{}, unit_box, 8, 100, first, &evaluations) ==
        0);
  CHECK(evaluations <= 600);
}

TEST_CASE("segment trace: the hit is refined to the root") {
  // Ray along x toward the unit sphere scaled by 1000: the root is t = 2.
  auto ray    = closed_form_ray<scaled_sphere>{scaled_sphere{1000},
         ray3f{{-3, 0, 0}, {1, 0, 0}, 0, flt_max}, unit_box, 8};
  auto params = march_params{};
  auto march  = segment_trace(ray, 1.8f, 4.2f, flt_max, params, 1e-6f);
  CHECK(march.hit);
  CHECK(march.distance <= 2.0f);
  CHECK(march.distance >= 2.0f - 4 * flt_eps * 2);
  // From inside, the exit: t = 4.
  auto inside = segment_trace(ray, 2.5f, 4.2f, flt_max, params, 1e-6f);
  CHECK(inside.hit);
  CHECK(inside.distance == doctest::Approx(4.0f).epsilon(1e-6));
  // A cutoff before the hit gives no hit; after it, the same hit.
  CHECK(!segment_trace(ray, 1.8f, 4.2f, 1.9f, params, 1e-6f).hit);
  auto cut = segment_trace(ray, 1.8f, 4.2f, 2.1f, params, 1e-6f);
  CHECK(cut.hit);
  CHECK(cut.distance == march.distance);
}

// Mean evaluations (passes over the function) per ray of
// count_disagreements's rays.
template <class Shape>
double mean_evaluations(const Shape& shape, const bbox3f& box, int cells) {
  auto first = std::string{};
  auto total = 0;
  count_disagreements(shape, box, cells, 300, first, nullptr, &total);
  return total / 300.0;
}

TEST_CASE("segment trace: steps bound how fast f may move towards 0") {
  // f outside (> 0) falls at most 1 and may rise 5 per unit of t: its step
  // is |f| / 1; inside (< 0), |f| / 5. A slope away from the surface allows
  // any step; NaN none.
  CHECK(segment_approach(interval{-1, 5}, false) == 1);
  CHECK(segment_approach(interval{-1, 5}, true) == 5);
  CHECK(segment_approach(interval{2, 5}, false) == 0);
  CHECK(segment_approach(interval{-5, -2}, true) == 0);
  CHECK(segment_approach(interval{flt_nan}, false) == flt_inf);
  CHECK(!std::signbit(segment_approach(interval{-5, -0.0f}, true)));
  CHECK(segment_monotone(interval{-5, -2}, false));
  CHECK(!segment_monotone(interval{-5, 0}, false));
  CHECK(segment_monotone(interval{1, 2}, true));
}

TEST_CASE("segment trace: small regions march on their own bounds") {
  // In an octree's leaves (segment_region::local_bounds false) the march
  // steps by the region's own slope bound and asks no bound over a segment
  // ahead (one costs about 8 values and rarely steps farther there: the
  // gyroid lattice example 1.8x faster); it still finds every hit.
  auto check = [](const auto& shape, const bbox3f& box) {
    auto first       = std::string{};
    auto leaf_bounds = 0, whole_bounds = 0;
    CHECK(count_disagreements(shape, box, 16, 300, first, nullptr, nullptr,
              false, &leaf_bounds) == 0);
    CHECK(leaf_bounds == 0);
    count_disagreements(
        shape, box, 16, 300, first, nullptr, nullptr, true, &whole_bounds);
    CHECK(whole_bounds > 0);
  };
  check(tangle_cube{}, tangle_box);
  check(gyroid_sheet{}, unit_box);
}

TEST_CASE("segment trace: a surface ahead costs few evaluations") {
  // Signed slope bounds step farther where f may rise, a segment where f
  // falls all the way is bracketed at once, and the refinement starts with
  // a secant step and closes its bracket (before them: 11.6-12.7, 24.4-25.1
  // and 13-14 evaluations).
  for (auto cells : {1, 8}) {
    CHECK(mean_evaluations(scaled_sphere{1000}, unit_box, cells) < 9);
    CHECK(mean_evaluations(tangle_cube{}, tangle_box, cells) < 20);
    auto ray   = closed_form_ray<scaled_sphere>{scaled_sphere{1000},
          ray3f{{-3, 0, 0}, {1, 0, 0}, 0, flt_max}, unit_box, cells};
    auto march = segment_trace(ray, 1.8f, 4.2f, flt_max, march_params{}, 1e-6f);
    CHECK(march.hit);
    CHECK(march.evaluations <= 8);
  }
}

TEST_CASE("segment trace: a ray that starts on one side costs nothing there") {
  // From a corner of the box along x at y = z = 1.1, x^2 + y^2 + z^2 - 1
  // stays above 1.4: every one of the 8 regions it crosses holds one side
  // only, the start's side included, so no value is needed (before: 1).
  auto ray   = closed_form_ray<scaled_sphere>{scaled_sphere{1},
        ray3f{{-3, 1.1f, 1.1f}, {1, 0, 0}, 0, flt_max}, unit_box, 8};
  auto march = segment_trace(ray, 1.8f, 4.2f, flt_max, march_params{}, 1e-6f);
  CHECK(!march.hit);
  CHECK(march.evaluations == 0);
  // Starting inside, in a region on the inside only, the start is inside:
  // the exit is found.
  auto out = closed_form_ray<scaled_sphere>{
      scaled_sphere{1}, ray3f{{0, 0, 0}, {1, 0, 0}, 0, flt_max}, unit_box, 8};
  REQUIRE(segment_one_side(out.locate(0).range));
  auto exit = segment_trace(out, 0, 1.2f, flt_max, march_params{}, 1e-6f);
  CHECK(exit.hit);
  CHECK(exit.distance == doctest::Approx(1).epsilon(1e-5));
}

// exp(x) - 2: falls towards its root at ln 2 from +x at a rate between
// e^-2 and e^2 over the unit box's region, so an approach by steps of
// |f| / e^2 creeps up to it.
struct exp_wall {
  template <class V>
  V operator()(const V& x, const V&, const V&) const {
    return math_exp(x) - constant_like(x, 2);
  }
};

TEST_CASE("segment trace: a region's signed slope decides it at once") {
  // Away from the root (from x = 0.8, f > 0 rises over the region): one
  // evaluation, no hit (before: 4).
  auto away = closed_form_ray<exp_wall>{
      exp_wall{}, ray3f{{0.8f, 0, 0}, {1, 0, 0}, 0, flt_max}, unit_box, 1};
  auto miss = segment_trace(away, 0, 0.4f, flt_max, march_params{}, 1e-6f);
  CHECK(!miss.hit);
  CHECK(miss.evaluations == 1);
  // Towards it, f falls over the whole region: at most where its least
  // rate reaches 0 the root is bracketed.
  auto toward = closed_form_ray<exp_wall>{
      exp_wall{}, ray3f{{3, 0, 0}, {-1, 0, 0}, 0, flt_max}, unit_box, 1};
  auto march =
      segment_trace(toward, 1.8f, 4.2f, flt_max, march_params{}, 1e-6f);
  CHECK(march.hit);
  CHECK(march.distance == doctest::Approx(3 - std::log(2.0f)).epsilon(1e-5));
  // Per ray over 8 x 8 x 8 regions (signed slopes: 7.98, 19.0 and 22.2 ->
  // 5.81, 14.9 and 19.3; no value at a start on one side: 5.07, 14.7 and
  // 18.4; the far end's value, which settles a region that a ray passes by
  // from both ends: 5.06, 13.6 and 18.2).
  CHECK(mean_evaluations(scaled_sphere{1000}, unit_box, 8) < 5.5);
  CHECK(mean_evaluations(tangle_cube{}, tangle_box, 8) < 14.2);
  CHECK(mean_evaluations(exp_log_blend{}, unit_box, 8) < 18.8);
}

// A ripple, 0.1 (x^2 + y^2) + 0.5 sin(w (x + 0.3 z)) + c, whose troughs
// dip just below 0 (c near 0.5): thin root pairs that a step landing past
// them on the same side would pass unseen.
struct ripple {
  float w = 10, c = 0.45f;
  template <class V>
  V operator()(const V& x, const V& y, const V& z) const {
    auto k = [&](float v) { return constant_like(x, v); };
    return k(0.1f) * (x * x + y * y) +
           k(0.5f) * math_sin(k(w) * (x + k(0.3f) * z)) + k(c);
  }
};

TEST_CASE("segment trace: a loose slope bound does not make the march creep") {
  // Steps of |f| / rate shrink |f| by a fixed factor each when the rate
  // bound is loose; a bolder step checked from both ends (segment_bold_step)
  // closes in faster and still finds every first hit, and the bold and plain
  // steps that would follow one another go in batches (segment_bold_batch,
  // segment_plain_batch, each batch one pass of the function). Evaluations
  // per ray over 16 x 16 x 16
  // regions without bounds ahead, as octree leaves: 8.4, 9.4 and 12.2 (one
  // step at a time: 15.0, 11.6 and 18.2; without bold steps: 33.6, 14.2 and
  // 21.2).
  auto mean = [](const auto& shape, const bbox3f& box) {
    auto first = std::string{};
    auto total = 0;
    CHECK(count_disagreements(
              shape, box, 16, 300, first, nullptr, &total, false) == 0);
    return total / 300.0;
  };
  CHECK(mean(exp_log_blend{}, unit_box) < 10);
  CHECK(mean(tangle_cube{}, tangle_box) < 10.5);
  CHECK(mean(gyroid_sheet{}, unit_box) < 13.5);
  // The bold step's end is checked: without the check, 1-33 of 1,000 rays
  // passed a ripple's first trough here.
  for (auto w : {10.0f, 30.0f, 60.0f})
    for (auto c : {0.45f, 0.49f}) {
      auto first = std::string{};
      for (auto cells : {1, 4})
        CHECK_MESSAGE(count_disagreements(ripple{w, c}, unit_box, cells, 1000,
                          first, nullptr, nullptr, false) == 0,
            first);
    }
}

}  // namespace
}  // namespace implicit
