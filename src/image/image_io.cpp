// # implicit: image files
//
// 8-bit formats and Radiance HDR go through stb, OpenEXR through the OpenEXR
// library, always as 32-bit float channels so that round trips are exact.
// Every writer streams into a temporary file next to the target that is then
// renamed over it: a reader never sees a half-written image, and a failed
// save leaves the previous file (if any) untouched.

#include "image_io.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#include <unistd.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "../util/error.h"
#include "../util/file.h"

namespace implicit {

// -----------------------------------------------------------------------------
// HELPERS
// -----------------------------------------------------------------------------

// The kinds of file we read and write, chosen by extension.
enum class image_format { ldr, hdr, exr, unknown };

// The format of a file name, by extension.
static image_format get_format(const std::string& filename) {
  auto ext = path_extension(filename);
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tga" ||
      ext == ".bmp")
    return image_format::ldr;
  if (ext == ".hdr") return image_format::hdr;
  if (ext == ".exr") return image_format::exr;
  return image_format::unknown;
}

// Throw the error for an extension we do not handle.
[[noreturn]] static void throw_unknown_format(const std::string& filename) {
  throw_io_error(
      filename, "unknown image format (use .png, .jpg, .hdr or .exr)");
}

// The text for an errno value, with a fallback when the C library left none.
static std::string errno_reason(int error) {
  return error != 0 ? std::strerror(error) : "input/output error";
}

// Closes a FILE* when it goes out of scope.
struct file_closer {
  void operator()(std::FILE* file) const { std::fclose(file); }
};
using file_ptr = std::unique_ptr<std::FILE, file_closer>;

// Frees stb's pixel buffers.
struct stb_freer {
  void operator()(void* data) const { stbi_image_free(data); }
};

// stb's reason for its last failure.
static std::string stb_reason() {
  auto reason = stbi_failure_reason();
  return reason != nullptr ? reason : "unknown error";
}

// -----------------------------------------------------------------------------
// LOADING
// -----------------------------------------------------------------------------

// Open a file for reading; a missing or empty file is an error naming it.
static file_ptr open_for_reading(const std::string& filename) {
  auto file = file_ptr{std::fopen(filename.c_str(), "rb")};
  if (!file)
    throw_io_error(filename, "cannot open (" + errno_reason(errno) + ")");
  // A directory opens fine on Linux and fails later with vaguer reasons;
  // an empty file would get stb's "unknown image type".
  if (std::filesystem::is_directory(filename))
    throw_io_error(filename, "cannot open (" + errno_reason(EISDIR) + ")");
  if (std::fseek(file.get(), 0, SEEK_END) != 0)
    throw_io_error(filename, "cannot read (" + errno_reason(errno) + ")");
  auto size = std::ftell(file.get());
  if (size < 0)
    throw_io_error(filename, "cannot read (" + errno_reason(errno) + ")");
  if (size == 0) throw_io_error(filename, "file is empty");
  std::rewind(file.get());
  return file;
}

// Check what stb returned; dimensions must make a non-empty image.
static void check_stb_result(
    const std::string& filename, const void* data, int width, int height) {
  if (data == nullptr)
    throw_io_error(filename, "cannot read image (" + stb_reason() + ")");
  if (width <= 0 || height <= 0) throw_io_error(filename, "image is empty");
}

