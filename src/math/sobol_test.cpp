// Tests for the scrambled Sobol samples: range, stratification of the first
// 2^m samples in every dimension, independence of pixels and dimensions,
// and faster convergence than independent random numbers.

#include "sobol.h"

#include <doctest/doctest.h>

#include <cmath>
#include <set>
#include <vector>

#include "random.h"

using namespace implicit;

// The points of dimension `dimension` of samples 0..count-1 of one pixel.
static std::vector<vec2f> pixel_points(
    uint32_t seed, int count, int dimension) {
  auto points = std::vector<vec2f>{};
  for (auto index = 0; index < count; index++) {
    auto state = make_sobol(seed, (uint32_t)index);
    for (auto d = 0; d < dimension; d++) sample2f(state);
    points.push_back(sample2f(state));
  }
  return points;
}

TEST_CASE("sobol: owen_scramble is a bijection that keeps top-bit strata") {
  // 8-bit prefixes: the scramble of x depends on the top k bits of x only
  // through the top k bits of the result.
  for (auto seed : {1u, 0xdeadbeefu, 12345u}) {
    auto images = std::set<uint32_t>{};
    for (auto x = 0u; x < 256u; x++)
      images.insert(owen_scramble(x << 24, seed) >> 24);
    CHECK(images.size() == 256);  // a permutation of the top 8 bits
    for (auto x = 0u; x < 256u; x++) {
      auto top      = owen_scramble(x << 24, seed) >> 24;
      auto with_low = owen_scramble((x << 24) | 0x00abcdefu, seed) >> 24;
      CHECK(top == with_low);
    }
  }
}

TEST_CASE("sobol: reverse_bits") {
  CHECK(reverse_bits(1u) == 0x80000000u);
  CHECK(reverse_bits(0x12345678u) == 0x1e6a2c48u);
  CHECK(reverse_bits(0xf0000001u) == 0x8000000fu);
  for (auto x : {0u, 7u, 0xdeadbeefu, 0xffffffffu})
    CHECK(reverse_bits(reverse_bits(x)) == x);
}

TEST_CASE("sobol: dimension 1 tables equal the direction-number loop") {
  auto rng = make_rng(11);
  for (auto k = 0; k < 1000; k++) {
    auto index    = k < 64 ? (uint32_t)k : (uint32_t)advance_rng(rng);
    auto expected = 0u;
    auto bits     = index;
    for (auto v = 1u << 31; bits != 0; bits >>= 1, v ^= v >> 1)
      if (bits & 1) expected ^= v;
    CHECK(sobol_dimension1(index) == expected);
  }
  // Its first points: 1/2, 3/4, 1/4, 5/8 as fractions of 2^32.
  CHECK(sobol_dimension1(1) == 0x80000000u);
  CHECK(sobol_dimension1(2) == 0xc0000000u);
  CHECK(sobol_dimension1(3) == 0x40000000u);
  CHECK(sobol_dimension1(4) == 0xa0000000u);
}

TEST_CASE("sobol: first 2^m samples of a pixel are a (0,m,2)-net") {
  // 64 points: every partition into 64 elementary intervals 2^-a x 2^-(6-a)
  // has exactly one point per interval, in every dimension and pixel.
  for (auto seed : {7u, 99u, 0xabcdef01u}) {
    for (auto dimension : {0, 1, 5, 20}) {
      auto points = pixel_points(seed, 64, dimension);
      for (auto a = 0; a <= 6; a++) {
        auto cells = std::set<int>{};
        for (auto& p : points) {
          REQUIRE(p.x >= 0);
          REQUIRE(p.x < 1);
          REQUIRE(p.y >= 0);
          REQUIRE(p.y < 1);
          auto cx = (int)(p.x * (1 << a)), cy = (int)(p.y * (1 << (6 - a)));
          cells.insert(cx * (1 << (6 - a)) + cy);
        }
        INFO("seed ", seed, " dimension ", dimension, " a ", a);
        CHECK(cells.size() == 64);
      }
    }
  }
}

TEST_CASE("sobol: 1D samples are stratified and dimensions differ") {
  auto values = std::set<int>{};
  auto same   = 0;
  for (auto index = 0u; index < 32u; index++) {
    auto state = make_sobol(5, index);
    auto a     = sample1f(state);
    auto b     = sample1f(state);
    values.insert((int)(a * 32));
    if ((int)(a * 32) == (int)(b * 32)) same++;
  }
  CHECK(values.size() == 32);  // one per 1/32 stratum
  CHECK(same < 8);             // dimension 1 is not a copy of dimension 0
}

TEST_CASE("sobol: pixels are decorrelated") {
  // The first sample of neighbouring pixels: spread over the square, not
  // one point repeated.
  auto cells = std::set<int>{};
  for (auto pixel = 0u; pixel < 256u; pixel++) {
    auto state = make_sobol(hash_uint32(pixel), 0);
    auto p     = sample2f(state);
    cells.insert((int)(p.x * 4) * 4 + (int)(p.y * 4));
  }
  CHECK(cells.size() == 16);
}

TEST_CASE("sobol: integrates a smooth function with a smaller error") {
  // f(x, y) = x exp(x) y over the unit square: 1 * 1/2.
  auto exact       = 0.5;
  auto sobol_error = 0.0, random_error = 0.0;
  auto rng = make_rng(3);
  for (auto pixel = 0u; pixel < 64u; pixel++) {
    auto sobol = 0.0, random = 0.0;
    for (auto index = 0u; index < 256u; index++) {
      auto state = make_sobol(hash_uint32(pixel), index);
      auto p     = sample2f(state);
      auto q     = rand2f(rng);
      sobol += p.x * std::exp(p.x) * p.y / 256;
      random += q.x * std::exp(q.x) * q.y / 256;
    }
    sobol_error += (sobol - exact) * (sobol - exact) / 64;
    random_error += (random - exact) * (random - exact) / 64;
  }
  // Random: RMSE ~ 0.025 at 256 samples; scrambled Sobol ~ 100x less.
  CHECK(std::sqrt(sobol_error) < 0.1 * std::sqrt(random_error));
  CHECK(std::sqrt(sobol_error) < 1e-3);
}
