// # implicit: image decoders (implementation)
//
// Why these libraries: stb_image (the 2022 snapshot Debian ships) has
// known fuzz findings in its PNG, JPEG, PNM and HDR decoders (a 1-byte
// write past a JPEG Huffman table, HDR runs of length 0 that loop for ever,
// 16-bit PNM buffers read past their end). libpng and libjpeg-turbo are
// fuzzed continuously upstream and bound their own allocations; the RGBE
// format is small enough to decode here, where our fuzzer covers it.

#include "image_decode.h"

#include <jpeglib.h>
#include <png.h>

#include <cmath>
#include <csetjmp>
#include <cstring>
#include <vector>

#include "../util/error.h"
#include "image_io.h"

namespace implicit {

std::string check_image_size(
    int64_t width, int64_t height, size_t file_size, int64_t pixels_per_byte) {
  auto text = std::to_string(width) + "x" + std::to_string(height);
  if (width <= 0 || height <= 0) return "image is empty (" + text + ")";
  if (width > max_image_size || height > max_image_size)
    return "image is " + text + " pixels, over the limit of " +
           std::to_string(max_image_size) + " per side";
  if (width * height > max_image_pixels)
    return "image is " + text + " pixels, over the limit of " +
           std::to_string(max_image_pixels) + " pixels";
  // Even the best compression needs some bytes: a header alone can not
  // make us allocate gigabytes.
  if (width * height / pixels_per_byte > (int64_t)file_size)
    return "image claims " + text + " pixels, more than a file of " +
           std::to_string(file_size) + " bytes can hold";
  return "";
}

// Throw "cannot read image (reason)" for the file.
[[noreturn]] static void throw_decode_error(
    const std::string& filename, const std::string& reason) {
  throw_io_error(filename, "cannot read image (" + reason + ")");
}

// -----------------------------------------------------------------------------
// PNG (libpng's simplified API)
// -----------------------------------------------------------------------------

bool is_png_data(const uint8_t* data, size_t size) {
  return size >= 8 && png_sig_cmp(data, 0, 8) == 0;
}

// Frees libpng's decoder state on every exit.
struct png_image_owner {
  png_image image = {};
  png_image_owner() { image.version = PNG_IMAGE_VERSION; }
  ~png_image_owner() { png_image_free(&image); }
  png_image_owner(const png_image_owner&)            = delete;
  png_image_owner& operator=(const png_image_owner&) = delete;
};

image_data decode_png(
    const std::string& filename, const uint8_t* data, size_t size) {
  auto  owner = png_image_owner{};
  auto& png   = owner.image;
  if (!png_image_begin_read_from_memory(&png, data, size))
    throw_decode_error(filename, png.message);
  auto error =
      check_image_size(png.width, png.height, size, png_pixels_per_byte);
  if (!error.empty()) throw_io_error(filename, error);
  auto image = make_image((int)png.width, (int)png.height);
  // 16-bit files keep their precision: libpng hands them back linear (it
  // decodes sRGB or the file's gamma) with alpha premultiplied.
  if (png.format & PNG_FORMAT_FLAG_LINEAR) {
    png.format  = PNG_FORMAT_LINEAR_RGB_ALPHA;
    auto pixels = std::vector<uint16_t>(image.pixels.size() * 4);
    if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr))
      throw_decode_error(filename, png.message);
    for (size_t idx = 0; idx < image.pixels.size(); idx++) {
      auto px           = pixels.data() + idx * 4;
      auto alpha        = px[3] / 65535.0f;
      auto scale        = px[3] > 0 ? 1 / (65535.0f * alpha) : 0.0f;
      image.pixels[idx] = {px[0] * scale, px[1] * scale, px[2] * scale, alpha};
    }
    return image;
  }
  png.format  = PNG_FORMAT_RGBA;
  auto pixels = std::vector<uint8_t>(image.pixels.size() * 4);
  if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr))
    throw_decode_error(filename, png.message);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto px           = pixels.data() + idx * 4;
    image.pixels[idx] = {srgb_to_linear(byte_to_float(px[0])),
        srgb_to_linear(byte_to_float(px[1])),
        srgb_to_linear(byte_to_float(px[2])), byte_to_float(px[3])};
  }
  return image;
}

// -----------------------------------------------------------------------------
// JPEG (libjpeg-turbo)
// -----------------------------------------------------------------------------

bool is_jpeg_data(const uint8_t* data, size_t size) {
  return size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF;
}

// Progressive files may hold thousands of scans, each a pass over the whole
// image: libjpeg-turbo's own fuzzers stop at 500 as well.
static constexpr int max_jpeg_scans = 500;

// libjpeg reports errors by calling error_exit, which must not return: we
// jump back to decode_jpeg() with the message.
struct jpeg_error_state {
  jpeg_error_mgr manager                  = {};
  jmp_buf        jump                     = {};
  char           message[JMSG_LENGTH_MAX] = {};
};