// Load an 8- or 16-bit file through stb, decoding sRGB colour (not alpha).
static image_data load_ldr(const std::string& filename) {
  auto file  = open_for_reading(filename);
  auto width = 0, height = 0, channels = 0;
  // 16-bit PNGs keep their precision; everything else is 8-bit.
  if (stbi_is_16_bit_from_file(file.get())) {
    auto data = std::unique_ptr<stbi_us, stb_freer>{
        stbi_load_from_file_16(file.get(), &width, &height, &channels, 4)};
    check_stb_result(filename, data.get(), width, height);
    auto image = make_image(width, height);
    for (size_t idx = 0; idx < image.pixels.size(); idx++) {
      auto px           = data.get() + idx * 4;
      image.pixels[idx] = {srgb_to_linear(px[0] / 65535.0f),
          srgb_to_linear(px[1] / 65535.0f), srgb_to_linear(px[2] / 65535.0f),
          px[3] / 65535.0f};
    }
    return image;
  }
  auto data = std::unique_ptr<stbi_uc, stb_freer>{
      stbi_load_from_file(file.get(), &width, &height, &channels, 4)};
  check_stb_result(filename, data.get(), width, height);
  auto image = make_image(width, height);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto px           = data.get() + idx * 4;
    image.pixels[idx] = {srgb_to_linear(byte_to_float(px[0])),
        srgb_to_linear(byte_to_float(px[1])),
        srgb_to_linear(byte_to_float(px[2])), byte_to_float(px[3])};
  }
  return image;
}

// Load a Radiance HDR file through stb (linear; alpha is 1).
static image_data load_hdr(const std::string& filename) {
  auto file = open_for_reading(filename);
  // stbi_loadf would also decode an 8-bit file, with a gamma 2.2 guess.
  if (!stbi_is_hdr_from_file(file.get()))
    throw_io_error(filename, "cannot read image (not a Radiance HDR file)");
  auto width = 0, height = 0, channels = 0;
  auto data = std::unique_ptr<float, stb_freer>{
      stbi_loadf_from_file(file.get(), &width, &height, &channels, 4)};
  check_stb_result(filename, data.get(), width, height);
  auto image = make_image(width, height);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto px           = data.get() + idx * 4;
    image.pixels[idx] = {px[0], px[1], px[2], px[3]};
  }
  return image;
}

// Load an OpenEXR file as float RGBA. Missing colour channels read as 0 and
// a missing alpha as 1; a luminance-only file (channel Y) is read as grey.
static image_data load_exr(const std::string& filename) {
  // Open it once ourselves for a clear message on missing or empty files.
  open_for_reading(filename);
  try {
    auto file   = Imf::InputFile(filename.c_str());
    auto window = file.header().dataWindow();
    auto width  = (int64_t)window.max.x - window.min.x + 1;
    auto height = (int64_t)window.max.y - window.min.y + 1;
    if (width <= 0 || height <= 0 || width > INT32_MAX || height > INT32_MAX)
      throw_io_error(filename, "image is empty or too large");
    auto  image    = make_image((int)width, (int)height);
    auto& channels = file.header().channels();
    auto  has      = [&](const char* name) {
      return channels.findChannel(name) != nullptr;
    };
    auto grey = !has("R") && !has("G") && !has("B") && has("Y");
    // Without any colour channel the image would silently read as black.
    if (!has("R") && !has("G") && !has("B") && !has("Y")) {
      auto found = std::string{};
      for (auto it = channels.begin(); it != channels.end(); ++it)
        found += (found.empty() ? "" : ", ") + std::string(it.name());
      throw_io_error(
          filename, "no R, G, B or Y channel (found: " + found + ")");
    }
    // The slices read straight into the interleaved vec4f pixels; OpenEXR
    // converts half/uint channels to float and fills absent ones.
    auto base    = (char*)image.pixels.data();
    auto xstride = sizeof(vec4f), ystride = sizeof(vec4f) * (size_t)width;
    auto buffer = Imf::FrameBuffer{};
    auto names  = grey ? std::vector<const char*>{"Y"}
                       : std::vector<const char*>{"R", "G", "B"};
    for (size_t c = 0; c < names.size(); c++) {
      buffer.insert(
          names[c], Imf::Slice::Make(Imf::FLOAT, base + c * sizeof(float),
                        window, xstride, ystride, 1, 1, 0.0));
    }
    buffer.insert("A", Imf::Slice::Make(Imf::FLOAT, base + 3 * sizeof(float),
                           window, xstride, ystride, 1, 1, 1.0));
    file.setFrameBuffer(buffer);
    file.readPixels(window.min.y, window.max.y);
    if (grey) {
      for (auto& p : image.pixels) p.y = p.z = p.x;
    }
    return image;
  } catch (const io_error&) { throw; } catch (const std::exception& error) {
    // OpenEXR throws Iex exceptions (and std::bad_alloc on absurd headers).
    throw_io_error(
        filename, std::string("cannot read image (") + error.what() + ")");
  }
}

