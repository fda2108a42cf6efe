// Tests of the grid loaders and savers, good and bad files.

#include "sdf_grid_io.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../../tests/shared_data.h"
#include "../util/error.h"

using namespace implicit;

// OpenVDB 10 leaks a node when a truncated file makes its topology read
// throw (tree/RootNode.h readTopology: `new ChildT` before the child's read,
// no owner). The loader still reports the error; this keeps the sanitizer
// build's leak check about our code. LeakSanitizer calls this hook.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:openvdb::v10_0::tree::RootNode*::readTopology\n";
}

namespace {

// Scratch file path for this test binary.
std::string temp_path(const std::string& name) {
  auto dir = std::string(IMPLICIT_BINARY_DIR) + "/grid_io_test";
  std::filesystem::create_directories(dir);
  return dir + "/" + name;
}

std::string shared_path(const std::string& name) {
  return std::string(IMPLICIT_SHARED_DIR) + "/sdf_samples/" + name;
}

void write_file(const std::string& filename, const std::string& bytes) {
  auto out = std::ofstream(filename, std::ios::binary);
  out.write(bytes.data(), (std::streamsize)bytes.size());
}

std::string read_file(const std::string& filename) {
  auto in = std::ifstream(filename, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Append raw little-endian values.
template <typename T>
void append(std::string& bytes, T value) {
  char buffer[sizeof(T)];
  std::memcpy(buffer, &value, sizeof(T));
  bytes.append(buffer, sizeof(T));
}

// An asymmetric field: each sample's value encodes its (i,j,k).
constexpr int nx = 7, ny = 11, nz = 13;
float         field(int i, int j, int k) {
          return (float)(i + 10 * j + 200 * k) - 900.5f;
}

// Check the loaded grid is the field above.
void check_field(const grid_data& grid) {
  REQUIRE(grid.dims == vec3i{nx, ny, nz});
  REQUIRE(has_grid_accel(grid));
  auto wrong = 0;
  for (auto k = 0; k < nz; k++)
    for (auto j = 0; j < ny; j++)
      for (auto i = 0; i < nx; i++)
        wrong += grid_value(grid, i, j, k) != field(i, j, k);
  CHECK(wrong == 0);
}

// Values of the field, x fastest.
std::vector<float> field_values() {
  auto values = std::vector<float>{};
  for (auto k = 0; k < nz; k++)
    for (auto j = 0; j < ny; j++)
      for (auto i = 0; i < nx; i++) values.push_back(field(i, j, k));
  return values;
}

// skanti header with a given matrix (16 floats, as stored).
std::string skanti_header(vec3i dims, float res, const std::vector<float>& m) {
  auto bytes = std::string{};
  append(bytes, (int32_t)dims.x);
  append(bytes, (int32_t)dims.y);
  append(bytes, (int32_t)dims.z);
  append(bytes, res);
  for (auto v : m) append(bytes, v);
  return bytes;
}

std::string vol_header(
    vec3i dims, int channels, const std::vector<float>& box) {
  auto bytes = std::string{"VOL\x03"};
  append(bytes, (int32_t)1);
  append(bytes, (int32_t)dims.x);
  append(bytes, (int32_t)dims.y);
  append(bytes, (int32_t)dims.z);
  append(bytes, (int32_t)channels);
  for (auto v : box) append(bytes, v);
  return bytes;
}

std::string float_bytes(const std::vector<float>& values) {
  auto bytes = std::string{};
  for (auto v : values) append(bytes, v);
  return bytes;
}

// Loading must fail with an io_error that names the file and says `what`.
void check_refused(const std::string& name, const std::string& bytes,
    grid_format format, const std::string& what) {
  CAPTURE(name);
  auto filename = temp_path(name);
  write_file(filename, bytes);
  auto message = std::string{};
  try {
    load_grid(filename, format);
  } catch (const io_error& error) { message = error.what(); }
  CAPTURE(message);
  CHECK(message.find(filename) != std::string::npos);
  CHECK(message.find(what) != std::string::npos);
}

}  // namespace

TEST_CASE("grid io loads every format with odd dims, x fastest") {
  auto values = field_values();
  // SDFGen text: CRLF, several values per line, scientific notation.
  auto text = std::string{"7 11 13\r\n-1.5 2 3e-1\r\n2.5e-1\r\n"};
  for (auto n = size_t{0}; n < values.size(); n++) {
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), n % 3 ? "%.8e" : "%g", values[n]);
    text += buffer;
    text += n % 4 == 3 ? "\r\n" : " \t";
  }
  write_file(temp_path("field.sdf"), text);
  auto sdfgen = load_grid(temp_path("field.sdf"), grid_format::sdfgen);
  check_field(sdfgen);
  CHECK(sdfgen.spacing == 0.25f);
  CHECK(sdfgen.origin == vec3f{-1.5f, 2, 0.3f});

