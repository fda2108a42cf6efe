// Tests for image loading and saving: round trips per format, atomic writes
// and the errors for bad names and bad files.

#include "image_io.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "../util/error.h"

namespace implicit {

namespace fs = std::filesystem;

// A fresh empty directory for one test case, under the build directory.
static std::string make_test_dir(const std::string& name) {
  auto dir = fs::path(IMPLICIT_BINARY_DIR) / "image_io_test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

// The names of the entries of a directory, sorted.
static std::vector<std::string> list_dir(const std::string& dir) {
  auto names = std::vector<std::string>{};
  for (auto& entry : fs::directory_iterator(dir))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The message of the io_error thrown by f, or "" when it does not throw one.
template <typename Func>
static std::string error_of(Func&& f) {
  try {
    f();
  } catch (const io_error& error) { return error.what(); }
  return "";
}

// Whether text starts with prefix.
static bool starts_with(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

// A test image with smooth gradients in [0,1], varied alpha.
static image_data make_gradient(int width, int height) {
  auto image = make_image(width, height);
  for (auto j = 0; j < height; j++) {
    for (auto i = 0; i < width; i++) {
      auto u = (i + 0.5f) / width, v = (j + 0.5f) / height;
      pixel(image, i, j) = {u, v, u * v, 1 - 0.5f * u};
    }
  }
  return image;
}

// Exact comparison of all four channels.
static bool equal_pixels(vec4f a, vec4f b) {
  return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w;
}

// Write raw bytes to a file.
static void write_bytes(const std::string& filename, const std::string& bytes) {
  auto stream = std::ofstream(filename, std::ios::binary);
  stream.write(bytes.data(), (std::streamsize)bytes.size());
}

// Read a whole file as bytes.
static std::string read_bytes(const std::string& filename) {
  auto stream = std::ifstream(filename, std::ios::binary);
  return {std::istreambuf_iterator<char>(stream), {}};
}

TEST_CASE("image io png round trip") {
  auto dir      = make_test_dir("png");
  auto filename = dir + "/gradient.png";
  auto image    = make_gradient(13, 7);
  save_image(filename, image);
  CHECK(list_dir(dir) == std::vector<std::string>{"gradient.png"});
  auto loaded = load_image(filename);
  REQUIRE(loaded.width == 13);
  REQUIRE(loaded.height == 7);
  // Quantisation is int(s * 256) on save and b / 255 on load: within 1/255
  // in sRGB; alpha is stored linearly.
  auto max_error = 0.0;
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto a = image.pixels[idx], b = loaded.pixels[idx];
    for (auto c = 0; c < 3; c++) {
      auto error =
          std::abs(linear_to_srgb((&a.x)[c]) - linear_to_srgb((&b.x)[c]));
      max_error = std::max(max_error, (double)error);
    }
    max_error = std::max(max_error, (double)std::abs(a.w - b.w));
  }
  CHECK(max_error <= 1.0 / 255 + 1e-6);
  // Row 0 is the top: the first row has the smallest v.
  CHECK(pixel(loaded, 0, 0).y < pixel(loaded, 0, 6).y);
}

TEST_CASE("image io png applies exposure and filmic") {
  auto dir     = make_test_dir("png_tonemap");
  auto image   = make_image(2, 1);
  image.pixels = {{0.25f, 0.25f, 0.25f, 1}, {0.5f, 0.5f, 0.5f, 1}};
  save_image(dir + "/plain.png", image);
  save_image(dir + "/exposed.png", image, 1, false);
  save_image(dir + "/filmic.png", image, 0, true);
  auto plain   = load_image(dir + "/plain.png");
  auto exposed = load_image(dir + "/exposed.png");
  auto filmic  = load_image(dir + "/filmic.png");
  // One stop on 0.25 reads back as the plain 0.5.
  CHECK(exposed.pixels[0].x == plain.pixels[1].x);
  auto expected = linear_to_srgb(tonemap_filmic({0.25f, 0, 0}).x);
  CHECK(std::abs(linear_to_srgb(filmic.pixels[0].x) - expected) <= 1.0f / 255);
  CHECK(filmic.pixels[0].x != plain.pixels[0].x);
}

TEST_CASE("image io jpg round trip") {
  auto dir   = make_test_dir("jpg");
  auto image = make_gradient(32, 16);
  for (auto ext : {".jpg", ".jpeg"}) {
    auto filename = dir + "/gradient" + ext;
    save_image(filename, image);
    auto loaded = load_image(filename);
    REQUIRE(loaded.width == 32);
    REQUIRE(loaded.height == 16);
    // Lossy at quality 95: a few levels of error; JPEG drops alpha.
    auto max_error = 0.0f;
    for (size_t idx = 0; idx < image.pixels.size(); idx++) {
      auto a = image.pixels[idx], b = loaded.pixels[idx];
      for (auto c = 0; c < 3; c++)
        max_error = std::max(max_error,
            std::abs(linear_to_srgb((&a.x)[c]) - linear_to_srgb((&b.x)[c])));
      CHECK(b.w == 1);
    }
    CHECK(max_error < 0.03f);
  }
  CHECK(list_dir(dir) ==
        std::vector<std::string>{"gradient.jpeg", "gradient.jpg"});
}

TEST_CASE("image io tga and bmp round trip") {
  auto dir   = make_test_dir("tga_bmp");
  auto image = make_gradient(9, 4);
  for (auto ext : {".tga", ".bmp", ".PNG"}) {
    auto filename = dir + "/gradient" + ext;
    save_image(filename, image);
    auto loaded = load_image(filename);
    REQUIRE(loaded.width == 9);
    REQUIRE(loaded.height == 4);
    for (size_t idx = 0; idx < image.pixels.size(); idx++) {
      auto a = image.pixels[idx], b = loaded.pixels[idx];
      CHECK(std::abs(linear_to_srgb(a.x) - linear_to_srgb(b.x)) <=
            1.0f / 255 + 1e-6f);
      CHECK(std::abs(linear_to_srgb(a.z) - linear_to_srgb(b.z)) <=
            1.0f / 255 + 1e-6f);
    }
  }
}

TEST_CASE("image io hdr: every RGBE exponent decodes to mantissa * 2^(e-136)") {
  // One flat (not run-length) scanline of 256 texels: texel e has exponent
  // e and mantissas 255, 128, 1, so that the largest and smallest powers
  // (subnormal floats below e = 10) are all read.
  auto dir = make_test_dir("hdr_exponents");
  auto bytes =
      std::string{"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 256\n"};
  for (auto e = 0; e < 256; e++)
    bytes += std::string{(char)255, (char)128, (char)1, (char)e};
  auto filename = dir + "/exponents.hdr";
  std::ofstream(filename, std::ios::binary) << bytes;
  auto image = load_image(filename);
  REQUIRE(image.width == 256);
  CHECK(xyz(image.pixels[0]) == vec3f{0, 0, 0});  // exponent 0 is black
  for (auto e = 1; e < 256; e++) {
    auto& texel = image.pixels[e];
    CHECK(texel.x == std::ldexp(255.0f, e - 136));
    CHECK(texel.y == std::ldexp(128.0f, e - 136));
    CHECK(texel.z == std::ldexp(1.0f, e - 136));
    CHECK(texel.w == 1);
  }
}

TEST_CASE("image io hdr round trip") {
  auto dir      = make_test_dir("hdr");
  auto filename = dir + "/values.hdr";
  auto image    = make_image(16, 3);
  for (auto idx = 0; idx < 48; idx++) {
    auto value        = std::pow(10.0f, -3 + idx * 5.0f / 47);  // 1e-3 .. 1e2
    image.pixels[idx] = {value, value * 0.5f, value * 0.25f, 0.5f};
  }
  save_image(filename, image);
  auto loaded = load_image(filename);
  REQUIRE(loaded.width == 16);
  REQUIRE(loaded.height == 3);
  // RGBE: an 8-bit mantissa per channel with the exponent of the largest.
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto a = image.pixels[idx], b = loaded.pixels[idx];
    auto scale = std::max(a.x, std::max(a.y, a.z));
    CHECK(std::abs(a.x - b.x) <= 0.01f * scale);
    CHECK(std::abs(a.y - b.y) <= 0.01f * scale);
    CHECK(std::abs(a.z - b.z) <= 0.01f * scale);
    CHECK(b.w == 1);  // RGBE has no alpha
  }
}

TEST_CASE("image io exr round trip is exact") {
  auto dir      = make_test_dir("exr");
  auto filename = dir + "/values.exr";
  auto image    = make_image(5, 4);
  for (auto idx = 0; idx < 20; idx++) {
    // Values no 16-bit half could hold: negative, tiny, huge, odd mantissas.
    auto value        = (idx - 7) * 1234.5678f + 1e-20f * idx;
    image.pixels[idx] = {value, 1 / (idx + 3.0f), 1e30f, idx * 0.1f};
  }
  save_image(filename, image);
  CHECK(list_dir(dir) == std::vector<std::string>{"values.exr"});
  auto loaded = load_image(filename);
  REQUIRE(loaded.width == 5);
  REQUIRE(loaded.height == 4);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto a = image.pixels[idx], b = loaded.pixels[idx];
    CHECK(a.x == b.x);
    CHECK(a.y == b.y);
    CHECK(a.z == b.z);
    CHECK(a.w == b.w);
  }
}

// Rename channels in an EXR header written by save_image: each name is
// followed by its pixel type (FLOAT = 2), so "R\0\2\0\0\0" is channel R.
static std::string rename_exr_channels(
    std::string bytes, const std::string& from, const std::string& to) {
  auto list = bytes.find(std::string("chlist\0", 7));
  REQUIRE(list != std::string::npos);
  for (size_t c = 0; c < from.size(); c++) {
    auto entry = std::string{from[c], '\0', '\2', '\0', '\0', '\0'};
    auto at    = bytes.find(entry, list);
    REQUIRE(at != std::string::npos);
    bytes[at] = to[c];
  }
  return bytes;
}

TEST_CASE("image io exr channels") {
  auto dir     = make_test_dir("exr_channels");
  auto image   = make_image(2, 1);
  image.pixels = {{0.5f, 0.25f, 0.125f, 0.75f}, {2, 3, 4, 5}};
  save_image(dir + "/rgba.exr", image);
  auto bytes = read_bytes(dir + "/rgba.exr");
  // A vector (A, X, Y, Z: the old B, G and R), as the normal and position
  // AOVs: X, Y and Z read as R, G and B.
  write_bytes(dir + "/vector.exr", rename_exr_channels(bytes, "BGR", "XYZ"));
  auto vector = load_image(dir + "/vector.exr");
  REQUIRE(vector.pixels.size() == 2);
  CHECK(equal_pixels(vector.pixels[0], {0.125f, 0.25f, 0.5f, 0.75f}));
  CHECK(equal_pixels(vector.pixels[1], {4, 3, 2, 5}));
  // Luminance only (A, S, T, Y: the old R is now Y), or depth only (Z):
  // grey from it.
  for (auto name : {"Y", "Z"}) {
    auto path = dir + "/grey" + name + ".exr";
    write_bytes(
        path, rename_exr_channels(bytes, "BGR", std::string("ST") + name));
    auto grey = load_image(path);
    REQUIRE(grey.pixels.size() == 2);
    CHECK(equal_pixels(grey.pixels[0], {0.5f, 0.5f, 0.5f, 0.75f}));
    CHECK(equal_pixels(grey.pixels[1], {2, 2, 2, 5}));
  }
  // R missing but G and B there: the colour file reads R as 0, not grey.
  write_bytes(dir + "/no_red.exr", rename_exr_channels(bytes, "R", "Y"));
  auto no_red = load_image(dir + "/no_red.exr");
  CHECK(equal_pixels(no_red.pixels[0], {0, 0.25f, 0.125f, 0.75f}));
  // No alpha (A renamed to a channel we do not read): alpha is 1.
  write_bytes(dir + "/rgb.exr", rename_exr_channels(bytes, "A", "0"));
  auto rgb = load_image(dir + "/rgb.exr");
  CHECK(equal_pixels(rgb.pixels[0], {0.5f, 0.25f, 0.125f, 1}));
  // No colour at all is an error, not a black image.
  auto none = dir + "/none.exr";
  write_bytes(none, rename_exr_channels(bytes, "BGR", "STU"));
  CHECK(error_of([&] { load_image(none); }) ==
        none + ": no R, G, B, X, Y or Z channel (found: A, S, T, U)");
}

TEST_CASE("image io save replaces an existing file") {
  auto dir      = make_test_dir("replace");
  auto filename = dir + "/out.exr";
  auto first    = make_image(2, 2);
  auto second   = make_image(3, 1);
  second.pixels = {{1, 2, 3, 4}, {5, 6, 7, 8}, {9, 10, 11, 12}};
  save_image(filename, first);
  save_image(filename, second);
  auto loaded = load_image(filename);
  CHECK(loaded.width == 3);
  CHECK(loaded.pixels[2].z == 11);
  CHECK(list_dir(dir) == std::vector<std::string>{"out.exr"});
}

TEST_CASE("image io failed save leaves no file") {
  auto dir   = make_test_dir("failed_save");
  auto image = make_gradient(4, 4);
  // The directory does not exist: the error names the target, not the
  // temporary, and nothing is created.
  auto missing = dir + "/missing/out.png";
  CHECK(error_of([&] { save_image(missing, image); }) ==
        missing + ": cannot write (No such file or directory)");
  CHECK(list_dir(dir).empty());
  // The rename fails (the target is a directory): the temporary written so
  // far is removed and the directory is untouched.
  for (auto name : {"dir.png", "dir.exr", "dir.hdr", "dir.jpg"}) {
    fs::create_directory(dir + "/" + name);
    auto message = error_of([&] { save_image(dir + "/" + name, image); });
    CHECK(starts_with(message, dir + "/" + name + ": cannot write ("));
    CHECK(message.find(".tmp") == std::string::npos);
  }
  CHECK(list_dir(dir) ==
        std::vector<std::string>{"dir.exr", "dir.hdr", "dir.jpg", "dir.png"});
  // A failed save keeps the previous file as it was.
  auto kept = dir + "/kept.png";
  save_image(kept, image);
  auto before = read_bytes(kept);
  CHECK_THROWS_AS(save_image(kept, image_data{}), io_error);
  CHECK(read_bytes(kept) == before);
}

TEST_CASE("image io bad names and empty images") {
  auto dir   = make_test_dir("bad_names");
  auto image = make_gradient(2, 2);
  CHECK(error_of([&] { save_image(dir + "/x.foo", image); }) ==
        dir + "/x.foo: unknown image format (use .png, .jpg, .hdr or .exr)");
  CHECK(error_of([&] { save_image(dir + "/noext", image); }) ==
        dir + "/noext: unknown image format (use .png, .jpg, .hdr or .exr)");
  write_bytes(dir + "/y.foo", "data");
  CHECK(error_of([&] { load_image(dir + "/y.foo"); }) ==
        dir + "/y.foo: unknown image format (use .png, .jpg, .hdr or .exr)");
  CHECK(error_of([&] { save_image(dir + "/empty.png", make_image(0, 3)); }) ==
        dir + "/empty.png: cannot save an empty image (0x3)");
  auto short_image = make_image(2, 2);
  short_image.pixels.pop_back();
  CHECK(error_of([&] { save_image(dir + "/short.exr", short_image); }) ==
        dir + "/short.exr: image has 3 pixels, expected 2x2");
  CHECK(list_dir(dir) == std::vector<std::string>{"y.foo"});
  CHECK(is_hdr_filename("a/b.exr"));
  CHECK(is_hdr_filename("b.HDR"));
  CHECK_FALSE(is_hdr_filename("b.png"));
  CHECK_FALSE(is_hdr_filename("dir.exr/b"));
}

TEST_CASE("image io load errors name the file") {
  auto dir = make_test_dir("load_errors");
  for (auto ext : {".png", ".hdr", ".exr"}) {
    auto missing = dir + "/missing" + ext;
    CHECK(error_of([&] { load_image(missing); }) ==
          missing + ": cannot open (No such file or directory)");
    auto empty = dir + "/empty" + ext;
    write_bytes(empty, "");
    CHECK(error_of([&] { load_image(empty); }) == empty + ": file is empty");
    auto directory = dir + "/directory" + ext;
    fs::create_directory(directory);
    CHECK(error_of([&] { load_image(directory); }) ==
          directory + ": cannot open (Is a directory)");
    auto garbage = dir + "/garbage" + ext;
    write_bytes(garbage, std::string(100, 'x'));
    CHECK(starts_with(error_of([&] { load_image(garbage); }),
        garbage + ": cannot read image ("));
  }
  // Truncated files: a valid PNG/EXR cut in half.
  auto image = make_gradient(32, 32);
  for (auto ext : {".png", ".exr"}) {
    auto whole = dir + "/whole" + ext;
    save_image(whole, image);
    auto bytes     = read_bytes(whole);
    auto truncated = dir + "/truncated" + ext;
    write_bytes(truncated, bytes.substr(0, bytes.size() / 2));
    CHECK(starts_with(error_of([&] { load_image(truncated); }),
        truncated + ": cannot read image ("));
  }
  // An 8-bit file under an HDR name is refused rather than gamma-guessed.
  auto misnamed = dir + "/misnamed.hdr";
  fs::copy_file(dir + "/whole.png", misnamed);
  CHECK(error_of([&] { load_image(misnamed); }) ==
        misnamed + ": cannot read image (not a Radiance HDR file)");
}

// A file of tests/data: the fuzz findings of issue 12, kept as inputs.
static std::string data_path(const std::string& name) {
  return std::string{IMPLICIT_SOURCE_DIR} + "/tests/data/" + name;
}

TEST_CASE("image io refuses the fuzz findings, naming the file") {
  struct finding {
    std::string name  = "";
    std::string error = "";
  };
  for (auto& [name, expected] : std::vector<finding>{
           // stb decoded this as a 16-bit PGM and load_ldr read past its
           // 8-bit buffer.
           {"pgm16_named_png.png",
               "cannot read image (not a PNG, JPEG, BMP or TGA file)"},
           // stb's HDR decoder looped for ever on both.
           {"hdr_rle_zero_run.hdr",
               "cannot read image (scanline 0: bad run length"},
           {"hdr_ends_mid_scanline.hdr",
               "cannot read image (scanline 0: file ends"},
           // 10.5 GB before failing: refused from the header now.
           {"tga_huge_header.tga",
               "image is 23170x23170 pixels, over the limit of 67108864"},
           // stb wrote a byte past its Huffman table; libjpeg refuses it.
           {"jpeg_bad_huffman_table.jpg", "cannot read image ("},
           // OpenEXR allocated 1.7 GB for an attribute of this 225-byte
           // file (after a channel list shorter than its size field).
           {"exr_huge_attribute_after_chlist.exr",
               "cannot read image (byte 81: attribute "}}) {
    auto filename = data_path(name);
    CAPTURE(filename);
    auto error = error_of([&] { load_image(filename); });
    CAPTURE(error);
    CHECK(starts_with(error, filename + ": " + expected));
  }
}

TEST_CASE("image io checks the size in the header before decoding") {
  auto dir    = make_test_dir("size_limits");
  auto header = [](const std::string& resolution) {
    return "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + resolution + "\n";
  };
  struct sized {
    std::string resolution = "";
    std::string error      = "";
  };
  for (auto& [resolution, expected] :
      std::vector<sized>{
          {"-Y 1 +X 40000", "image is 40000x1 pixels, over the limit of 32768"},
          {"-Y 30000 +X 30000", "over the limit of 67108864 pixels"},
          {"-Y 8000 +X 8000", "more than a file of 51 bytes can hold"},
          {"-Y 0 +X 8", "image is empty (8x0)"},
          {"+Y 8 +X 8", "unsupported resolution line"}}) {
    auto filename = dir + "/size.hdr";
    write_bytes(filename, header(resolution));
    auto error = error_of([&] { load_image(filename); });
    CAPTURE(error);
    CHECK(error.find(filename + ": ") == 0);
    CHECK(error.find(expected) != std::string::npos);
  }
  // An EXR whose data window claims 100000 pixels a side.
  auto exr = dir + "/wide.exr";
  save_image(exr, make_gradient(2, 2));
  auto bytes = read_bytes(exr);
  auto where = bytes.find(std::string("dataWindow\0box2i\0", 17));
  REQUIRE(where != std::string::npos);
  auto max_x = int32_t{99999};
  bytes.replace(where + 17 + 4 + 8, 4, (const char*)&max_x, 4);
  write_bytes(exr, bytes);
  CHECK(starts_with(error_of([&] { load_image(exr); }), exr + ": "));
  // An attribute claiming 1.7 GB: OpenEXR would allocate it before reading.
  save_image(exr, make_gradient(2, 2));
  bytes = read_bytes(exr);
  where = bytes.find(std::string("dataWindow\0box2i\0", 17));
  bytes.replace(where + 11, 5, "boxXi");
  auto huge = int32_t{1768947712};
  bytes.replace(where + 17, 4, (const char*)&huge, 4);
  write_bytes(exr, bytes);
  CHECK(error_of([&] {
    load_image(exr);
  }).find("attribute dataWindow (1768947712 bytes) runs past the end") !=
        std::string::npos);
}

TEST_CASE("image io decodes from memory like from a file") {
  auto dir = make_test_dir("memory");
  for (auto ext : {".png", ".jpg", ".hdr", ".exr", ".tga", ".bmp"}) {
    auto filename = dir + "/gradient" + ext;
    save_image(filename, make_gradient(7, 5));
    auto bytes  = read_bytes(filename);
    auto loaded = load_image_from_memory(filename, bytes.data(), bytes.size());
    auto again  = load_image(filename);
    REQUIRE(loaded.width == 7);
    REQUIRE(loaded.height == 5);
    CHECK(loaded.pixels.size() == again.pixels.size());
    for (size_t idx = 0; idx < loaded.pixels.size(); idx++)
      CHECK(equal_pixels(loaded.pixels[idx], again.pixels[idx]));
  }
  // A PNG named .jpg is read by its content, as before.
  auto png   = dir + "/gradient.png";
  auto bytes = read_bytes(png);
  CHECK(load_image_from_memory("misnamed.jpg", bytes.data(), bytes.size())
            .width == 7);
  CHECK(error_of([&] { load_image_from_memory("x.png", bytes.data(), 0); }) ==
        "x.png: file is empty");
}

TEST_CASE("image io rejects every truncation of each format cleanly") {
  auto dir = make_test_dir("truncations");
  for (auto ext : {".png", ".jpg", ".hdr", ".exr", ".tga", ".bmp"}) {
    auto filename = dir + "/gradient" + ext;
    save_image(filename, make_gradient(9, 9));
    auto bytes = read_bytes(filename);
    // Cut at every byte: an image or an io_error, never a crash or a hang
    // (libjpeg pads a truncated JPEG with grey, so that one loads).
    for (size_t size = 1; size < bytes.size(); size++) {
      CAPTURE(size);
      try {
        load_image_from_memory(filename, bytes.data(), size);
      } catch (const io_error& error) {
        CHECK(starts_with(error.what(), filename + ": "));
      }
    }
  }
}

}  // namespace implicit
