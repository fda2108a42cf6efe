// Tests for the sampling helpers: the fast atan2 against the C library's
// (error bound, signs and zeros) and the lat-long mapping's round trip.

#include "sampling.h"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

#include "random.h"

using namespace implicit;

// Absolute error of atan2_fast(y, x) against the double-precision atan2 of
// the same float arguments.
static double atan2_error(float y, float x) {
  return std::abs((double)atan2_fast(y, x) - std::atan2((double)y, (double)x));
}

TEST_CASE("sampling: atan2_fast is within 4e-7 rad of atan2") {
  // Directions all around the circle, at lengths from tiny to large (only
  // the ratio matters, but the division must not lose it).
  auto max_error = 0.0;
  auto n         = 1 << 20;
  auto pi        = 3.14159265358979323846;
  for (auto k = 0; k < n; k++) {
    auto angle = (2 * pi * k) / n - pi;
    for (auto length : {1e-30f, 1e-3f, 1.0f, 7.5f, 1e20f}) {
      auto x    = (float)(std::cos(angle) * length);
      auto y    = (float)(std::sin(angle) * length);
      max_error = std::max(max_error, atan2_error(y, x));
    }
  }
  // Random unit directions' components, as latlong_uv calls it.
  auto rng = make_rng(7);
  for (auto k = 0; k < n; k++) {
    auto d    = sample_sphere(rand2f(rng));
    max_error = std::max(max_error, atan2_error(d.z, d.x));
    auto s    = std::sqrt(d.x * d.x + d.z * d.z);
    max_error = std::max(max_error, atan2_error(s, d.y));
  }
  // Near the octant boundaries (a close to 1) and the axes (a close to 0).
  for (auto k = 0; k < 4096; k++) {
    auto e = k * 1e-7f;
    for (auto sx : {-1.0f, 1.0f}) {
      for (auto sy : {-1.0f, 1.0f}) {
        max_error = std::max(max_error, atan2_error(sy, sx * (1 - e)));
        max_error = std::max(max_error, atan2_error(sy * (1 - e), sx));
        max_error = std::max(max_error, atan2_error(sy * e, sx));
        max_error = std::max(max_error, atan2_error(sy, sx * e));
      }
    }
  }
  MESSAGE("atan2_fast max abs error: ", max_error);
  CHECK(max_error < 4e-7);
}

TEST_CASE("sampling: atan2_fast keeps atan2's signs, zeros and axes") {
  auto nan = std::numeric_limits<float>::quiet_NaN();
  // Every signed zero and axis, exactly as std::atan2 (ties are bit-equal).
  for (auto y : {0.0f, -0.0f, 1.0f, -1.0f, 3e-39f, -3e-39f}) {
    for (auto x : {0.0f, -0.0f, 1.0f, -1.0f, 3e-39f, -3e-39f}) {
      CAPTURE(y);
      CAPTURE(x);
      auto fast = atan2_fast(y, x), exact = std::atan2(y, x);
      CHECK(std::signbit(fast) == std::signbit(exact));
      CHECK(std::abs(fast - exact) <= 3e-7f);
    }
  }
  CHECK(atan2_fast(0.0f, 0.0f) == 0.0f);
  CHECK(!std::signbit(atan2_fast(0.0f, 0.0f)));
  CHECK(std::signbit(atan2_fast(-0.0f, 0.0f)));
  CHECK(atan2_fast(0.0f, -0.0f) == pif);
  CHECK(atan2_fast(-0.0f, -0.0f) == -pif);
  CHECK(atan2_fast(0.0f, -1.0f) == pif);
  CHECK(atan2_fast(-0.0f, -1.0f) == -pif);
  CHECK(atan2_fast(0.0f, 2.0f) == 0.0f);
  CHECK(atan2_fast(1.0f, 0.0f) == pif / 2);
  CHECK(atan2_fast(-1.0f, 0.0f) == -pif / 2);
  CHECK(atan2_fast(1.0f, -0.0f) == pif / 2);
  CHECK(std::isnan(atan2_fast(nan, 1.0f)));
  CHECK(std::isnan(atan2_fast(1.0f, nan)));
  CHECK(std::isnan(atan2_fast(nan, 0.0f)));
  CHECK(std::isnan(atan2_fast(0.0f, nan)));
}

