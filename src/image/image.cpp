// # implicit: images
//
// Colour conversions, tone mapping and lookups, following Yocto/GL 4.2
// (yocto_color.h, yocto_image.cpp, yocto_scene.cpp eval_texture).

#include "image.h"

#include <cmath>
#include <string>

#include "../util/error.h"
#include "../util/memory.h"

namespace implicit {

// -----------------------------------------------------------------------------
// IMAGE DATA
// -----------------------------------------------------------------------------

// A black transparent image of the given size.
image_data make_image(int width, int height) {
  // A negative size would wrap to a huge allocation: refuse it here.
  if (width < 0 || height < 0)
    throw io_error("make_image: bad size " + std::to_string(width) + "x" +
                   std::to_string(height));
  // Reserved first and advised before the zeros touch it: lat-long skies
  // are read at random, where huge pages spare most TLB misses.
  auto image = image_data{width, height, {}};
  assign_huge(image.pixels, (size_t)width * height, vec4f{0, 0, 0, 0});
  return image;
}

// -----------------------------------------------------------------------------
// COLOR
// -----------------------------------------------------------------------------

// sRGB decoding (IEC 61966-2-1 piecewise curve).
float srgb_to_linear(float srgb) {
  return srgb <= 0.04045f ? srgb / 12.92f
                          : std::pow((srgb + 0.055f) / 1.055f, 2.4f);
}

// sRGB encoding (IEC 61966-2-1 piecewise curve).
float linear_to_srgb(float linear) {
  return linear <= 0.0031308f ? 12.92f * linear
                              : 1.055f * std::pow(linear, 1 / 2.4f) - 0.055f;
}

// 8-bit quantisation as in Yocto: clamp(int(x * 256), 0, 255).
uint8_t float_to_byte(float x) {
  // Clamp in float before converting: int(x * 256) is undefined for NaN and
  // for values past INT_MAX, which a diverging path can produce.
  auto scaled = x * 256;
  if (!(scaled > 0)) return 0;
  if (scaled >= 255) return 255;
  return (uint8_t)scaled;
}

// 8-bit to [0,1] float.
float byte_to_float(uint8_t b) { return b / 255.0f; }

// ACES filmic fit (Narkowicz 2015), with Yocto's 0.6 pre-scale that brings
// scene values back to the ACES range.
vec3f tonemap_filmic(vec3f hdr) {
  auto x   = hdr * 0.6f;
  auto ldr = (x * x * 2.51f + x * 0.03f) / (x * x * 2.43f + x * 0.59f + 0.14f);
  return max(ldr, 0.0f);
}

// Exposure (stops), optional filmic curve, then sRGB encoding; alpha is kept.
vec4f tonemap(vec4f hdr, float exposure, bool filmic, bool srgb) {
  auto rgb = xyz(hdr);
  if (exposure != 0) rgb *= std::exp2(exposure);
  if (filmic) rgb = tonemap_filmic(rgb);
  if (srgb) {
    rgb = {linear_to_srgb(rgb.x), linear_to_srgb(rgb.y), linear_to_srgb(rgb.z)};
  }
  return {rgb.x, rgb.y, rgb.z, hdr.w};
}

// Tonemap every pixel.
image_data tonemap_image(
    const image_data& hdr, float exposure, bool filmic, bool srgb) {
  auto ldr = image_data{hdr.width, hdr.height, hdr.pixels};
  for (auto& p : ldr.pixels) p = tonemap(p, exposure, filmic, srgb);
  return ldr;
}

// -----------------------------------------------------------------------------
// LOOKUP
// -----------------------------------------------------------------------------

// Wrap a texture coordinate to [0, size) as Yocto does: fract(u) * size.
// u - trunc(u) is fmod(u, 1) exactly (the difference of a float and its
// integer part is exact) without a libm call; from 2^23 up floats are
// integers, and non-finite u (the comparison fails) reads as 0 too.
static float wrap_coordinate(float u, int size) {
  auto f = std::abs(u) < 8388608.0f ? u - (float)(int)u : 0.0f;
  auto s = f * size;
  if (s < 0) s += size;
  return s;
}

// The four texels of a bilinear lookup, columns i, ii and rows j, jj, and
// the weights u, v of the second ones. The image must not be empty.
struct bilinear_footprint {
  int   i = 0, ii = 0, j = 0, jj = 0;
  float u = 0, v = 0;
};

static bilinear_footprint eval_footprint(const image_data& image, vec2f uv) {
  auto s = wrap_coordinate(uv.x, image.width);
  auto t = wrap_coordinate(uv.y, image.height);
  // s can round up to exactly width for a tiny negative u: the clamp keeps i
  // in range and the weight u = 1 then moves all of it to texel 0.
  auto f = bilinear_footprint{};
  f.i    = clamp((int)s, 0, image.width - 1);
  f.j    = clamp((int)t, 0, image.height - 1);
  f.ii   = f.i + 1 == image.width ? 0 : f.i + 1;  // wrap without a division
  f.jj   = f.j + 1 == image.height ? 0 : f.j + 1;
  f.u    = s - f.i;
  f.v    = t - f.j;
  return f;
}

// Bilinear lookup with wrap-around; texel i sits at u = i / width (Yocto).
vec4f eval_image(const image_data& image, vec2f uv) {
  if (image.width <= 0 || image.height <= 0) return {0, 0, 0, 0};
  auto [i, ii, j, jj, u, v] = eval_footprint(image, uv);
  return pixel(image, i, j) * ((1 - u) * (1 - v)) +
         pixel(image, i, jj) * ((1 - u) * v) +
         pixel(image, ii, j) * (u * (1 - v)) + pixel(image, ii, jj) * (u * v);
}

void prefetch_image(const image_data& image, vec2f uv) {
  if (image.width <= 0 || image.height <= 0) return;
  auto f = eval_footprint(image, uv);
  for (auto row : {f.j, f.jj}) {
    __builtin_prefetch(&pixel(image, f.i, row));
    __builtin_prefetch(&pixel(image, f.ii, row));
  }
}

}  // namespace implicit
