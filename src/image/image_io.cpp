// # implicit: image files
//
// Loading reads the whole file and decodes it from memory: PNG through
// libpng, JPEG through libjpeg-turbo, Radiance HDR with our own decoder
// (image_decode.cpp says why), BMP and TGA through stb, OpenEXR through the
// OpenEXR library. Every decoder checks the size in the header against the
// limits of image_io.h before it allocates the pixels. Saving goes through
// libpng (its fast mode: stb's encoder took 50 ms of every 720 px render's
// serial tail), stb and OpenEXR, always as 32-bit float channels for OpenEXR
// so that round trips are exact.
// Every writer streams into a temporary file next to the target that is then
// renamed over it: a reader never sees a half-written image, and a failed
// save leaves the previous file (if any) untouched.

#include "image_io.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#include <unistd.h>

#include <Iex.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <png.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>

#include "../util/error.h"
#include "../util/file.h"
#include "image_decode.h"

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

// Whether the bytes start with `magic`.
static bool starts_with(const uint8_t* data, size_t size, const char* magic) {
  auto length = std::strlen(magic);
  return size >= length && std::memcmp(data, magic, length) == 0;
}

// Load a BMP or TGA through stb, 8-bit, sRGB colour (not alpha). The size
// from the header is checked before stb allocates.
static image_data load_stb(
    const std::string& filename, const uint8_t* data, size_t size) {
  // stb probes every format it knows before TGA (which has no signature):
  // refuse those it would decode instead, among them 16-bit PNM, whose
  // buffer stb hands back 8-bit and we would read past.
  for (auto magic : {"GIF8", "8BPS", "\x53\x80\xF6\x34", "P1", "P2", "P3", "P4",
           "P5", "P6", "#?"}) {
    if (starts_with(data, size, magic))
      throw_io_error(
          filename, "cannot read image (unsupported format for this name)");
  }
  if (size > INT32_MAX)
    throw_io_error(filename, "cannot read image (file over 2 GiB)");
  auto width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(data, (int)size, &width, &height, &channels))
    throw_io_error(filename, "cannot read image (" + stb_reason() + ")");
  auto error = check_image_size(width, height, size, stb_pixels_per_byte);
  if (!error.empty()) throw_io_error(filename, error);
  auto pixels = std::unique_ptr<stbi_uc, stb_freer>{
      stbi_load_from_memory(data, (int)size, &width, &height, &channels, 4)};
  if (!pixels)
    throw_io_error(filename, "cannot read image (" + stb_reason() + ")");
  error = check_image_size(width, height, size, stb_pixels_per_byte);
  if (!error.empty()) throw_io_error(filename, error);
  auto image = make_image(width, height);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto px           = pixels.get() + idx * 4;
    image.pixels[idx] = {srgb_to_linear(byte_to_float(px[0])),
        srgb_to_linear(byte_to_float(px[1])),
        srgb_to_linear(byte_to_float(px[2])), byte_to_float(px[3])};
  }
  return image;
}

// Load an 8- or 16-bit file, by its content: PNG (libpng), JPEG
// (libjpeg-turbo), BMP (stb), and TGA (stb; it has no signature, so only
// under a .tga name).
static image_data load_ldr(
    const std::string& filename, const uint8_t* data, size_t size) {
  if (is_png_data(data, size)) return decode_png(filename, data, size);
  if (is_jpeg_data(data, size)) return decode_jpeg(filename, data, size);
  if (starts_with(data, size, "BM") || path_extension(filename) == ".tga")
    return load_stb(filename, data, size);
  throw_io_error(
      filename, "cannot read image (not a PNG, JPEG, BMP or TGA file)");
}

// OpenEXR input stream over bytes in memory.
struct exr_memory_stream : Imf::IStream {
  const char* data     = nullptr;
  uint64_t    size     = 0;
  uint64_t    position = 0;
  exr_memory_stream(const char* data_, size_t size_, const char* filename)
      : Imf::IStream(filename), data(data_), size(size_) {}
  bool read(char c[], int n) override {
    if (n < 0 || position > size || (uint64_t)n > size - position)
      throw Iex::InputExc("unexpected end of file");
    std::memcpy(c, data + position, (size_t)n);
    position += (uint64_t)n;
    return position < size;
  }
  uint64_t tellg() override { return position; }
  void     seekg(uint64_t pos) override { position = pos; }
};