  // skanti, column major (translation at 12..14) with a pdf channel.
  auto h = 0.125f;
  auto colmajor =
      std::vector<float>{h, 0, 0, 0, 0, h, 0, 0, 0, 0, h, 0, 1, 2, 3, 1};
  auto pdf = std::vector<float>(values.size(), 7.0f);
  write_file(
      temp_path("field_col.sdf"), skanti_header({nx, ny, nz}, h, colmajor) +
                                      float_bytes(values) + float_bytes(pdf));
  auto col = load_grid(temp_path("field_col.sdf"), grid_format::skanti);
  check_field(col);
  CHECK(col.spacing == h);
  CHECK(col.origin == vec3f{1, 2, 3});
  // Row major (translation at 3, 7, 11), no pdf, res field wrong (1.0):
  // the matrix wins.
  auto rowmajor =
      std::vector<float>{h, 0, 0, 1, 0, h, 0, 2, 0, 0, h, 3, 0, 0, 0, 1};
  write_file(temp_path("field_row.sdf"),
      skanti_header({nx, ny, nz}, 1.0f, rowmajor) + float_bytes(values));
  auto row = load_grid(temp_path("field_row.sdf"), grid_format::skanti);
  check_field(row);
  CHECK(row.spacing == h);
  CHECK(row.origin == vec3f{1, 2, 3});

  // Mitsuba VOL: the bbox gives the spacing.
  write_file(temp_path("field.vol"),
      vol_header({nx, ny, nz}, 1, {0, 1, 2, 3, 6, 8}) + float_bytes(values));
  auto vol = load_grid(temp_path("field.vol"), grid_format::mitsuba);
  check_field(vol);
  CHECK(vol.spacing == doctest::Approx(0.5f));
  CHECK(vol.origin == vec3f{0, 1, 2});

  // OpenVDB: through our saver, a narrow band of 3 voxels (0.75) that
  // holds every sample once the field is scaled into it.
  auto scaled = sdfgen;
  for (auto& v : scaled.values) v /= 4000;
  save_grid(temp_path("field.vdb"), scaled, grid_format::vdb);
  auto vdb = load_grid(temp_path("field.vdb"), grid_format::vdb);
  REQUIRE(vdb.dims == vec3i{nx, ny, nz});
  CHECK(vdb.values == scaled.values);
  CHECK(vdb.file_active_voxels == nx * ny * nz);
  CHECK(vdb.file_background == 0.75f);
  CHECK(vdb.placed_by_file);
  CHECK(!sdfgen.placed_by_file);
  CHECK(vdb.spacing == 0.25f);
  CHECK(vdb.origin.x == doctest::Approx(-1.5f));
  CHECK(vdb.origin.z == doctest::Approx(0.3f));
}

