// Tests for colour conversions, tone mapping and image lookups.

#include "image.h"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "../math/random.h"
#include "../util/error.h"

namespace implicit {

// A 2x2 image whose blends are exact in float: texel (i,j) holds
// base[j*2+i] in every channel, alpha 1 - base / 8.
static image_data make_test_image_2x2() {
  auto image  = make_image(2, 2);
  auto values = {0.0f, 1.0f, 2.0f, 4.0f};
  auto idx    = 0;
  for (auto v : values) image.pixels[idx++] = {v, v * 2, v * 4, 1 - v / 8};
  return image;
}

// Exact comparison of all four channels.
static bool equal(vec4f a, vec4f b) {
  return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w;
}

TEST_CASE("image make_image") {
  auto image = make_image(3, 2);
  CHECK(image.width == 3);
  CHECK(image.height == 2);
  REQUIRE(image.pixels.size() == 6);
  for (auto& p : image.pixels) CHECK(equal(p, {0, 0, 0, 0}));
  // Row-major, row 0 at the top: pixel(i, j) is pixels[j * width + i].
  pixel(image, 2, 1) = {1, 2, 3, 4};
  CHECK(equal(image.pixels[5], {1, 2, 3, 4}));
  CHECK(make_image(0, 0).pixels.empty());
  CHECK_THROWS_AS(make_image(-1, 4), io_error);
}

TEST_CASE("image srgb known values and round trip") {
  // 1.055 * 0.5^(1/2.4) - 0.055.
  CHECK(linear_to_srgb(0.5f) == doctest::Approx(0.7353569).epsilon(1e-6));
  CHECK(srgb_to_linear(0.7353569f) == doctest::Approx(0.5).epsilon(1e-6));
  CHECK(linear_to_srgb(0.0f) == 0.0f);
  CHECK(linear_to_srgb(1.0f) == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(srgb_to_linear(1.0f) == doctest::Approx(1.0).epsilon(1e-6));
  // The linear segment below the knee.
  CHECK(linear_to_srgb(0.002f) == doctest::Approx(0.02584).epsilon(1e-5));
  CHECK(srgb_to_linear(0.04f) == doctest::Approx(0.04 / 12.92).epsilon(1e-6));
  // The two pieces meet at the knee (continuity within float rounding).
  CHECK(linear_to_srgb(0.0031308f) ==
        doctest::Approx(linear_to_srgb(0.0031309f)).epsilon(1e-4));
  // Round trip over [0, 4] (values above 1 come from HDR renders).
  for (auto i = 0; i <= 400; i++) {
    auto linear = i / 100.0f;
    CHECK(srgb_to_linear(linear_to_srgb(linear)) ==
          doctest::Approx(linear).epsilon(1e-5).scale(1e-6));
  }
}

TEST_CASE("image float_to_byte") {
  CHECK(float_to_byte(0.0f) == 0);
  CHECK(float_to_byte(0.5f) == 128);
  CHECK(float_to_byte(1.0f / 256) == 1);
  CHECK(float_to_byte(0.999f) == 255);
  CHECK(float_to_byte(1.0f) == 255);
  CHECK(float_to_byte(-0.5f) == 0);
  CHECK(float_to_byte(1e30f) == 255);
  CHECK(float_to_byte(std::numeric_limits<float>::infinity()) == 255);
  CHECK(float_to_byte(std::numeric_limits<float>::quiet_NaN()) == 0);
  CHECK(byte_to_float(255) == 1.0f);
  CHECK(byte_to_float(0) == 0.0f);
}

TEST_CASE("image filmic curve") {
  // x = 0.6: (0.36*2.51 + 0.018) / (0.36*2.43 + 0.354 + 0.14).
  auto one = tonemap_filmic({1, 1, 1});
  CHECK(one.x == doctest::Approx(0.9216 / 1.3688).epsilon(1e-6));
  CHECK(one.y == one.x);
  CHECK(one.z == one.x);
  CHECK(tonemap_filmic({0, 0, 0}).x == 0);
  // Small negative values give a negative fit, clamped to 0.
  CHECK(tonemap_filmic({-0.01f, -0.01f, -0.01f}).x == 0);
  // Monotone increasing over [0, 100], approaching 2.51 / 2.43.
  auto previous = -1.0f;
  for (auto i = 0; i <= 1000; i++) {
    auto value = tonemap_filmic({i / 10.0f, 0, 0}).x;
    CHECK(value > previous);
    previous = value;
  }
  CHECK(previous < 2.51f / 2.43f);
  CHECK(previous > 1.0f);
}

TEST_CASE("image tonemap exposure filmic srgb") {
  auto hdr = vec4f{0.25f, 0.125f, 1.5f, 0.3f};
  // One stop doubles the linear value; alpha is never touched.
  auto doubled = tonemap(hdr, 1, false, false);
  CHECK(equal(doubled, {0.5f, 0.25f, 3.0f, 0.3f}));
  CHECK(
      equal(tonemap(hdr, -2, false, false), {0.0625f, 0.03125f, 0.375f, 0.3f}));
  CHECK(equal(tonemap(hdr, 0, false, false), hdr));
  // sRGB encoding after exposure.
  auto encoded = tonemap(hdr, 1, false, true);
  CHECK(encoded.x == doctest::Approx(0.7353569).epsilon(1e-6));
  CHECK(encoded.w == 0.3f);
  // Filmic comes after exposure and before sRGB.
  auto filmic = tonemap({0.5f, 0.5f, 0.5f, 1}, 1, true, true);
  CHECK(filmic.x == doctest::Approx(linear_to_srgb(0.9216f / 1.3688f)));
  CHECK(filmic.w == 1);
  // The image version applies the same to every pixel.
  auto image  = make_test_image_2x2();
  auto mapped = tonemap_image(image, 1.5f, true, true);
  CHECK(mapped.width == 2);
  CHECK(mapped.height == 2);
  for (auto idx = 0; idx < 4; idx++)
    CHECK(equal(mapped.pixels[idx], tonemap(image.pixels[idx], 1.5f, true)));
}

TEST_CASE("image eval_image bilinear") {
  auto image = make_test_image_2x2();
  auto p00 = pixel(image, 0, 0), p10 = pixel(image, 1, 0);
  auto p01 = pixel(image, 0, 1), p11 = pixel(image, 1, 1);
  // Texel (i,j) is met exactly at uv = (i/W, j/H), as in Yocto.
  CHECK(equal(eval_image(image, {0, 0}), p00));
  CHECK(equal(eval_image(image, {0.5f, 0}), p10));
  CHECK(equal(eval_image(image, {0, 0.5f}), p01));
  CHECK(equal(eval_image(image, {0.5f, 0.5f}), p11));
  // Halfway between the four texels: their mean, (0+1+2+4)/4 in red.
  auto mid = eval_image(image, {0.25f, 0.25f});
  CHECK(equal(mid, {1.75f, 3.5f, 7.0f, 1 - 1.75f / 8}));
  // A quarter of the way from texel 0 to texel 1 along u.
  CHECK(equal(
      eval_image(image, {0.125f, 0}), {0.25f, 0.5f, 1.0f, 1 - 0.25f / 8}));
  // Along v: 3/4 of the way from row 0 to row 1 in column 1.
  auto down = eval_image(image, {0.5f, 0.375f});
  CHECK(down.x == 0.25f * p10.x + 0.75f * p11.x);
  CHECK(p01.x == 2.0f);
}

TEST_CASE("image eval_image wrap-around") {
  auto image = make_test_image_2x2();
  auto p00 = pixel(image, 0, 0), p10 = pixel(image, 1, 0);
  auto p01 = pixel(image, 0, 1);
  // Past the last texel the lookup blends back into the first one.
  auto half = eval_image(image, {0.75f, 0});
  CHECK(half.x == 0.5f * p10.x + 0.5f * p00.x);
  CHECK(eval_image(image, {0, 0.75f}).x == 0.5f * p01.x + 0.5f * p00.x);
  // Whole periods do not matter, in either direction.
  CHECK(equal(eval_image(image, {1.25f, 0}), eval_image(image, {0.25f, 0})));
  CHECK(equal(eval_image(image, {-0.25f, 0}), half));
  CHECK(equal(eval_image(image, {1, 1}), p00));
  CHECK(equal(eval_image(image, {-3, 2}), p00));
  CHECK(equal(
      eval_image(image, {0.25f, -0.75f}), eval_image(image, {0.25f, 0.25f})));
  // A tiny negative u rounds s up to exactly W: the weight goes to texel 0.
  auto tiny = eval_image(image, {-1e-9f, 0});
  CHECK(tiny.x == doctest::Approx(p00.x).scale(1));
  // No throw and no out-of-range read for bad input.
  auto nan = std::numeric_limits<float>::quiet_NaN();
  CHECK(equal(eval_image(image, {nan, nan}), p00));
  CHECK(equal(eval_image(image_data{}, {0.5f, 0.5f}), {0, 0, 0, 0}));
}

// eval_image as first written (fmod and %), the reference its cheaper
// wrap-around must match bit for bit.
static vec4f eval_image_fmod(const image_data& image, vec2f uv) {
  auto wrap = [](float u, int size) {
    if (!std::isfinite(u)) return 0.0f;
    auto s = std::fmod(u, 1.0f) * size;
    if (s < 0) s += size;
    return s;
  };
  auto s = wrap(uv.x, image.width), t = wrap(uv.y, image.height);
  auto i  = std::clamp((int)s, 0, image.width - 1);
  auto j  = std::clamp((int)t, 0, image.height - 1);
  auto ii = (i + 1) % image.width, jj = (j + 1) % image.height;
  auto u = s - i, v = t - j;
  return pixel(image, i, j) * ((1 - u) * (1 - v)) +
         pixel(image, i, jj) * ((1 - u) * v) +
         pixel(image, ii, j) * (u * (1 - v)) + pixel(image, ii, jj) * (u * v);
}

TEST_CASE("image eval_image equals the fmod wrap-around bit for bit") {
  auto image = make_image(7, 5);
  auto rng   = make_rng(3);
  for (auto& p : image.pixels) p = {rand1f(rng), rand1f(rng), rand1f(rng), 1};
  auto same = [&](vec2f uv) {
    CAPTURE(uv.x);
    CAPTURE(uv.y);
    CHECK(equal(eval_image(image, uv), eval_image_fmod(image, uv)));
  };
  for (auto k = 0; k < 100000; k++) {
    auto r = rand2f(rng);
    same({r.x, r.y});
    same({(r.x - 0.5f) * 10, (r.y - 0.5f) * 1e-6f});
    same({(r.x - 0.5f) * 3e7f, -r.y});
  }
  auto inf = std::numeric_limits<float>::infinity();
  auto nan = std::numeric_limits<float>::quiet_NaN();
  for (auto u : {0.0f, -0.0f, 1.0f, -1.0f, 1e-9f, -1e-9f, -1e-30f, 0.99999994f,
           -0.99999994f, 8388607.5f, -8388607.5f, 8388608.0f, -8388609.0f,
           1e30f, -1e30f, inf, -inf, nan})
    for (auto v : {0.0f, -1e-9f, 0.5f, -0.75f}) {
      same({u, v});
      same({v, u});
    }
}

}  // namespace implicit