// Bytes of an OpenEXR attribute value of a fixed-size type: OpenEXR reads
// these by their type, whatever the size field says; -1 for other types.
static int64_t exr_attribute_size(const std::string& type) {
  static const std::pair<const char*, int64_t> sizes[] = {{"box2i", 16},
      {"box2f", 16}, {"compression", 1}, {"envmap", 1}, {"lineOrder", 1},
      {"deepImageState", 1}, {"int", 4}, {"float", 4}, {"double", 8},
      {"v2i", 8}, {"v2f", 8}, {"v2d", 16}, {"v3i", 12}, {"v3f", 12},
      {"v3d", 24}, {"m33f", 36}, {"m33d", 72}, {"m44f", 64}, {"m44d", 128},
      {"rational", 8}, {"timecode", 8}, {"keycode", 28}, {"chromaticities", 32},
      {"tiledesc", 9}};
  for (auto& [name, size] : sizes) {
    if (type == name) return size;
  }
  return -1;
}

// Check an OpenEXR header the way OpenEXR reads it, before it does: it
// allocates an unknown attribute's size, a string vector's string sizes and
// a preview's width x height as the file states them (1.7 GB for a 225-byte
// file in fuzzing). The layout: magic, version and flags, then per part a
// list of (name, type, int32 size, value) ended by an empty name;
// multi-part files end the list of parts with one more empty name.
static void check_exr_header(
    const std::string& filename, const uint8_t* data, size_t size) {
  auto offset = size_t{0};
  auto fail   = [&](const std::string& problem) {
    throw_io_error(filename, "cannot read image (byte " +
                                   std::to_string(offset) + ": " + problem + ")");
  };
  auto need = [&](uint64_t bytes, const std::string& what) {
    if (bytes > size - offset)
      fail(what + " (" + std::to_string(bytes) +
           " bytes) runs past the end of the file");
  };
  auto read_i32 = [&](const std::string& what) {
    need(4, what);
    auto value = int32_t{0};
    std::memcpy(&value, data + offset, 4);
    offset += 4;
    return value;
  };
  // A NUL-terminated name of at most 255 characters (long names).
  auto read_name = [&](const std::string& what) {
    auto end = (const uint8_t*)std::memchr(
        data + offset, 0, std::min(size - offset, size_t{256}));
    if (end == nullptr) fail(what + " has no end");
    auto name = std::string((const char*)data + offset, (const char*)end);
    offset += name.size() + 1;
    return name;
  };
  if (size < 8 || data[0] != 0x76 || data[1] != 0x2f || data[2] != 0x31 ||
      data[3] != 0x01)
    fail("not an OpenEXR file");
  auto multipart = (data[5] & 0x10) != 0;  // bit 12 of the version field
  offset         = 8;
  for (auto part = 0;; part++) {
    need(1, "the header");
    if (multipart && part > 0 && data[offset] == 0) break;
    while (true) {
      auto name = read_name("attribute name");
      if (name.empty()) break;
      auto type   = read_name("attribute type");
      auto length = read_i32("attribute size");
      if (length < 0) fail("attribute size " + std::to_string(length));
      auto value = offset;
      if (type == "chlist") {
        // Channels up to an empty name, whatever the size says.
        while (!read_name("channel name").empty()) {
          need(16, "channel");
          offset += 16;
        }
      } else if (type == "preview") {
        auto width  = (uint32_t)read_i32("preview width");
        auto height = (uint32_t)read_i32("preview height");
        need((uint64_t)width * height * 4, "preview pixels");
        offset += (size_t)width * height * 4;
      } else if (exr_attribute_size(type) >= 0) {
        need((uint64_t)exr_attribute_size(type), "attribute " + name);
        offset += (size_t)exr_attribute_size(type);
      } else {
        need((uint64_t)length, "attribute " + name);
        // A string vector holds (int32 size, bytes) pairs within it.
        while (type == "stringvector" && offset < value + (size_t)length) {
          auto string = read_i32("string size");
          if (string < 0) fail("string size " + std::to_string(string));
          need((uint64_t)string, "string");
          offset += (size_t)string;
        }
        offset = value + (size_t)length;
      }
    }
    if (!multipart) break;
  }
}