TEST_CASE("grid io round trips through every saver") {
  auto grid   = make_grid({nx, ny, nz}, 0.037f, {-0.1f, 0.2f, 1e-3f}, 0);
  grid.values = field_values();
  // Not short decimals, and within 3 voxels so that the .vdb (a narrow
  // band) keeps every sample.
  for (auto& v : grid.values) v = v / 37000 + 1e-11f * v * v;
  update_grid_accel(grid);
  for (auto format : {grid_format::sdfgen, grid_format::skanti,
           grid_format::mitsuba, grid_format::vdb}) {
    auto name = grid_format_names[(int)format];
    CAPTURE(name);
    auto filename = temp_path("roundtrip_" + name);
    // Another writer's temporary by the old fixed name stays untouched: each
    // save has a temporary of its own (the file layer's).
    write_file(filename + ".tmp", "another writer's");
    save_grid(filename, grid, format);
    CHECK(read_file(filename + ".tmp") == "another writer's");
    auto loaded = load_grid(filename, format);
    CHECK(loaded.dims == grid.dims);
    CHECK(loaded.spacing == doctest::Approx(grid.spacing).epsilon(1e-6));
    CHECK(distance(loaded.origin, grid.origin) < 1e-6f);
    CHECK(loaded.values == grid.values);
  }
  CHECK(grid_format_from_uri("a/b.VDB", false) == grid_format::vdb);
  CHECK(grid_format_from_uri("a.vol", true) == grid_format::mitsuba);
  CHECK(grid_format_from_uri("a.sdf", true) == grid_format::skanti);
  CHECK(grid_format_from_uri("a.sdf", false) == grid_format::sdfgen);
  CHECK(grid_format_from_uri("noext", false) == grid_format::sdfgen);
  // Saving where it can not be written is an error, not a crash.
  CHECK_THROWS_AS(
      save_grid("/nonexistent/dir/x.sdf", grid, grid_format::sdfgen), io_error);
}

TEST_CASE("grid io refuses bad SDFGen text") {
  auto f     = grid_format::sdfgen;
  auto eight = std::string{"2 2 2\n0 0 0\n0.5\n"};
  check_refused("missing.sdf", "", f, "file is empty");
  check_refused("empty.sdf", "\n", f, ":2: dims[0]: missing");
  check_refused("short_header.sdf", "7 11\n", f, ":2: dims[2]: missing");
  check_refused("zero_dims.sdf", "0 5 5\n0 0 0\n1\n", f, ":1: dims 0x5x5");
  check_refused("one_dim.sdf", "1 5 5\n0 0 0\n1\n", f, "at least 2 samples");
  check_refused("negative_dims.sdf", "4 -5 5\n0 0 0\n1\n", f, "dims 4x-5x5");
  check_refused("absurd_dims.sdf", "100000 100000 100000\n", f, "over budget");
  check_refused("overflow_dims.sdf", "99999999999999999999 2 2\n", f,
      ":1: dims[0]: '99999999999999999999' is not an integer");
  check_refused("float_dims.sdf", "2.5 2 2\n", f, "is not an integer");
  check_refused("zero_dx.sdf", "2 2 2\n0 0 0\n0\n", f,
      ":3: dx 0.000000 must be positive");
  check_refused("negative_dx.sdf", "2 2 2\n0 0 0\n-1\n", f, "must be positive");
  check_refused("nan_dx.sdf", "2 2 2\n0 0 0\nnan\n", f, ":3: dx is not finite");
  check_refused(
      "nan_origin.sdf", "2 2 2\n0 inf 0\n1\n", f, ":2: origin.y is not finite");
  // Fewer bytes than the values could possibly need: refused up front.
  check_refused("huge_dims.sdf", "2000 2000 500\n0 0 0\n1\n1\n2\n", f,
      "too few values: dims 2000x2000x500 need 2000000000 values");
  check_refused("too_few.sdf",
      eight + "1.0000\n2.0000\n3.0000\n4.0000\n5.0000\n6.0000\n7.0000\n", f,
      ":11: too few values: expected 8, found 7");
  check_refused("too_many.sdf", eight + "1 2 3 4 5 6 7 8\n9\n", f,
      ":5: too many values: expected 8, found '9'");
  check_refused("junk.sdf", eight + "1\n2\nabc\n4 5 6 7 8\n", f,
      ":6: sample 2 (0,1,0): 'abc' is not a number");
  check_refused("junk_suffix.sdf", eight + "1\n2\n3x\n4 5 6 7 8\n", f,
      "'3x' is not a number");
  check_refused("nan.sdf", eight + "1\n2\n3\nnan\n5 6 7 8\n", f,
      ":7: sample 3 (1,1,0) is NaN");
  check_refused("inf.sdf", eight + "1 2 3 4 5 6 7\n-inf\n", f,
      ":5: sample 7 (1,1,1) is infinite");
  check_refused("out_of_range.sdf", eight + "1 2 3 4 5 6 7 1e50\n", f,
      "'1e50' is not a number");
  check_refused("binary_junk.sdf", std::string("\x01\x02\x03\x00\xff", 5), f,
      "is not an integer");
  // A directory is not a grid file.
  CHECK_THROWS_AS(load_grid(std::string(IMPLICIT_BINARY_DIR), f), io_error);
}

