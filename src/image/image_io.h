// # implicit: image files
//
// Load and save images by extension: .png/.jpg/.jpeg/.tga/.bmp (8-bit sRGB,
// through stb), .hdr (Radiance, stb) and .exr (OpenEXR), linear float.
// Errors throw io_error naming the file. Saving writes a temporary file next
// to the target and renames it, so a file is written whole or not at all.
#pragma once

#include <string>

#include "image.h"

namespace implicit {

// Whether the extension is a linear float format (.hdr, .exr).
bool is_hdr_filename(const std::string& filename);

// Load an image as linear RGBA (8-bit files are converted from sRGB).
image_data load_image(const std::string& filename);

// Save linear RGBA: HDR formats get the values as they are, LDR formats the
// tonemapped sRGB (exposure in stops, optional filmic curve).
void save_image(const std::string& filename, const image_data& image,
    float exposure = 0, bool filmic = false);

}  // namespace implicit
