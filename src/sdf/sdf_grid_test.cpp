// Tests of grid evaluation and exact ray intersection.

#include "sdf_grid.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "../math/random.h"
#include "../util/error.h"

using namespace implicit;

namespace {

// A random point in [0,1)^3.
vec3f rand3f(rng_state& rng) {
  auto x = rand1f(rng), y = rand1f(rng);
  return {x, y, rand1f(rng)};
}

// A grid of f sampled at spacing*(i,j,k).
template <typename F>
grid_data sample_grid(vec3i dims, float spacing, F&& f) {
  auto grid = make_grid(dims, spacing, {0, 0, 0}, 0);
  for (auto k = 0; k < dims.z; k++)
    for (auto j = 0; j < dims.y; j++)
      for (auto i = 0; i < dims.x; i++)
        grid.values[i + dims.x * (j + (size_t)dims.y * k)] =
            f(vec3f{(float)i, (float)j, (float)k} * spacing);
  update_grid_accel(grid);
  return grid;
}

// Sphere of radius r at the centre of a cube of n samples.
grid_data sphere_grid(int n, float spacing, float radius, vec3f& center) {
  center = vec3f{1, 1, 1} * ((n - 1) * spacing * 0.5f);
  auto c = center;
  return sample_grid(
      {n, n, n}, spacing, [&](vec3f p) { return length(p - c) - radius; });
}

// First t where the interpolant changes sign, by dense sampling along the
// ray (a reference that knows nothing of voxels or skip distances).
bool reference_hit(
    const grid_data& grid, const ray3f& ray, float step, float& t_hit) {
  auto in_solid = eval_grid(grid, ray_point(ray, ray.tmin)) < 0;
  for (auto t = ray.tmin + step; t <= ray.tmax; t += step) {
    auto p = ray_point(ray, t);
    if (!inside(grid_bounds(grid), p)) continue;
    if ((eval_grid(grid, p) < 0) != in_solid) {
      t_hit = t;
      return true;
    }
  }
  return false;
}

}  // namespace

TEST_CASE("grid interpolant is exact at the nodes") {
  // Spacing 0.25 makes i*h/h exact, so the nodes hit voxel corners exactly.
  auto rng  = make_rng(7);
  auto grid = sample_grid(
      {7, 11, 13}, 0.25f, [&](vec3f) { return rand1f(rng) * 2 - 1; });
  for (auto k = 0; k < 13; k++)
    for (auto j = 0; j < 11; j++)
      for (auto i = 0; i < 7; i++)
        CHECK(eval_grid(grid, vec3f{(float)i, (float)j, (float)k} * 0.25f) ==
              grid_value(grid, i, j, k));
  // Any spacing: within rounding.
  auto grid2 = sample_grid(
      {7, 11, 13}, 0.1f, [&](vec3f p) { return p.x - 2 * p.y + p.z * p.z; });
  for (auto k = 0; k < 13; k += 3)
    for (auto j = 0; j < 11; j += 2)
      for (auto i = 0; i < 7; i++)
        CHECK(eval_grid(grid2, vec3f{(float)i, (float)j, (float)k} * 0.1f) ==
              doctest::Approx(grid_value(grid2, i, j, k)).epsilon(1e-5));
  // Between nodes a linear field is reproduced exactly (up to rounding).
  CHECK(eval_grid(grid2, {0.33f, 0.47f, 0.2f}) ==
        doctest::Approx(0.33 - 2 * 0.47 + 0.2 * 0.2).epsilon(1e-2));
  CHECK(eval_grid(grid2, {0.35f, 0.45f, 0.3f}) ==
        doctest::Approx(0.35 - 2 * 0.45 + 0.3 * 0.3 + 0.05 * 0.05 * 0)
            .epsilon(0.02));
}