TEST_CASE("grid io refuses bad binary files") {
  auto s  = grid_format::skanti;
  auto m  = std::vector<float>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  auto v8 = float_bytes({1, 2, 3, 4, 5, 6, 7, 8});
  check_refused("empty.bin", "", s, "file is empty");
  check_refused("short.bin", std::string(10, '\0'), s,
      "truncated header: 10 bytes, the header needs 80");
  check_refused(
      "zero_dims.bin", skanti_header({0, 2, 2}, 1, m), s, "byte 0: dims 0x2x2");
  check_refused("absurd_dims.bin", skanti_header({5000, 5000, 5000}, 1, m), s,
      "over budget");
  auto big_endian = std::string{};
  for (auto d : {0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, 4}) big_endian += (char)d;
  check_refused(
      "big_endian.bin", big_endian + std::string(68, '\0'), s, "big-endian");
  check_refused("truncated.bin",
      skanti_header({2, 2, 2}, 1, m) + v8.substr(0, 20), s,
      "size 100 bytes, but dims 2x2x2 need 80+4N = 112 (sdf) or 80+8N = 144");
  check_refused("three_channels.bin",
      skanti_header({2, 2, 2}, 1, m) + v8 + v8 + v8, s, "size 176 bytes");
  auto not_affine = m;
  not_affine[15]  = 0;
  check_refused("not_affine.bin", skanti_header({2, 2, 2}, 1, not_affine) + v8,
      s, "byte 16: grid2world is not an affine matrix");
  auto uneven = m;
  uneven[5]   = 2;
  check_refused("uneven.bin", skanti_header({2, 2, 2}, 1, uneven) + v8, s,
      "not a uniform positive scale");
  auto nan_matrix = m;
  nan_matrix[13]  = NAN;
  check_refused("nan_matrix.bin", skanti_header({2, 2, 2}, 1, nan_matrix) + v8,
      s, "byte 68: grid2world element is not finite");
  check_refused("nan_sample.bin",
      skanti_header({2, 2, 2}, 1, m) + float_bytes({1, 2, 3, 4, 5, NAN, 7, 8}),
      s, "byte 100: sample 5 (1,0,1) is NaN");

  auto v    = grid_format::mitsuba;
  auto box  = std::vector<float>{0, 0, 0, 1, 1, 1};
  auto good = vol_header({2, 2, 2}, 1, box) + v8;
  check_refused("short.vol", "VOL", v, "truncated header: 3 bytes");
  auto bad_magic = good;
  bad_magic[1]   = 'X';
  check_refused(
      "magic.vol", bad_magic, v, "byte 0: magic 'VXL', expected 'VOL'");
  auto bad_version = good;
  bad_version[3]   = 4;
  check_refused("version.vol", bad_version, v, "byte 3: version 4, expected 3");
  auto bad_encoding = good;
  bad_encoding[4]   = 2;
  check_refused(
      "encoding.vol", bad_encoding, v, "byte 4: encoding 2, expected 1");
  check_refused("channels.vol", vol_header({2, 2, 2}, 3, box) + v8 + v8 + v8, v,
      "byte 20: channels 3, an SDF grid needs 1");
  check_refused("dims.vol", vol_header({2, -2, 2}, 1, box) + v8, v,
      "byte 8: dims 2x-2x2");
  check_refused("truncated.vol", good.substr(0, good.size() - 1), v,
      "size 79 bytes, but dims need 48+4N = 80");
  check_refused("long.vol", good + "x", v, "size 81 bytes");
  check_refused("uneven.vol", vol_header({2, 2, 2}, 1, {0, 0, 0, 1, 2, 1}) + v8,
      v, "byte 24: bbox gives voxel sizes");
  check_refused("flat.vol", vol_header({2, 2, 2}, 1, {0, 0, 0, 1, 0, 1}) + v8,
      v, "bbox is empty along axis 1");
  check_refused("nan.vol",
      vol_header({2, 2, 2}, 1, box) +
          float_bytes({1, 2, INFINITY, 4, 5, 6, 7, 8}),
      v, "byte 56: sample 2 (0,1,0) is infinite");
}

