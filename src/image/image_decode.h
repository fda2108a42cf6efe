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

// Pixels per byte of the file beyond what each format's best compression
// reaches (with a margin): a header claiming more is refused.
inline constexpr int64_t png_pixels_per_byte = 1
                                               << 14;  // deflate ~1032:1, 1-bit
inline constexpr int64_t jpeg_pixels_per_byte = 1 << 12;  // progressive runs
inline constexpr int64_t exr_pixels_per_byte  = 1 << 12;  // zip of one channel
inline constexpr int64_t hdr_pixels_per_byte  = 64;   // runs of 127 in 8 bytes
inline constexpr int64_t stb_pixels_per_byte  = 256;  // TGA and BMP runs

// "" when a width x height image from a file of `file_size` bytes is within
// the limits of image_io.h and `pixels_per_byte`, else the problem.
std::string check_image_size(
    int64_t width, int64_t height, size_t file_size, int64_t pixels_per_byte);

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