// Whether the extension is a linear float format (.hdr, .exr).
bool is_hdr_filename(const std::string& filename) {
  auto format = get_format(filename);
  return format == image_format::hdr || format == image_format::exr;
}

// Load an image as linear RGBA (8-bit files are converted from sRGB).
image_data load_image(const std::string& filename) {
  switch (get_format(filename)) {
    case image_format::ldr: return load_ldr(filename);
    case image_format::hdr: return load_hdr(filename);
    case image_format::exr: return load_exr(filename);
    case image_format::unknown: throw_unknown_format(filename);
  }
  throw_unknown_format(filename);
}

// -----------------------------------------------------------------------------
// SAVING
// -----------------------------------------------------------------------------

// stb's write callback: append to a FILE*. Errors are caught by ferror().
static void stb_write_to_file(void* context, void* data, int size) {
  std::fwrite(data, 1, (size_t)size, (std::FILE*)context);
}

// OpenEXR output stream over a FILE*, so that OpenEXR writes into the
// temporary file we opened and its messages name the target file.
struct exr_file_stream : Imf::OStream {
  std::FILE* file = nullptr;
  exr_file_stream(std::FILE* file_, const char* filename)
      : Imf::OStream(filename), file(file_) {}
  void write(const char c[], int n) override {
    if (std::fwrite(c, 1, (size_t)n, file) != (size_t)n)
      throw std::runtime_error("write failed (" + errno_reason(errno) + ")");
  }
  uint64_t tellp() override { return (uint64_t)ftello(file); }
  void     seekp(uint64_t pos) override {
    if (fseeko(file, (off_t)pos, SEEK_SET) != 0)
      throw std::runtime_error("seek failed (" + errno_reason(errno) + ")");
  }
};

// Tonemap and quantise to 8-bit RGBA.
static std::vector<uint8_t> to_bytes(
    const image_data& image, float exposure, bool filmic) {
  auto bytes = std::vector<uint8_t>(image.pixels.size() * 4);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto ldr           = tonemap(image.pixels[idx], exposure, filmic, true);
    bytes[idx * 4 + 0] = float_to_byte(ldr.x);
    bytes[idx * 4 + 1] = float_to_byte(ldr.y);
    bytes[idx * 4 + 2] = float_to_byte(ldr.z);
    bytes[idx * 4 + 3] = float_to_byte(ldr.w);
  }
  return bytes;
}

// Write an 8-bit file through stb; returns false when stb fails to encode.
static bool write_ldr(std::FILE* file, const std::string& filename,
    const image_data& image, float exposure, bool filmic) {
  auto ext   = path_extension(filename);
  auto bytes = to_bytes(image, exposure, filmic);
  auto w = image.width, h = image.height;
  if (ext == ".png")
    return stbi_write_png_to_func(
        stb_write_to_file, file, w, h, 4, bytes.data(), w * 4);
  if (ext == ".tga")
    return stbi_write_tga_to_func(
        stb_write_to_file, file, w, h, 4, bytes.data());
  if (ext == ".bmp")
    return stbi_write_bmp_to_func(
        stb_write_to_file, file, w, h, 4, bytes.data());
  // JPEG has no alpha: drop it.
  auto rgb = std::vector<uint8_t>(image.pixels.size() * 3);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    for (auto c = 0; c < 3; c++) rgb[idx * 3 + c] = bytes[idx * 4 + c];
  }
  const auto jpeg_quality = 95;
  return stbi_write_jpg_to_func(
      stb_write_to_file, file, w, h, 3, rgb.data(), jpeg_quality);
}