TEST_CASE("grid io refuses bad OpenVDB files") {
  auto f = grid_format::vdb;
  check_refused(
      "text.vdb", "this is not a vdb file\n", f, "not a readable OpenVDB file");
  check_refused("empty.vdb", "", f, "file is empty");
  // A valid file whose only grid is not a level set: patch the class
  // metadata ("level set" -> "staggered", same length) of a saved file.
  auto grid = make_grid({3, 3, 3}, 0.5f, {0, 0, 0}, -1);
  save_grid(temp_path("good.vdb"), grid, f);
  auto bytes = read_file(temp_path("good.vdb"));
  auto where = bytes.find("level set");
  REQUIRE(where != std::string::npos);
  auto staggered = bytes;
  staggered.replace(where, 9, "staggered");
  check_refused("staggered.vdb", staggered, f,
      "no float level set grid; found: sdf (float, staggered)");
  // Truncated at several places: an error, never a crash.
  for (auto cut :
      {size_t{8}, bytes.size() / 3, bytes.size() / 2, bytes.size() - 10}) {
    auto filename = temp_path("cut.vdb");
    write_file(filename, bytes.substr(0, cut));
    CAPTURE(cut);
    CAPTURE(bytes.size());
    CHECK_THROWS_AS(load_grid(filename, f), io_error);
  }
  check_refused(
      "cut.vdb", bytes.substr(0, bytes.size() - 10), f, "truncated or corrupt");
}

// Overwrite a little-endian uint32 of a file's bytes.
void put_u32(std::string& bytes, size_t offset, uint32_t value) {
  std::memcpy(&bytes[offset], &value, 4);
}

