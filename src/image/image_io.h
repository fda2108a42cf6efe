// # implicit: image files
//
// Load and save images by extension: .png/.jpg/.jpeg/.tga/.bmp (8-bit sRGB;
// 16-bit PNG), .hdr (Radiance) and .exr (OpenEXR), linear float. Errors
// throw io_error naming the file, an image over the limits below included.
// Saving writes a temporary file next to the target and renames it, so a file
// is written whole or not at all.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "image.h"

namespace implicit {

// Limits on images read, checked from the header before decoding: pixels per
// side and pixels in all (2^26 pixels is 1 GiB as float RGBA). Each format
// also bounds the pixels per byte of the file (image_decode.h), so that a
// tiny header can not make us allocate gigabytes.
inline constexpr int     max_image_size   = 32768;
inline constexpr int64_t max_image_pixels = int64_t{1} << 26;

// Whether the extension is a linear float format (.hdr, .exr).
bool is_hdr_filename(const std::string& filename);

// Load an image as linear RGBA (8-bit files are converted from sRGB).
image_data load_image(const std::string& filename);
// The same from the bytes of a file; `filename` picks the decoder by its
// extension and names the file in errors.
image_data load_image_from_memory(
    const std::string& filename, const void* data, size_t size);

// Save linear RGBA: HDR formats get the values as they are, LDR formats the
// tonemapped sRGB (exposure in stops, optional filmic curve). `layers` (AOVs)
// go into an .exr as channels "layer.channel" (albedo.R, normal.X, depth.Z:
// OpenEXR's multi-layer naming, which Blender reads); beside any other
// format each is a file of its own, layer_filename(), with its channels
// unprefixed. Every file is written atomically.
void save_image(const std::string& filename, const image_data& image,
    float exposure = 0, bool filmic = false,
    const std::vector<image_layer>& layers = {});

// The file of a layer beside a .png/.jpg/.hdr image: out.png ->
// out.albedo.exr.
std::string layer_filename(
    const std::string& filename, const std::string& layer);

}  // namespace implicit
