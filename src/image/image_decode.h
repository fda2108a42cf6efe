// # implicit: image decoders (internal to src/image)
//
// PNG through libpng, JPEG through libjpeg-turbo (both fuzzed upstream, in
// OSS-Fuzz), Radiance HDR with our own decoder (stb's loops for ever on a
// run of length 0). Each decodes a whole file held in memory, checks the
// size its header claims with check_image_size() before allocating, and
// throws io_error naming the file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "image.h"

namespace implicit {

// "" when a width x height image from a file of `file_size` bytes is within
// the limits of image_io.h, else the problem ("4096x0 pixels: ...").
std::string check_image_size(int64_t width, int64_t height, size_t file_size);

// Whether the bytes start with the signature of the format.
bool is_png_data(const uint8_t* data, size_t size);
bool is_jpeg_data(const uint8_t* data, size_t size);
bool is_hdr_data(const uint8_t* data, size_t size);

// Decode as linear RGBA: 8- and 16-bit colour from sRGB, alpha as it is.
image_data decode_png(
    const std::string& filename, const uint8_t* data, size_t size);
// Decode as linear RGBA (sRGB colour; alpha is 1).
image_data decode_jpeg(
    const std::string& filename, const uint8_t* data, size_t size);
// Decode RGBE scanlines (flat or run-length encoded) as linear RGBA (alpha
// is 1).
image_data decode_hdr(
    const std::string& filename, const uint8_t* data, size_t size);

}  // namespace implicit