TEST_CASE("grid io checks OpenVDB length fields before OpenVDB reads them") {
  auto f    = grid_format::vdb;
  auto grid = make_grid({3, 3, 3}, 0.5f, {0, 0, 0}, -1);
  save_grid(temp_path("lengths.vdb"), grid, f);
  auto good = read_file(temp_path("lengths.vdb"));
  // Magic 8, version 4, library version 8, offsets flag 1, UUID 36 bytes;
  // then the file metadata count (0), the grid count and the first grid's
  // name length.
  constexpr size_t file_meta = 57, grid_count = 61, name_length = 65;
  uint32_t         value = 0;
  std::memcpy(&value, good.data() + file_meta, 4);
  REQUIRE(value == 0);
  struct patch {
    size_t      offset = 0;
    uint32_t    value  = 0;
    std::string error  = "";
  };
  for (auto& [offset, patched, what] : std::vector<patch>{
           {8, 221, "byte 12: file format version 221 (supported: 222 to"},
           {file_meta, 0x10000000,
               "file metadata count 268435456 does not fit in the file"},
           {grid_count, 0x7fffffff,
               "grid count 2147483647 does not fit in the file"},
           {name_length, 0xfffffff0,
               "grid name (4294967280 bytes) runs past the end"}}) {
    auto bytes = good;
    put_u32(bytes, offset, patched);
    check_refused("patched.vdb", bytes, f, what);
  }
  // Corrupt every 4 bytes of the header and descriptor, and a sample of the
  // tree, with large and negative lengths: an error or a grid, never a
  // crash, a hang or an allocation the file can not back.
  for (size_t offset = 0; offset + 4 <= good.size();
       offset += offset < 256 ? 1 : 61) {
    for (auto patched : {0xffffffffu, 0x7fffffffu, 0x80000000u}) {
      auto bytes = good;
      put_u32(bytes, offset, patched);
      write_file(temp_path("corrupt.vdb"), bytes);
      CAPTURE(offset);
      CAPTURE(patched);
      try {
        load_grid(temp_path("corrupt.vdb"), f);
      } catch (const io_error&) {
        // The expected outcome.
      }
    }
  }
}

TEST_CASE("grid io skanti matrix order is detected on the shared samples") {
  IMPLICIT_SKIP_WITHOUT_SHARED("sample grids; round trips cover skanti");
  auto col =
      load_grid(shared_path("skanti_layout_exact_sphere_colmajor_sdf_pdf.sdf"),
          grid_format::skanti);
  auto row =
      load_grid(shared_path("skanti_layout_exact_sphere_rowmajor_sdf_only.sdf"),
          grid_format::skanti);
  for (auto grid : {&col, &row}) {
    CHECK(grid->dims == vec3i{51, 51, 51});
    CHECK(grid->spacing == doctest::Approx(0.025f));
    CHECK(distance(grid->origin, vec3f{-0.625f, -0.625f, -0.625f}) < 1e-6f);
    // Exact sphere values at grid2world * (i,j,k).
    for (auto [i, j, k] :
        {std::array<int, 3>{0, 0, 0}, {25, 25, 25}, {5, 30, 47}}) {
      auto p =
          grid->origin + vec3f{(float)i, (float)j, (float)k} * grid->spacing;
      CHECK(grid_value(*grid, i, j, k) ==
            doctest::Approx(length(p) - 0.5f).epsilon(1e-4));
    }
  }
  CHECK(col.values == row.values);
}