// Write a Radiance HDR file through stb. RGBE holds only finite non-negative
// colours and no alpha, so other values are written as 0.
static bool write_hdr(std::FILE* file, const image_data& image) {
  auto rgb = std::vector<float>(image.pixels.size() * 3);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto& p = image.pixels[idx];
    for (auto c = 0; c < 3; c++) {
      auto value       = (&p.x)[c];
      rgb[idx * 3 + c] = std::isfinite(value) && value > 0 ? value : 0;
    }
  }
  return stbi_write_hdr_to_func(
      stb_write_to_file, file, image.width, image.height, 3, rgb.data());
}

// Write an OpenEXR file with 32-bit float R, G, B, A channels.
static void write_exr(
    std::FILE* file, const std::string& filename, const image_data& image) {
  auto stream = exr_file_stream{file, filename.c_str()};
  auto header = Imf::Header{image.width, image.height};
  for (auto name : {"R", "G", "B", "A"})
    header.channels().insert(name, Imf::Channel{Imf::FLOAT});
  auto base    = (char*)image.pixels.data();
  auto xstride = sizeof(vec4f), ystride = sizeof(vec4f) * (size_t)image.width;
  auto buffer = Imf::FrameBuffer{};
  buffer.insert("R", Imf::Slice{Imf::FLOAT, base + 0, xstride, ystride});
  buffer.insert("G", Imf::Slice{Imf::FLOAT, base + 4, xstride, ystride});
  buffer.insert("B", Imf::Slice{Imf::FLOAT, base + 8, xstride, ystride});
  buffer.insert("A", Imf::Slice{Imf::FLOAT, base + 12, xstride, ystride});
  // The destructor writes the line offset table: keep it inside this scope.
  auto output = Imf::OutputFile{stream, header};
  output.setFrameBuffer(buffer);
  output.writePixels(image.height);
}

// Save linear RGBA by extension, through a temporary file and a rename.
void save_image(const std::string& filename, const image_data& image,
    float exposure, bool filmic) {
  auto format = get_format(filename);
  if (format == image_format::unknown) throw_unknown_format(filename);
  if (image.width <= 0 || image.height <= 0)
    throw_io_error(filename, "cannot save an empty image (" +
                                 std::to_string(image.width) + "x" +
                                 std::to_string(image.height) + ")");
  if (image.pixels.size() != (size_t)image.width * (size_t)image.height)
    throw_io_error(
        filename, "image has " + std::to_string(image.pixels.size()) +
                      " pixels, expected " + std::to_string(image.width) + "x" +
                      std::to_string(image.height));

  auto temporary = temporary_path(filename);
  auto file      = file_ptr{std::fopen(temporary.c_str(), "wb")};
  if (!file)
    throw_io_error(filename, "cannot write (" + errno_reason(errno) + ")");
  // From here on every failure removes the temporary before throwing.
  auto fail = [&](const std::string& reason) {
    file.reset();
    std::remove(temporary.c_str());
    throw_io_error(filename, "cannot write (" + reason + ")");
  };
  errno = 0;
  try {
    auto encoded = true;
    switch (format) {
      case image_format::ldr:
        encoded = write_ldr(file.get(), filename, image, exposure, filmic);
        break;
      case image_format::hdr: encoded = write_hdr(file.get(), image); break;
      case image_format::exr: write_exr(file.get(), filename, image); break;
      case image_format::unknown: break;
    }
    if (!encoded) fail("the encoder failed");
  } catch (const io_error&) { throw; } catch (const std::exception& error) {
    fail(error.what());
  }
  if (std::ferror(file.get())) fail(errno_reason(errno));
  // fclose flushes the last buffer: a full disk shows up here.
  auto closed = std::fclose(file.release());
  if (closed != 0) {
    auto reason = errno_reason(errno);
    std::remove(temporary.c_str());
    throw_io_error(filename, "cannot write (" + reason + ")");
  }
  if (std::rename(temporary.c_str(), filename.c_str()) != 0) {
    auto reason = errno_reason(errno);
    std::remove(temporary.c_str());
    throw_io_error(filename, "cannot write (" + reason + ")");
  }
}

}  // namespace implicit