TEST_CASE("grid eval outside the box is the documented lower bound") {
  auto center = vec3f{};
  auto grid   = sphere_grid(21, 0.1f, 0.6f, center);  // box [0,2]^3
  // Straight out of the +x face: sqrt(d^2 + f(q)^2).
  auto q  = vec3f{2, 1.3f, 0.7f};
  auto fq = eval_grid(grid, q);
  REQUIRE(fq > 0);
  CHECK(eval_grid(grid, q + vec3f{0.5f, 0, 0}) ==
        doctest::Approx(std::sqrt(0.25f + fq * fq)).epsilon(1e-5));
  // A lower bound of the distance to the (nearly exact) sphere everywhere.
  auto rng = make_rng(3);
  for (auto n = 0; n < 1000; n++) {
    auto p = (rand3f(rng) * 2 - 0.5f) * 4.0f;
    CHECK(eval_grid(grid, p) <= length(p - center) - 0.6f + 0.01f);
  }
  // A negative boundary value: the distance to the box.
  auto clipped = sample_grid({5, 5, 5}, 1.0f, [](vec3f) { return -1.0f; });
  CHECK(eval_grid(clipped, {-3, 2, 2}) == doctest::Approx(3));
  CHECK(eval_grid(clipped, {7, 8, 4}) == doctest::Approx(5));
  // NaN points and empty grids do not crash.
  CHECK(eval_grid(clipped, {NAN, 0, 0}) == flt_max);
  CHECK(eval_grid(grid_data{}, {0, 0, 0}) == flt_max);
}

TEST_CASE("grid ray hits lie on the interpolant's root") {
  auto center  = vec3f{};
  auto spacing = 0.05f;
  auto grid    = sphere_grid(25, spacing, 0.5f, center);  // box [0,1.2]^3
  auto rng     = make_rng(11);
  auto eye     = center + vec3f{0.3f, 0.4f, 3.0f};
  auto hits = 0, misses = 0;
  for (auto n = 0; n < 400; n++) {
    // Targets on a disc facing the eye: within 0.9 r must hit, beyond 1.1 r
    // (but still crossing the box) must miss.
    auto frame  = basis_fromz(normalize(eye - center));
    auto uv     = rand2f(rng) * 2 - vec2f{1, 1};
    auto target = center + (frame.x * uv.x + frame.y * uv.y) * 0.58f;
    auto radius = length(uv) * 0.58f;
    auto ray    = ray3f{eye, (target - eye) * 0.37f, 0, flt_max};
    auto t      = 0.0f;
    auto steps  = 0;
    auto hit    = intersect_grid(grid, ray, t, steps);
    if (hit) CHECK(steps > 0);
    if (radius < 0.45f) {
      REQUIRE(hit);
      hits++;
      auto p = ray_point(ray, t);
      CHECK(std::abs(eval_grid(grid, p)) < 1e-4f * spacing);
      // Close to the analytic sphere (the interpolant's error is O(h^2)).
      CHECK(std::abs(length(p - center) - 0.5f) < 0.01f);
      // First root: no sign change before it.
      auto t_ref  = 0.0f;
      auto before = ray;
      before.tmax = t * 0.999f;
      CHECK(!reference_hit(grid, before, 1e-3f, t_ref));
    } else if (radius > 0.55f) {
      CHECK(!hit);
      misses++;
    }
  }
  CHECK(hits > 100);
  CHECK(misses > 50);
  // tmin/tmax are honoured: a segment that stops short misses, one that
  // starts past the front surface finds the back one from inside.
  auto ray   = ray3f{center + vec3f{0, 0, 3}, {0, 0, -1}, 0, 2.0f};
  auto t     = 0.0f;
  auto steps = 0;
  CHECK(!intersect_grid(grid, ray, t, steps));
  ray.tmax = flt_max;
  REQUIRE(intersect_grid(grid, ray, t, steps));
  CHECK(t == doctest::Approx(2.5f).epsilon(2e-3));
  ray.tmin = 2.8f;
  REQUIRE(intersect_grid(grid, ray, t, steps));
  CHECK(t == doctest::Approx(3.5f).epsilon(2e-3));
}

