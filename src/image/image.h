// # implicit: images
//
// Linear float RGBA images, tone mapping and colour conversions. Row 0 is the
// top of the image.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "../math/math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// IMAGE DATA
// -----------------------------------------------------------------------------

// Linear RGBA pixels, row-major, row 0 at the top.
struct image_data {
  int                width  = 0;
  int                height = 0;
  std::vector<vec4f> pixels = {};
};

// A named layer of float channels beside an image (an AOV: albedo, normal,
// depth, ...): `channels.size()` values per pixel, interleaved, row-major,
// with the image's size. OpenEXR writes them as channels "name.channel".
struct image_layer {
  std::string              name     = "";
  std::vector<std::string> channels = {};
  std::vector<float>       values   = {};
};

// A black transparent image of the given size.
image_data make_image(int width, int height);

// Pixel access.
inline vec4f& pixel(image_data& image, int i, int j) {
  return image.pixels[(size_t)j * image.width + i];
}
inline const vec4f& pixel(const image_data& image, int i, int j) {
  return image.pixels[(size_t)j * image.width + i];
}

// -----------------------------------------------------------------------------
// COLOR
// -----------------------------------------------------------------------------

// sRGB transfer functions, per channel.
float srgb_to_linear(float srgb);
float linear_to_srgb(float linear);

// 8-bit quantisation as in Yocto: clamp(int(x * 256), 0, 255); NaN maps to 0.
uint8_t float_to_byte(float x);
// 8-bit to [0,1] float: b / 255.
float byte_to_float(uint8_t b);

// ACES filmic fit (Narkowicz 2015), as in Yocto/GL.
vec3f tonemap_filmic(vec3f hdr);

// Exposure (stops), optional filmic curve, then sRGB encoding; alpha is kept.
vec4f      tonemap(vec4f hdr, float exposure, bool filmic, bool srgb = true);
image_data tonemap_image(
    const image_data& hdr, float exposure, bool filmic, bool srgb = true);

// Bilinear lookup with wrap-around, uv in [0,1]^2 (u right, v down).
// As Yocto's eval_texture: s = fract(u) * width, so texel i's value is met
// exactly at u = i / width (not at its centre (i + 0.5) / width) and the last
// texel blends into the first. An empty image gives (0,0,0,0); a non-finite
// uv is read as 0. Never throws.
vec4f eval_image(const image_data& image, vec2f uv);

// Start reading the texels eval_image(image, uv) reads, for a lookup that
// comes later: a light sample toward a large sky knows its uv a whole ray
// before the sky is looked up. A hint; reads nothing.
void prefetch_image(const image_data& image, vec2f uv);

}  // namespace implicit