// OpenEXR's own header checks: it refuses larger images before allocating
// its line buffers and offset tables. Set once per process.
static void init_openexr() {
  static std::once_flag once;
  std::call_once(once, [] {
    Imf::Header::setMaxImageSize(max_image_size, max_image_size);
    Imf::Header::setMaxTileSize(max_image_size, max_image_size);
  });
}

// Load an OpenEXR file as float RGBA. Missing colour channels read as 0 and
// a missing alpha as 1. Without R, G and B: X, Y and Z (a vector, as the
// normal and position AOVs this renderer writes) read as R, G and B; Y
// alone (luminance) or Z alone (a depth AOV) as grey.
static image_data load_exr(
    const std::string& filename, const uint8_t* data, size_t size) {
  init_openexr();
  check_exr_header(filename, data, size);
  try {
    auto stream = exr_memory_stream{(const char*)data, size, filename.c_str()};
    auto file   = Imf::InputFile(stream);
    auto window = file.header().dataWindow();
    auto error  = check_image_size((int64_t)window.max.x - window.min.x + 1,
         (int64_t)window.max.y - window.min.y + 1, size, exr_pixels_per_byte);
    if (!error.empty()) throw_io_error(filename, error);
    auto  width    = window.max.x - window.min.x + 1;
    auto  height   = window.max.y - window.min.y + 1;
    auto  image    = make_image(width, height);
    auto& channels = file.header().channels();
    auto  has      = [&](const char* name) {
      return channels.findChannel(name) != nullptr;
    };
    auto names = std::vector<const char*>{};
    if (has("R") || has("G") || has("B")) {
      names = {"R", "G", "B"};
    } else if (has("X")) {
      names = {"X", "Y", "Z"};
    } else if (has("Y") || has("Z")) {
      names = {has("Y") ? "Y" : "Z"};
    } else {
      // Without any of them the image would silently read as black.
      auto found = std::string{};
      for (auto it = channels.begin(); it != channels.end(); ++it)
        found += (found.empty() ? "" : ", ") + std::string(it.name());
      throw_io_error(
          filename, "no R, G, B, X, Y or Z channel (found: " + found + ")");
    }
    auto grey = names.size() == 1;
    // The slices read straight into the interleaved vec4f pixels; OpenEXR
    // converts half/uint channels to float and fills absent ones.
    auto base    = (char*)image.pixels.data();
    auto xstride = sizeof(vec4f), ystride = sizeof(vec4f) * (size_t)width;
    auto buffer = Imf::FrameBuffer{};
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
  } catch (const io_error&) { throw; } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& error) {
    // OpenEXR throws Iex exceptions.
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
  if (get_format(filename) == image_format::unknown)
    throw_unknown_format(filename);
  auto file = mapped_file{filename};
  return load_image_from_memory(filename, file.data, file.size);
}