TEST_CASE("grid exact intersection agrees with a dense reference march") {
  // A wiggly field with many thin features; the reference samples every
  // 1/100 voxel and knows nothing of skip distances.
  auto spacing = 0.1f;
  auto grid    = sample_grid({37, 29, 41}, spacing, [](vec3f p) {
    return std::sin(3.1f * p.x) * std::cos(2.3f * p.y) +
           0.7f * std::sin(4.7f * p.z + p.x) - 0.35f;
  });
  auto rng     = make_rng(5);
  auto box     = grid_bounds(grid);
  auto agreed  = 0;
  for (auto n = 0; n < 200; n++) {
    // From anywhere around the box (or inside it) toward a point in it.
    auto o      = center(box) + (rand3f(rng) - 0.5f) * size(box) * 2.2f;
    auto target = box.min + rand3f(rng) * size(box);
    auto d      = normalize(target - o) * (0.5f + rand1f(rng));
    auto ray    = ray3f{o, d, 0, 20};
    auto t = 0.0f, t_ref = 0.0f;
    auto steps   = 0;
    auto hit     = intersect_grid(grid, ray, t, steps);
    auto step    = spacing / 100 / length(d);
    auto ref_hit = reference_hit(grid, ray, step, t_ref);
    if (ref_hit) {
      // The exact solver may find a thinner dip first, never a later one.
      REQUIRE(hit);
      CHECK(t <= t_ref + step);
      if (std::abs(t - t_ref) <= step) agreed++;
    }
    if (hit) {
      auto p = ray_point(ray, t);
      if (inside(expand(box, -1e-3f), p))
        CHECK(std::abs(eval_grid(grid, p)) < 1e-4f * spacing);
      // No sampled sign change well before the reported hit.
      auto before = ray;
      before.tmax = t - 2 * step;
      if (before.tmax > before.tmin)
        CHECK(!reference_hit(grid, before, step, t_ref));
    }
  }
  CHECK(agreed > 150);
  // Axis-aligned rays running exactly along voxel faces.
  for (auto n = 0; n < 300; n++) {
    auto axis = n % 3;
    auto sign = (n / 3) % 2 ? 1.0f : -1.0f;
    auto o    = vec3f{(float)rand1i(rng, 37), (float)rand1i(rng, 29),
                 (float)rand1i(rng, 41)} *
             spacing;
    if (n % 5 == 0) o = vec3f{8, 16, 24} * spacing;
    auto d      = vec3f{0, 0, 0};
    at(d, axis) = sign;
    at(o, axis) = sign > 0 ? -1.0f : at(box.max, axis) + 1;
    auto ray    = ray3f{o, d, 0, 20};
    auto t = 0.0f, t_ref = 0.0f;
    auto steps   = 0;
    auto hit     = intersect_grid(grid, ray, t, steps);
    auto step    = spacing / 100;
    auto ref_hit = reference_hit(grid, ray, step, t_ref);
    CHECK(hit == ref_hit);
    if (hit && ref_hit) CHECK(std::abs(t - t_ref) <= step);
  }
}

TEST_CASE("grid finds a dip inside a single voxel") {
  // f = 0.2 - x*y in one voxel: positive at the ray's ends, negative in the
  // middle of the segment x = s, y = 1 - s. Roots of s^2 - s + 0.2.
  auto grid =
      sample_grid({2, 2, 2}, 1.0f, [](vec3f p) { return 0.2f - p.x * p.y; });
  auto ray   = ray3f{{0, 1, 0.5f}, {1, -1, 0}, 0, flt_max};
  auto t     = 0.0f;
  auto steps = 0;
  REQUIRE(intersect_grid(grid, ray, t, steps));
  CHECK(t == doctest::Approx((1 - std::sqrt(0.2)) / 2).epsilon(1e-5));
  // A barely negative dip (min -1e-4) is still found.
  auto shallow =
      sample_grid({2, 2, 2}, 1.0f, [](vec3f p) { return 0.2501f - p.x * p.y; });
  REQUIRE(!intersect_grid(shallow, ray, t, steps));
  auto deeper =
      sample_grid({2, 2, 2}, 1.0f, [](vec3f p) { return 0.2499f - p.x * p.y; });
  REQUIRE(intersect_grid(deeper, ray, t, steps));
  CHECK(t == doctest::Approx(0.49).epsilon(2e-3));
}