TEST_CASE("sampling: latlong_uv inverts latlong_direction") {
  // Poles and seams: +y is v = 0, -y is v = 1, +x is u = 0, +z is u = 1/4.
  CHECK(latlong_uv({0, 1, 0}).y == 0);
  CHECK(latlong_uv({0, -1, 0}).y == doctest::Approx(1).epsilon(1e-6));
  CHECK(latlong_uv({1, 0, 0}).x == 0);
  CHECK(latlong_uv({1, 0, 0}).y == doctest::Approx(0.5f).epsilon(1e-6));
  CHECK(latlong_uv({0, 0, 1}).x == doctest::Approx(0.25f).epsilon(1e-6));
  CHECK(latlong_uv({-1, 0, 0}).x == doctest::Approx(0.5f).epsilon(1e-6));
  CHECK(latlong_uv({0, 0, -1}).x == doctest::Approx(0.75f).epsilon(1e-6));
  // u stays in [0, 1] (1 only where a tiny negative angle rounds up).
  auto rng       = make_rng(11);
  auto max_error = 0.0f;
  for (auto k = 0; k < 100000; k++) {
    auto uv   = rand2f(rng);
    uv.y      = 0.001f + 0.998f * uv.y;  // away from the poles' lost u
    auto back = latlong_uv(latlong_direction(uv));
    CHECK(back.x >= 0);
    CHECK(back.x <= 1);
    auto du   = std::abs(back.x - uv.x);
    max_error = std::max(
        max_error, std::max(std::min(du, 1 - du), std::abs(back.y - uv.y)));
  }
  MESSAGE("latlong round trip max uv error: ", max_error);
  CHECK(max_error < 2e-6f);
}

// Solid angle of the rectangle [x0, x1] x [y0, y1] at z = z0 seen from the
// origin by the midpoint rule over n x n cells: the integral of |z0| / r^3.
static double solid_angle_by_cells(
    double x0, double x1, double y0, double y1, double z0, int n) {
  auto sum = 0.0, dx = (x1 - x0) / n, dy = (y1 - y0) / n;
  for (auto i = 0; i < n; i++)
    for (auto j = 0; j < n; j++) {
      auto x = x0 + (i + 0.5) * dx, y = y0 + (j + 0.5) * dy;
      auto r = std::sqrt(x * x + y * y + z0 * z0);
      sum += std::abs(z0) / (r * r * r) * dx * dy;
    }
  return sum;
}

TEST_CASE("sampling: a spherical rectangle's solid angle") {
  // Centred 2a x 2b at height h: 4 asin(ab / sqrt((a^2 + h^2)(b^2 + h^2))).
  for (auto [a, b, h] : {std::tuple{1.0, 1.0, 1.0}, {0.3, 2.0, 0.1},
           {1e-3, 2e-3, 5.0}, {50.0, 50.0, 0.01}}) {
    auto exact =
        4 * std::asin(a * b / std::sqrt((a * a + h * h) * (b * b + h * h)));
    for (auto z0 : {-h, h}) {
      auto rect = make_spherical_rectangle(
          (float)-a, (float)a, (float)-b, (float)b, (float)z0);
      CHECK(std::abs(rect.solid_angle - exact) <= 2e-6 + 1e-5 * exact);
    }
  }
  // Off to a side and nearly edge-on, against the midpoint rule.
  for (auto [x0, x1, y0, y1, z0] : {std::tuple{0.2, 1.5, -0.3, 0.8, -0.7},
           {-2.0, -0.5, 0.1, 0.4, 0.05}, {1.0, 3.0, 1.0, 2.0, -0.02}}) {
    auto rect = make_spherical_rectangle(
        (float)x0, (float)x1, (float)y0, (float)y1, (float)z0);
    CHECK(rect.solid_angle ==
          doctest::Approx(solid_angle_by_cells(x0, x1, y0, y1, z0, 2000))
              .epsilon(1e-4));
  }
}

TEST_CASE("sampling: spherical rectangle points are uniform in solid angle") {
  // Points land on the rectangle, and each of 4 x 4 cells receives its
  // solid angle's share (midpoint rule) within 5 standard deviations.
  auto rng = make_rng(5);
  for (auto [x0, x1, y0, y1, z0] :
      {std::tuple{-1.0, 1.0, -0.5, 0.7, -0.3}, {0.2, 1.5, -0.3, 0.8, 0.7},
          {-3.0, -0.1, 0.5, 0.9, -0.05}, {-0.25, 0.25, -0.2, 0.2, -1.2}}) {
    auto rect = make_spherical_rectangle(
        (float)x0, (float)x1, (float)y0, (float)y1, (float)z0);
    auto total  = solid_angle_by_cells(x0, x1, y0, y1, z0, 1200);
    auto counts = std::vector<int>(16, 0);
    auto n      = 200000;
    for (auto k = 0; k < n; k++) {
      auto p = sample_spherical_rectangle(rect, rand2f(rng));
      REQUIRE(p.z == (float)z0);
      REQUIRE((p.x >= (float)x0 && p.x <= (float)x1));
      REQUIRE((p.y >= (float)y0 && p.y <= (float)y1));
      auto i = std::min(3, (int)((p.x - x0) / (x1 - x0) * 4));
      auto j = std::min(3, (int)((p.y - y0) / (y1 - y0) * 4));
      counts[i * 4 + j]++;
    }
    for (auto i = 0; i < 4; i++)
      for (auto j = 0; j < 4; j++) {
        auto dx = (x1 - x0) / 4, dy = (y1 - y0) / 4;
        auto share = solid_angle_by_cells(x0 + i * dx, x0 + (i + 1) * dx,
                         y0 + j * dy, y0 + (j + 1) * dy, z0, 300) /
                     total;
        auto expected = n * share;
        CHECK(std::abs(counts[i * 4 + j] - expected) <=
              5 * std::sqrt(expected) + 1);
      }
  }
}