// Load an image from the bytes of a file (the name picks the decoder).
image_data load_image_from_memory(
    const std::string& filename, const void* data, size_t size) {
  auto bytes = (const uint8_t*)data;
  if (size == 0) throw_io_error(filename, "file is empty");
  try {
    switch (get_format(filename)) {
      case image_format::ldr: return load_ldr(filename, bytes, size);
      case image_format::hdr: return decode_hdr(filename, bytes, size);
      case image_format::exr: return load_exr(filename, bytes, size);
      case image_format::unknown: throw_unknown_format(filename);
    }
  } catch (const std::bad_alloc&) {
    // Within the size limits, but more than this machine has.
    throw_io_error(filename, "out of memory decoding the image");
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
  if (ext == ".png") {
    // libpng's simplified writer: no setjmp, and the fast flag picks the
    // filter and compression effort of an interactive tool.
    auto png    = png_image{};
    png.version = PNG_IMAGE_VERSION;
    png.width   = (png_uint_32)w;
    png.height  = (png_uint_32)h;
    png.format  = PNG_FORMAT_RGBA;
    png.flags   = PNG_IMAGE_FLAG_FAST;
    auto ok     = png_image_write_to_stdio(
                      &png, file, 0, bytes.data(), w * 4, nullptr) != 0;
    png_image_free(&png);
    return ok;
  }
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

// Write an OpenEXR file with 32-bit float channels: R, G, B, A of `image`
// (unless null) and each layer's as "name.channel" (or "channel" with
// `prefixed` false). OpenEXR sorts the channels by name in the file.
static void write_exr(std::FILE* file, const std::string& filename,
    const image_data* image, int width, int height,
    const std::vector<image_layer>& layers, bool prefixed) {
  auto stream = exr_file_stream{file, filename.c_str()};
  auto header = Imf::Header{width, height};
  auto buffer = Imf::FrameBuffer{};
  auto insert = [&](const std::string& name, const float* base, size_t step) {
    header.channels().insert(name, Imf::Channel{Imf::FLOAT});
    auto xstride = sizeof(float) * step, ystride = xstride * (size_t)width;
    buffer.insert(name, Imf::Slice{Imf::FLOAT, (char*)base, xstride, ystride});
  };
  if (image) {
    auto base = &image->pixels.data()->x;
    for (auto c = 0; c < 4; c++) insert(std::string(1, "RGBA"[c]), base + c, 4);
  }
  for (auto& layer : layers) {
    auto step = layer.channels.size();
    for (size_t c = 0; c < step; c++)
      insert((prefixed ? layer.name + "." : "") + layer.channels[c],
          layer.values.data() + c, step);
  }
  // The destructor writes the line offset table: keep it inside this scope.
  auto output = Imf::OutputFile{stream, header};
  output.setFrameBuffer(buffer);
  output.writePixels(height);
}

std::string layer_filename(
    const std::string& filename, const std::string& layer) {
  auto ext = path_extension(filename);
  return filename.substr(0, filename.size() - ext.size()) + "." + layer +
         ".exr";
}

// Refuse a layer that does not fit the image.
static void check_layer(const std::string& filename, const image_data& image,
    const image_layer& layer) {
  if (layer.name.empty() || layer.channels.empty() ||
      layer.values.size() != image.pixels.size() * layer.channels.size())
    throw_io_error(filename, "layer \"" + layer.name +
                                 "\" does not match the " +
                                 std::to_string(image.width) + "x" +
                                 std::to_string(image.height) + " image");
}

// Write one file through the file layer: a temporary, renamed once
// complete; any error removes it.
template <typename Write>
static void write_image_file(const std::string& filename, const Write& write) {
  auto out  = output_file{filename};
  errno     = 0;
  auto fail = [&](const std::string& reason) {
    throw_io_error(filename, "cannot write (" + reason + ")");
  };
  try {
    if (!write(out.file)) fail("the encoder failed");
  } catch (const io_error&) { throw; } catch (const std::exception& error) {
    fail(error.what());
  }
  if (std::ferror(out.file)) fail(errno_reason(errno));
  commit_file(out);
}

// Save linear RGBA by extension, through a temporary file and a rename.
void save_image(const std::string& filename, const image_data& image,
    float exposure, bool filmic, const std::vector<image_layer>& layers) {
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

  for (auto& layer : layers) check_layer(filename, image, layer);
  auto w = image.width, h = image.height;
  write_image_file(filename, [&](std::FILE* file) {
    switch (format) {
      case image_format::ldr:
        return write_ldr(file, filename, image, exposure, filmic);
      case image_format::hdr: return write_hdr(file, image);
      case image_format::exr:
        write_exr(file, filename, &image, w, h, layers, true);
        return true;
      case image_format::unknown: return false;
    }
    return false;
  });
  if (format == image_format::exr) return;
  for (auto& layer : layers) {
    auto name = layer_filename(filename, layer.name);
    write_image_file(name, [&](std::FILE* file) {
      write_exr(file, name, nullptr, w, h, {layer}, false);
      return true;
    });
  }
}

}  // namespace implicit