TEST_CASE("grid io loads every shared sample or says why not") {
  IMPLICIT_SKIP_WITHOUT_SHARED("sample grids; round trips cover the formats");
  struct sample {
    std::string name;
    grid_format format;
    vec3i       dims;
    float       spacing;
    bool        has_surface;
  };
  auto samples = std::vector<sample>{
      {"sdfgen_icosphere_r0.5_dx0.05_pad2.sdf", grid_format::sdfgen,
          {24, 24, 24}, 0.05f, true},
      {"sdfgen_icosphere_r0.5_dx0.05_pad1.sdf", grid_format::sdfgen,
          {22, 22, 22}, 0.05f, true},
      {"sdfgen_torus_R0.6_r0.2_dx0.04_pad2.sdf", grid_format::sdfgen,
          {43, 44, 14}, 0.04f, true},
      {"gpis_Co_clean.sdf", grid_format::sdfgen, {25, 25, 25}, 0, true},
      {"gpis_Co_clean_dim_25.sdf", grid_format::sdfgen, {25, 25, 25}, 0, true},
      {"skanti_layout_exact_sphere_colmajor_sdf_pdf.sdf", grid_format::skanti,
          {51, 51, 51}, 0.025f, true},
      {"skanti_layout_exact_sphere_rowmajor_sdf_only.sdf", grid_format::skanti,
          {51, 51, 51}, 0.025f, true},
      {"skanti_emulated_pipeline_sphere_colmajor_sdf_pdf.sdf",
          grid_format::skanti, {51, 51, 51}, 0.025f, true},
      // Scan2CAD: unsigned distance fields (every value > 0): they load,
      // and have no surface to render (ysdf info says so).
      {"scan2cad_shapenet_chair_235c8ef2__0__.df", grid_format::skanti,
          {32, 32, 32}, 1 / 30.0f, false},
      {"scan2cad_cad_heatmap_235c8ef2_4_0.vox2", grid_format::skanti,
          {32, 32, 32}, 1 / 30.0f, false},
      {"mitsuba_sdfgrid_sphere_48.vol", grid_format::mitsuba, {48, 48, 48},
          1 / 47.0f, true},
  };
  for (auto& s : samples) {
    CAPTURE(s.name);
    auto grid = load_grid(shared_path(s.name), s.format);
    CHECK(grid.dims == s.dims);
    if (s.spacing > 0)
      CHECK(grid.spacing == doctest::Approx(s.spacing).epsilon(1e-5));
    auto stats = compute_grid_stats(grid);
    CHECK((stats.surface_voxels > 0) == s.has_surface);
    CHECK((stats.min > 0) == !s.has_surface);
  }
  // Every file in the folder is in the list above (or is the README).
  auto listed = 0;
  for (auto& entry : std::filesystem::directory_iterator(shared_path(""))) {
    auto name = entry.path().filename().string();
    if (name == "README.md") continue;
    auto found = false;
    for (auto& s : samples) found = found || s.name == name;
    CHECK_MESSAGE(found, name);
    listed++;
  }
  CHECK(listed == (int)samples.size());
}

TEST_CASE("grid io the clipped SDFGen sphere is closed by the box") {
  IMPLICIT_SKIP_WITHOUT_SHARED("the clipped SDFGen sphere sample");
  // pad1: the + faces sit exactly on the sphere (values ~6e-8 there), so
  // rays leave through the grid boundary; none may escape the solid.
  auto grid   = load_grid(shared_path("sdfgen_icosphere_r0.5_dx0.05_pad1.sdf"),
        grid_format::sdfgen);
  auto center = -grid.origin;  // the sphere's centre in grid space
  auto box    = grid_bounds(grid);
  CHECK(box.max.x == doctest::Approx(1.05f));
  auto escaped = 0, off = 0;
  auto count = 0;
  for (auto a = 0; a < 40; a++) {
    for (auto b = 0; b < 40; b++) {
      auto theta = (a + 0.5f) / 40 * pif, phi = b / 40.0f * 2 * pif;
      auto d = vec3f{std::sin(theta) * std::cos(phi), std::cos(theta),
          std::sin(theta) * std::sin(phi)};
      // From the centre outwards, and from outside inwards.
      for (auto from_inside : {true, false}) {
        auto ray   = from_inside ? ray3f{center, d, 0, flt_max}
                                 : ray3f{center + d * 3, -d, 0, flt_max};
        auto t     = 0.0f;
        auto steps = 0;
        count++;
        if (!intersect_grid(grid, ray, t, steps)) {
          escaped++;
          continue;
        }
        auto p = ray_point(ray, t);
        if (std::abs(length(p - center) - 0.5f) > 0.01f) off++;
        CHECK(inside(expand(box, 1e-5f), p));
      }
    }
  }
  CHECK(count == 3200);
  CHECK(escaped == 0);
  CHECK(off == 0);
  // Straight out through the +x face, where the sphere touches it.
  auto ray   = ray3f{center, {1, 0, 0}, 0, flt_max};
  auto t     = 0.0f;
  auto steps = 0;
  REQUIRE(intersect_grid(grid, ray, t, steps));
  CHECK(t == doctest::Approx(0.5f).epsilon(1e-3));
}