static void jpeg_error_exit(j_common_ptr info) {
  auto state = (jpeg_error_state*)info->err;
  info->err->format_message(info, state->message);
  std::longjmp(state->jump, 1);
}

// Warnings (corrupt data that the decoder recovers from) are not printed.
static void jpeg_no_output(j_common_ptr) {}

// Stops progressive files with too many scans.
static void jpeg_check_scans(j_common_ptr info) {
  auto decoder = (j_decompress_ptr)info;
  if (decoder->input_scan_number > max_jpeg_scans) {
    auto state = (jpeg_error_state*)info->err;
    std::snprintf(state->message, sizeof(state->message),
        "more than %d progressive scans", max_jpeg_scans);
    std::longjmp(state->jump, 1);
  }
}

// The libjpeg part, with only trivially destructible locals between setjmp
// and longjmp; returns false with the message in `error`. `image` is sized
// once the header is read.
static bool decode_jpeg_pixels(const uint8_t* data, size_t size,
    image_data& image, std::vector<uint8_t>& row, std::string& error) {
  auto decoder                 = jpeg_decompress_struct{};
  auto state                   = jpeg_error_state{};
  auto progress                = jpeg_progress_mgr{};
  decoder.err                  = jpeg_std_error(&state.manager);
  state.manager.error_exit     = jpeg_error_exit;
  state.manager.output_message = jpeg_no_output;
  progress.progress_monitor    = jpeg_check_scans;
  if (setjmp(state.jump)) {
    jpeg_destroy_decompress(&decoder);
    error = state.message;
    return false;
  }
  jpeg_create_decompress(&decoder);
  decoder.progress = &progress;
  jpeg_mem_src(&decoder, data, (unsigned long)size);
  jpeg_read_header(&decoder, TRUE);
  error = check_image_size(
      decoder.image_width, decoder.image_height, size, jpeg_pixels_per_byte);
  if (!error.empty()) {
    jpeg_destroy_decompress(&decoder);
    return false;
  }
  decoder.out_color_space = JCS_RGB;
  jpeg_start_decompress(&decoder);
  image = make_image((int)decoder.output_width, (int)decoder.output_height);
  row.resize((size_t)decoder.output_width * 3);
  while (decoder.output_scanline < decoder.output_height) {
    auto line   = (size_t)decoder.output_scanline;
    auto buffer = row.data();
    jpeg_read_scanlines(&decoder, &buffer, 1);
    for (size_t i = 0; i < (size_t)image.width; i++) {
      auto px                              = row.data() + i * 3;
      image.pixels[line * image.width + i] = {
          srgb_to_linear(byte_to_float(px[0])),
          srgb_to_linear(byte_to_float(px[1])),
          srgb_to_linear(byte_to_float(px[2])), 1};
    }
  }
  jpeg_finish_decompress(&decoder);
  jpeg_destroy_decompress(&decoder);
  return true;
}

image_data decode_jpeg(
    const std::string& filename, const uint8_t* data, size_t size) {
  auto image = image_data{};
  auto row   = std::vector<uint8_t>{};
  auto error = std::string{};
  if (!decode_jpeg_pixels(data, size, image, row, error)) {
    // Size problems (check_image_size, "image is ...") read as they are;
    // libjpeg's messages get the usual prefix.
    if (error.compare(0, 6, "image ") == 0) throw_io_error(filename, error);
    throw_decode_error(filename, error);
  }
  return image;
}

// -----------------------------------------------------------------------------
// RADIANCE HDR
// -----------------------------------------------------------------------------

bool is_hdr_data(const uint8_t* data, size_t size) {
  return size >= 2 && data[0] == '#' && data[1] == '?';
}

// A cursor over the file; every read checks the end.
struct hdr_reader {
  const uint8_t* begin = nullptr;  // start of the file (for offsets)
  const uint8_t* p     = nullptr;
  const uint8_t* end   = nullptr;
};

// The next header line without its '\n'; false at the end of the file.
static bool read_hdr_line(hdr_reader& r, std::string& line) {
  auto newline = (const uint8_t*)std::memchr(r.p, '\n', (size_t)(r.end - r.p));
  if (newline == nullptr) return false;
  line.assign((const char*)r.p, (size_t)(newline - r.p));
  r.p = newline + 1;
  return true;
}

// Parse "-Y <height> +X <width>" (top-to-bottom rows, the only orientation
// writers use); false for anything else.
static bool parse_hdr_resolution(
    const std::string& line, int64_t& width, int64_t& height) {
  auto p      = line.c_str();
  auto number = [&p](int64_t& value) {
    if (*p < '0' || *p > '9') return false;
    value = 0;
    while (*p >= '0' && *p <= '9') {
      if (value > max_image_size) return false;
      value = value * 10 + (*p++ - '0');
    }
    return true;
  };
  if (std::strncmp(p, "-Y ", 3) != 0) return false;
  p += 3;
  if (!number(height) || std::strncmp(p, " +X ", 4) != 0) return false;
  p += 4;
  return number(width) && *p == '\0';
}