TEST_CASE("grid ray grazing a thin plate") {
  // Plate: one row of samples at y = 1 is -0.05, the rest +1: the solid is
  // a slab |y - 1| < 0.05/1.05 voxels thick, far thinner than a voxel.
  auto h     = 0.5f;
  auto grid  = sample_grid({33, 5, 9}, h, [&](vec3f p) {
    return std::abs(p.y - 2 * h) < 0.1f * h ? -0.05f * h : h;
  });
  auto half  = 0.05f / 1.05f * h;
  auto t     = 0.0f;
  auto steps = 0;
  // Shallow descent: crosses the plate's top over many voxels.
  auto slope = 0.02f;
  auto ray   = ray3f{{-1, 2 * h + 0.3f, 2}, {1, -slope, 0}, 0, flt_max};
  REQUIRE(intersect_grid(grid, ray, t, steps));
  auto p = ray_point(ray, t);
  CHECK(p.y == doctest::Approx(2 * h + half).epsilon(1e-4));
  CHECK(steps > 1);
  // Parallel inside the slab: enters the box where the interpolant is
  // negative, so the box face is the surface.
  ray = ray3f{{-1, 2 * h + 0.5f * half, 2}, {1, 0, 0}, 0, flt_max};
  REQUIRE(intersect_grid(grid, ray, t, steps));
  CHECK(t == doctest::Approx(1));
  auto n = eval_grid_gradient(grid, ray_point(ray, t));
  CHECK(n.x == doctest::Approx(-1));
  // Parallel just above the slab: no hit anywhere along the plate.
  ray = ray3f{{-1, 2 * h + 2 * half, 2}, {1, 0, 0}, 0, flt_max};
  CHECK(!intersect_grid(grid, ray, t, steps));
}

TEST_CASE("grid ray starting inside the solid") {
  auto center = vec3f{};
  auto grid   = sphere_grid(25, 0.05f, 0.5f, center);
  auto rng    = make_rng(2);
  for (auto n = 0; n < 50; n++) {
    auto d     = normalize(rand3f(rng) - 0.5f) * 2.0f;  // not unit length
    auto o     = center + (rand3f(rng) - 0.5f) * 0.3f;
    auto ray   = ray3f{o, d, 0, flt_max};
    auto t     = 0.0f;
    auto steps = 0;
    REQUIRE(intersect_grid(grid, ray, t, steps));
    auto p = ray_point(ray, t);
    CHECK(std::abs(eval_grid(grid, p)) < 1e-4f * 0.05f);
    CHECK(length(p - center) == doctest::Approx(0.5f).epsilon(0.02));
    // The gradient at the exit points outwards, along the ray.
    CHECK(dot(eval_grid_gradient(grid, p), d) > 0);
  }
  // Clipped solid: the sphere cut by the box at x = 0.3 from the centre.
  auto clipped = sample_grid({17, 25, 25}, 0.05f, [&](vec3f p) {
    return length(p - vec3f{0.5f, 0.6f, 0.6f}) - 0.5f;
  });  // box x in [0, 0.8]
  auto ray     = ray3f{{0.5f, 0.6f, 0.6f}, {1, 0, 0}, 0, flt_max};
  auto t       = 0.0f;
  auto steps   = 0;
  REQUIRE(intersect_grid(clipped, ray, t, steps));
  CHECK(t == doctest::Approx(0.3f));
  auto n = eval_grid_gradient(clipped, ray_point(ray, t));
  CHECK(n.x == doctest::Approx(1));
  CHECK(eval_grid_gradient_smooth(clipped, ray_point(ray, t)).x ==
        doctest::Approx(1));
  // From outside, through the cut face: a face hit.
  ray = ray3f{{2, 0.6f, 0.65f}, {-1, 0, 0}, 0, flt_max};
  REQUIRE(intersect_grid(clipped, ray, t, steps));
  CHECK(t == doctest::Approx(1.2f));
}

TEST_CASE("grid normals: analytic in the voxel, smooth across voxels") {
  auto center     = vec3f{};
  auto grid       = sphere_grid(25, 0.05f, 0.5f, center);
  auto rng        = make_rng(9);
  auto jump_plain = 0.0f, jump_smooth = 0.0f;
  for (auto n = 0; n < 200; n++) {
    auto dir = normalize(rand3f(rng) - 0.5f);
    auto p   = center + dir * 0.5f;
    // Both close to the sphere's normal.
    CHECK(dot(eval_grid_gradient(grid, p), dir) > 0.99f);
    CHECK(dot(eval_grid_gradient_smooth(grid, p), dir) > 0.995f);
    // Across the x voxel face nearest to p.
    auto x = std::round(p.x / 0.05f) * 0.05f;
    auto a = vec3f{x - 1e-4f, p.y, p.z}, b = vec3f{x + 1e-4f, p.y, p.z};
    jump_plain = std::max(jump_plain,
        length(eval_grid_gradient(grid, a) - eval_grid_gradient(grid, b)));
    jump_smooth =
        std::max(jump_smooth, length(eval_grid_gradient_smooth(grid, a) -
                                     eval_grid_gradient_smooth(grid, b)));
  }
  CHECK(jump_smooth < 2e-3f);
  CHECK(jump_plain > 5 * jump_smooth);
}

