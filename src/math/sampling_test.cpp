// Tests for the sampling helpers: the fast atan2 against the C library's
// (error bound, signs and zeros) and the lat-long mapping's round trip.

#include "sampling.h"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>

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