// 2^k for k in [-149, 127], from its bits (std::ldexp(1.0f, k) exactly,
// without a libm call per texel: a 2048x1024 sky spent 60% of its decoding
// there). Below 2^-126 the power is subnormal: a single mantissa bit.
static float power_of_two(int k) {
  auto bits = k >= -126 ? (uint32_t)(k + 127) << 23 : 1u << (k + 149);
  auto f    = 0.0f;
  std::memcpy(&f, &bits, sizeof(f));
  return f;
}

// RGBE to float (a shared 8-bit exponent; 0 is black).
static vec4f rgbe_to_linear(const uint8_t rgbe[4]) {
  if (rgbe[3] == 0) return {0, 0, 0, 1};
  auto scale = power_of_two((int)rgbe[3] - (128 + 8));
  return {rgbe[0] * scale, rgbe[1] * scale, rgbe[2] * scale, 1};
}

// Decode one scanline into `rgbe` (width x 4 bytes): run-length encoded
// (a 2 2 hi lo header, then each channel as runs and literals) or flat.
static void read_hdr_scanline(const std::string& filename, hdr_reader& r,
    int64_t width, int64_t line, std::vector<uint8_t>& rgbe) {
  auto fail = [&](const std::string& problem) {
    throw_decode_error(filename, "scanline " + std::to_string(line) + ": " +
                                     problem + " at byte " +
                                     std::to_string(r.p - r.begin));
  };
  auto remaining = [&r]() { return (size_t)(r.end - r.p); };
  auto rle = width >= 8 && width < 32768 && remaining() >= 4 && r.p[0] == 2 &&
             r.p[1] == 2 && (r.p[2] & 0x80) == 0;
  if (!rle) {
    if (remaining() < (size_t)width * 4) fail("file ends");
    std::memcpy(rgbe.data(), r.p, (size_t)width * 4);
    r.p += width * 4;
    return;
  }
  if (((int64_t)r.p[2] << 8 | r.p[3]) != width)
    fail("run-length header for another width");
  r.p += 4;
  for (auto c = 0; c < 4; c++) {
    for (auto i = int64_t{0}; i < width;) {
      if (remaining() < 2) fail("file ends");
      auto count = (int64_t)*r.p++;
      auto run   = count > 128;
      if (run) count -= 128;
      // A count of 0 never advances: stb's decoder loops for ever on it.
      if (count == 0 || count > width - i) fail("bad run length");
      if (run) {
        auto value = *r.p++;
        for (auto n = 0; n < count; n++) rgbe[(size_t)(i + n) * 4 + c] = value;
      } else {
        if (remaining() < (size_t)count) fail("file ends");
        for (auto n = 0; n < count; n++) rgbe[(size_t)(i + n) * 4 + c] = *r.p++;
      }
      i += count;
    }
  }
}

image_data decode_hdr(
    const std::string& filename, const uint8_t* data, size_t size) {
  if (!is_hdr_data(data, size))
    throw_decode_error(filename, "not a Radiance HDR file");
  auto r      = hdr_reader{data, data, data + size};
  auto line   = std::string{};
  auto format = false;
  while (true) {
    if (!read_hdr_line(r, line))
      throw_decode_error(filename, "the header has no end");
    if (line.empty()) break;
    if (line.compare(0, 7, "FORMAT=") == 0) {
      if (line != "FORMAT=32-bit_rle_rgbe")
        throw_decode_error(filename, "unsupported " + line.substr(0, 40));
      format = true;
    }
  }
  if (!format) throw_decode_error(filename, "no FORMAT=32-bit_rle_rgbe line");
  auto width = int64_t{0}, height = int64_t{0};
  if (!read_hdr_line(r, line) || !parse_hdr_resolution(line, width, height))
    throw_decode_error(filename,
        "unsupported resolution line (only '-Y height +X width' is read)");
  auto error = check_image_size(width, height, size, hdr_pixels_per_byte);
  if (!error.empty()) throw_io_error(filename, error);
  auto image = make_image((int)width, (int)height);
  auto rgbe  = std::vector<uint8_t>((size_t)width * 4);
  for (auto j = int64_t{0}; j < height; j++) {
    read_hdr_scanline(filename, r, width, j, rgbe);
    for (auto i = int64_t{0}; i < width; i++)
      image.pixels[(size_t)(j * width + i)] = rgbe_to_linear(&rgbe[i * 4]);
  }
  return image;
}

}  // namespace implicit