TEST_CASE("grid rejects bad dims and degenerate rays") {
  CHECK(!check_grid_dims(1, 5, 5).empty());
  CHECK(!check_grid_dims(5, -5, 5).empty());
  CHECK(!check_grid_dims(5000, 5000, 5000).empty());
  CHECK(!check_grid_dims(int64_t{1} << 40, 2, 2).empty());
  CHECK(check_grid_dims(1290, 1290, 1290).empty());
  auto grid  = sample_grid({4, 4, 4}, 1.0f, [](vec3f p) { return p.x - 1.5f; });
  auto t     = 0.0f;
  auto steps = 0;
  CHECK(!intersect_grid(
      grid, ray3f{{-1, 1, 1}, {0, 0, 0}, 0, flt_max}, t, steps));
  CHECK(!intersect_grid(
      grid, ray3f{{NAN, 1, 1}, {1, 0, 0}, 0, flt_max}, t, steps));
  CHECK(!intersect_grid(
      grid, ray3f{{-1, 1, 1}, {-1, 0, 0}, 0, flt_max}, t, steps));
  // Denormal direction components and rays along voxel faces.
  REQUIRE(intersect_grid(
      grid, ray3f{{5, 1, 1}, {-1, 1e-42f, -1e-40f}, 0, flt_max}, t, steps));
  CHECK(t == doctest::Approx(3.5f));
  // x < 1.5 is solid and the x = 0 face closes it.
  REQUIRE(
      intersect_grid(grid, ray3f{{-1, 1, 1}, {1, 0, 0}, 0, flt_max}, t, steps));
  CHECK(t == doctest::Approx(1));
  REQUIRE(
      intersect_grid(grid, ray3f{{5, 1, 1}, {-1, 0, 0}, 0, flt_max}, t, steps));
  CHECK(t == doctest::Approx(3.5f));
  CHECK(has_grid_accel(grid));
  auto stats = compute_grid_stats(grid);
  CHECK(stats.min == -1.5f);
  CHECK(stats.max == 1.5f);
  CHECK(stats.negative_samples == 32);
  CHECK(stats.surface_voxels == 9);
  CHECK(stats.negative_boundary == 28);
}

TEST_CASE("grid bake samples an SDF program") {
  auto node    = sdf_node{};
  node.type    = sdf_type::sphere;
  node.radius  = 0.5f;
  auto program = make_primitive_program(node);
  // The sphere's local origin sits at world (1, 2, 3).
  auto local_from_world =
      frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, -2, -3}};
  auto bounds = bbox3f{{0.4f, 1.4f, 2.4f}, {1.6f, 2.6f, 3.6f}};
  auto calls  = 0;
  auto grid   = bake_grid(
        program, local_from_world, bounds, 0.1f, [&](int done, int total) {
        calls++;
        CHECK(done <= total);
      });
  CHECK(grid.dims == vec3i{13, 13, 13});
  CHECK(grid.origin == bounds.min);
  CHECK(has_grid_accel(grid));
  CHECK(calls > 0);
  for (auto [i, j, k] : {std::array<int, 3>{0, 0, 0}, {6, 6, 6}, {3, 9, 12}}) {
    auto p = bounds.min + vec3f{(float)i, (float)j, (float)k} * 0.1f;
    CHECK(grid_value(grid, i, j, k) ==
          doctest::Approx(length(p - vec3f{1, 2, 3}) - 0.5f).epsilon(1e-5));
  }
  // A frame that stretches by 2 halves the local distances back to world.
  auto stretched = frame3f{{2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {-2, -4, -6}};
  auto half      = bake_grid(program, stretched, bounds, 0.1f);
  CHECK(grid_value(half, 0, 0, 0) ==
        doctest::Approx((2 * length(bounds.min - vec3f{1, 2, 3}) - 0.5f) / 2)
            .epsilon(1e-5));
  // Unbounded, empty or over-budget requests are refused.
  auto plane = sdf_node{};
  plane.type = sdf_type::plane;
  CHECK_THROWS_AS(bake_grid(make_primitive_program(plane), identity_frame,
                      sdf_bounds(make_primitive_program(plane)), 0.1f),
      io_error);
  CHECK_THROWS_AS(bake_grid(program, identity_frame, bounds, 0), io_error);
  CHECK_THROWS_AS(bake_grid(program, identity_frame, bounds, 1e-7f), io_error);
  CHECK_THROWS_AS(
      bake_grid(sdf_program{}, identity_frame, bounds, 0.1f), io_error);
}

// Chessboard distance, capped at grid_skip_max, from every cell of a box
// of n cells to the nearest cell that `feature` marks, by brute force.
template <typename F>
std::vector<int> brute_force_skips(vec3i n, F&& feature) {
  auto features = std::vector<vec3i>{};
  for (auto k = 0; k < n.z; k++)
    for (auto j = 0; j < n.y; j++)
      for (auto i = 0; i < n.x; i++)
        if (feature(i, j, k)) features.push_back({i, j, k});
  auto skips = std::vector<int>{};
  for (auto k = 0; k < n.z; k++) {
    for (auto j = 0; j < n.y; j++) {
      for (auto i = 0; i < n.x; i++) {
        auto d = grid_skip_max;
        for (auto f : features)
          d = std::min(d, std::max({std::abs(f.x - i), std::abs(f.y - j),
                              std::abs(f.z - k)}));
        skips.push_back(d);
      }
    }
  }
  return skips;
}

TEST_CASE("grid voxel bits and block skip distances") {
  // Dense and sparse negative samples, and one small sphere in a larger
  // grid (distances reach the cap); odd and even sides, so that some blocks
  // hang over the box.
  for (auto kind = 0; kind < 3; kind++) {
    auto rng       = make_rng(33);
    auto threshold = kind == 0 ? 0.7f : 0.995f;
    auto grid      = sample_grid({19, 10, 13}, 0.1f,
             [&](vec3f) { return rand1f(rng) < threshold ? 1.0f : -1.0f; });
    if (kind == 2)
      grid = sample_grid({72, 23, 37}, 0.1f, [&](vec3f p) {
        return length(p - vec3f{0.5f, 0.3f, 0.4f}) - 0.05f;
      });
    REQUIRE(has_grid_accel(grid));
    // A voxel may hold a crossing of an outside ray where a corner is < 0,
    // of an inside ray where a corner is >= 0.
    auto corners = [&](int i, int j, int k, bool outside) {
      for (auto c = 0; c < 8; c++) {
        auto v = grid_value(
            grid, i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        if (outside ? v < 0 : v >= 0) return true;
      }
      return false;
    };
    auto nv = vec3i{grid.dims.x - 1, grid.dims.y - 1, grid.dims.z - 1};
    auto nb = vec3i{(nv.x + 1) / 2, (nv.y + 1) / 2, (nv.z + 1) / 2};
    REQUIRE(grid.voxel_masks.size() == (size_t)nb.x * nb.y * nb.z);
    for (auto side = 0; side < 2; side++) {
      auto block_has = [&](int bi, int bj, int bk) {
        auto any = false;
        for (auto c = 0; c < 8; c++) {
          auto i = 2 * bi + (c & 1), j = 2 * bj + ((c >> 1) & 1),
               k      = 2 * bk + ((c >> 2) & 1);
          auto in_box = i < nv.x && j < nv.y && k < nv.z;
          auto mark   = in_box && corners(i, j, k, side == 0);
          auto block  = (size_t)bi + (size_t)nb.x * (bj + (size_t)nb.y * bk);
          INFO(kind, " side ", side, " voxel ", i, " ", j, " ", k);
          CHECK(
              (bool)((grid.voxel_masks[block] >> (c + 8 * side)) & 1) == mark);
          any = any || mark;
        }
        return any;
      };
      auto skips   = brute_force_skips(nb, block_has);
      auto largest = 0;
      for (size_t b = 0; b < skips.size(); b++) {
        INFO(kind, " side ", side, " block ", b);
        CHECK(((grid.block_skips[b] >> (4 * side)) & 15) == skips[b]);
        largest = std::max(largest, skips[b]);
      }
      if (kind == 2 && side == 0) CHECK(largest == grid_skip_max);
    }
  }
  // Stale data is not current acceleration data.
  auto grid = make_grid({5, 6, 7}, 0.1f, {0, 0, 0}, 1);
  grid.block_skips.pop_back();
  CHECK_FALSE(has_grid_accel(grid));
}

TEST_CASE("grid rays are clipped to the box of the solid") {
  // A sphere of radius 0.5 in a box of 1.2: the solid box is the sphere's
  // box grown to whole voxels; rays that miss it take no step, and a grid
  // with no negative value is never hit.
  auto center  = vec3f{};
  auto spacing = 0.05f;
  auto grid    = sphere_grid(25, spacing, 0.5f, center);
  auto box     = grid_solid_bounds(grid);
  for (auto a = 0; a < 3; a++) {
    CHECK(at(box.min, a) >= at(center, a) - 0.5f - spacing);
    CHECK(at(box.min, a) <= at(center, a) - 0.5f);
    CHECK(at(box.max, a) <= at(center, a) + 0.5f + spacing);
    CHECK(at(box.max, a) >= at(center, a) + 0.5f);
  }
  auto t     = 0.0f;
  auto steps = 0;
  // Along an edge of the grid's box: inside it, outside the solid's.
  auto edge = ray3f{{-1, 0.01f, 0.01f}, {1, 0, 0}, 0, 10};
  CHECK_FALSE(intersect_grid(grid, edge, t, steps));
  CHECK(steps == 0);
  auto through = ray3f{{-1, center.y, center.z}, {1, 0, 0}, 0, 10};
  REQUIRE(intersect_grid(grid, through, t, steps));
  CHECK(t == doctest::Approx(1 + center.x - 0.5f).epsilon(1e-2));
  auto empty = make_grid({5, 5, 5}, 0.1f, {0, 0, 0}, 1);
  CHECK(grid_solid_bounds(empty).min.x > grid_solid_bounds(empty).max.x);
  CHECK_FALSE(intersect_grid(empty, through, t, steps));
  // A solid cut by the grid's box: its face is still hit where the value is
  // negative.
  auto cut = sample_grid({9, 9, 9}, 0.1f, [](vec3f p) { return p.x - 0.45f; });
  REQUIRE(
      intersect_grid(cut, ray3f{{-1, 0.4f, 0.4f}, {1, 0, 0}, 0, 10}, t, steps));
  CHECK(t == doctest::Approx(1.0f));
  CHECK(grid_solid_bounds(cut).max.x == doctest::Approx(0.5f));
}

TEST_CASE("grid jumps over empty space without missing small features") {
  // Small spheres (1.5 voxels) far apart in a large grid: rays aimed at
  // them from anywhere, also from inside the box, meet the dense
  // reference; rays through the empty middle take few steps.
  auto spacing = 0.1f;
  auto centers = std::vector<vec3f>{{1.1f, 0.8f, 2.3f}, {4.2f, 4.0f, 1.05f},
      {2.5f, 5.0f, 5.3f}, {0.3f, 5.5f, 0.4f}, {5.6f, 0.25f, 5.5f}};
  auto grid    = sample_grid({61, 60, 59}, spacing, [&](vec3f p) {
    auto d = flt_max;
    for (auto c : centers) d = std::min(d, length(p - c) - 0.15f);
    return d;
  });
  auto rng     = make_rng(7);
  auto box     = grid_bounds(grid);
  for (auto n = 0; n < 300; n++) {
    auto o      = center(box) + (rand3f(rng) - 0.5f) * size(box) * 1.6f;
    auto target = centers[n % centers.size()] + (rand3f(rng) - 0.5f) * 0.4f;
    auto ray    = ray3f{o, normalize(target - o), 0, 20};
    auto t = 0.0f, t_ref = 0.0f;
    auto steps   = 0;
    auto hit     = intersect_grid(grid, ray, t, steps);
    auto step    = spacing / 50;
    auto ref_hit = reference_hit(grid, ray, step, t_ref);
    INFO(n);
    CHECK(hit == ref_hit);
    if (hit && ref_hit) CHECK(t == doctest::Approx(t_ref).epsilon(step));
  }
  // Along the main diagonal (60 voxels, no sphere near it) jumps of up to
  // 29 blocks: a handful of steps, where a voxel walk takes 178.
  auto ray   = ray3f{{0, 0.01f, 0}, normalize(vec3f{1, 1, 1}), 0, 20};
  auto t     = 0.0f;
  auto steps = 0;
  CHECK_FALSE(intersect_grid(grid, ray, t, steps));
  CHECK(steps < 20);
}
