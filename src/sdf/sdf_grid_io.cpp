// # implicit: SDF grid files (implementation)
//
// Formats, byte by byte, in shared/reference/sdf_formats.md. Every loader
// checks sizes before it allocates, refuses NaN/Inf samples and names the
// file and the line or byte offset of the problem.

#include "sdf_grid_io.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <new>
#include <vector>

#include "../util/error.h"
#include "../util/file.h"
#include "../util/memory.h"
#include "sdf_grid_file.h"

namespace implicit {

// -----------------------------------------------------------------------------
// HELPERS
// -----------------------------------------------------------------------------

std::string token_excerpt(const char* begin, const char* end) {
  auto text = std::string{};
  for (auto p = begin; p < end && text.size() < 24; p++)
    text += std::isprint((unsigned char)*p) ? *p : '?';
  if (end - begin > 24) text += "...";
  return text;
}

grid_format grid_format_from_uri(const std::string& uri, bool binary) {
  auto ext = path_extension(uri);
  if (ext == ".vdb") return grid_format::vdb;
  if (ext == ".vol") return grid_format::mitsuba;
  return binary ? grid_format::skanti : grid_format::sdfgen;
}

// Error "file: byte N: message".
[[noreturn]] static void throw_at_byte(
    const std::string& filename, size_t offset, const std::string& message) {
  throw_io_error(filename, "byte " + std::to_string(offset) + ": " + message);
}

// Index triple of sample n, for messages.
static std::string sample_name(vec3i dims, int64_t n) {
  auto i = n % dims.x, j = (n / dims.x) % dims.y, k = n / dims.x / dims.y;
  return "sample " + std::to_string(n) + " (" + std::to_string(i) + "," +
         std::to_string(j) + "," + std::to_string(k) + ")";
}

// Copy n float32 samples starting at byte `offset` and refuse NaN/Inf.
static void read_samples(const std::string& filename, const mapped_file& file,
    size_t offset, grid_data& grid) {
  auto count = (size_t)grid_samples(grid.dims);
  assign_huge(grid.values, count, 0.0f);
  std::memcpy(grid.values.data(), file.data + offset, count * 4);
  for (auto n = size_t{0}; n < count; n++) {
    if (!std::isfinite(grid.values[n]))
      throw_at_byte(filename, offset + 4 * n,
          sample_name(grid.dims, (int64_t)n) + " is " +
              (std::isnan(grid.values[n]) ? "NaN" : "infinite"));
  }
}

// -----------------------------------------------------------------------------
// SDFGEN TEXT
// -----------------------------------------------------------------------------

// Whitespace tokenizer that counts lines (CR counts as whitespace).
struct text_reader {
  const char* p    = nullptr;
  const char* end  = nullptr;
  int64_t     line = 1;
};

static bool is_space(char c) {
  return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\v' ||
         c == '\f';
}

// Skip whitespace; false at the end of the text.
static bool skip_spaces(text_reader& r) {
  while (r.p < r.end && is_space(*r.p)) {
    if (*r.p == '\n') r.line++;
    r.p++;
  }
  return r.p < r.end;
}

// Next token, or false at the end of the text.
static bool next_token(text_reader& r, const char*& begin, const char*& end) {
  if (!skip_spaces(r)) return false;
  begin = r.p;
  while (r.p < r.end && !is_space(*r.p)) r.p++;
  end = r.p;
  return true;
}

// Error "file:line: message".
[[noreturn]] static void throw_at_line(
    const std::string& filename, int64_t line, const std::string& message) {
  throw_io_error(filename + ":" + std::to_string(line), message);
}

// The number that starts at `begin` (from_chars, which does not take a
// leading '+'): where it ends, or nullptr when none does.
template <typename T>
static const char* number_end(const char* begin, const char* end, T& value) {
  if (begin < end && *begin == '+') begin++;
  auto [ptr, ec] = std::from_chars(begin, end, value);
  return ec == std::errc{} ? ptr : nullptr;
}

// Parse a whole token as a number.
template <typename T>
static bool parse_number(const char* begin, const char* end, T& value) {
  return number_end(begin, end, value) == end;
}

// The token at r.p as a number, read where it starts so that the millions
// of samples are scanned once; on failure `end` marks the token's end.
static bool read_number(text_reader& r, float& value, const char*& end) {
  auto ptr = number_end(r.p, r.end, value);
  if (ptr && (ptr == r.end || is_space(*ptr))) {
    r.p = ptr;
    return true;
  }
  end = r.p;
  while (end < r.end && !is_space(*end)) end++;
  return false;
}

// Read one header number or throw naming the field.
template <typename T>
static T read_header_number(
    text_reader& r, const std::string& filename, const std::string& field) {
  const char *begin = nullptr, *end = nullptr;
  if (!next_token(r, begin, end))
    throw_at_line(filename, r.line, field + ": missing (truncated header)");
  auto value = T{};
  if (!parse_number(begin, end, value))
    throw_at_line(filename, r.line,
        field + ": '" + token_excerpt(begin, end) + "' is not " +
            (std::is_integral_v<T> ? "an integer" : "a number"));
  if constexpr (!std::is_integral_v<T>) {
    if (!std::isfinite(value))
      throw_at_line(filename, r.line, field + " is not finite");
  }
  return value;
}

static grid_data load_sdfgen(const std::string& filename) {
  auto file  = mapped_file{filename};
  auto r     = text_reader{file.data, file.data + file.size, 1};
  auto nx    = read_header_number<int64_t>(r, filename, "dims[0]");
  auto ny    = read_header_number<int64_t>(r, filename, "dims[1]");
  auto nz    = read_header_number<int64_t>(r, filename, "dims[2]");
  auto error = check_grid_dims(nx, ny, nz);
  if (!error.empty()) throw_at_line(filename, r.line, error);
  auto grid    = grid_data{};
  grid.dims    = {(int)nx, (int)ny, (int)nz};
  grid.origin  = {read_header_number<float>(r, filename, "origin.x"),
       read_header_number<float>(r, filename, "origin.y"),
       read_header_number<float>(r, filename, "origin.z")};
  grid.spacing = read_header_number<float>(r, filename, "dx");
  if (!(grid.spacing > 0))
    throw_at_line(filename, r.line,
        "dx " + std::to_string(grid.spacing) + " must be positive");

  // Every value takes at least one character and one separator: refuse
  // before allocating when the file is too short to hold them.
  auto count     = grid_samples(grid.dims);
  auto remaining = (int64_t)(r.end - r.p);
  if (remaining < 2 * count - 1)
    throw_at_line(filename, r.line,
        "too few values: dims " + std::to_string(nx) + "x" +
            std::to_string(ny) + "x" + std::to_string(nz) + " need " +
            std::to_string(count) + " values but only " +
            std::to_string(remaining) + " bytes follow");
  assign_huge(grid.values, (size_t)count, 0.0f);
  for (auto n = int64_t{0}; n < count; n++) {
    if (!skip_spaces(r))
      throw_at_line(filename, r.line,
          "too few values: expected " + std::to_string(count) + ", found " +
              std::to_string(n));
    auto& value = grid.values[(size_t)n];
    auto  end   = r.p;
    if (!read_number(r, value, end))
      throw_at_line(filename, r.line,
          sample_name(grid.dims, n) + ": '" + token_excerpt(r.p, end) +
              "' is not a number");
    if (!std::isfinite(value))
      throw_at_line(filename, r.line,
          sample_name(grid.dims, n) + " is " +
              (std::isnan(value) ? "NaN" : "infinite"));
  }
  const char *begin = nullptr, *end = nullptr;
  if (next_token(r, begin, end))
    throw_at_line(filename, r.line,
        "too many values: expected " + std::to_string(count) + ", found '" +
            token_excerpt(begin, end) + "' after them");
  return grid;
}

// Append a float in the shortest form that reads back exactly.
static void append_float(std::string& text, float value) {
  char buffer[32];
  auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  text.append(buffer, ptr);
}

static void save_sdfgen(const std::string& filename, const grid_data& grid) {
  auto out  = output_file{filename};
  auto text = std::to_string(grid.dims.x) + " " + std::to_string(grid.dims.y) +
              " " + std::to_string(grid.dims.z) + "\n";
  append_float(text, grid.origin.x);
  text += ' ';
  append_float(text, grid.origin.y);
  text += ' ';
  append_float(text, grid.origin.z);
  text += '\n';
  append_float(text, grid.spacing);
  text += '\n';
  // One value per line, as SDFGen writes them; flushed in chunks.
  for (auto value : grid.values) {
    append_float(text, value);
    text += '\n';
    if (text.size() > (1 << 20)) {
      write_bytes(out, text.data(), text.size());
      text.clear();
    }
  }
  write_bytes(out, text.data(), text.size());
  commit_file(out);
}

// -----------------------------------------------------------------------------
// SKANTI BINARY
// -----------------------------------------------------------------------------

// Header: int32 dims[3], float32 res, float32 grid2world[16] (Eigen column
// major as the tool writes it, or row major as Scan2CAD's .df files), then
// float32 sdf[N] and an optional float32 pdf[N] that is ignored.
static constexpr size_t skanti_header = 80;

// Byte-swap a 32-bit integer (to recognise big-endian files).
static int64_t byte_swapped(int32_t v) {
  auto u = (uint32_t)v;
  u = (u >> 24) | ((u >> 8) & 0xff00u) | ((u << 8) & 0xff0000u) | (u << 24);
  return (int32_t)u;
}

// Check the dims of a binary header; `offset` is where they start.
static vec3i check_binary_dims(const std::string& filename, int32_t nx,
    int32_t ny, int32_t nz, size_t offset) {
  auto error = check_grid_dims(nx, ny, nz);
  if (error.empty()) return {nx, ny, nz};
  if (check_grid_dims(byte_swapped(nx), byte_swapped(ny), byte_swapped(nz))
          .empty())
    throw_at_byte(filename, offset,
        error + " (they read as " + std::to_string(byte_swapped(nx)) + "x" +
            std::to_string(byte_swapped(ny)) + "x" +
            std::to_string(byte_swapped(nz)) +
            " big-endian; only little-endian files are supported)");
  throw_at_byte(filename, offset, error);
}

static grid_data load_skanti(const std::string& filename) {
  auto file = mapped_file{filename};
  if (file.size < skanti_header)
    throw_io_error(filename, "truncated header: " + std::to_string(file.size) +
                                 " bytes, the header needs 80");
  auto dims  = check_binary_dims(filename, read_i32(file.data),
       read_i32(file.data + 4), read_i32(file.data + 8), 0);
  auto count = (size_t)grid_samples(dims);
  auto data  = file.size - skanti_header;
  if (data != 4 * count && data != 8 * count)
    throw_io_error(filename,
        "size " + std::to_string(file.size) + " bytes, but dims " +
            std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
            std::to_string(dims.z) +
            " need 80+4N = " + std::to_string(skanti_header + 4 * count) +
            " (sdf) or 80+8N = " + std::to_string(skanti_header + 8 * count) +
            " (sdf + pdf)");

  // grid2world: find where the translation sits (sdf_formats.md §2.6).
  float m[16];
  for (auto i = 0; i < 16; i++) {
    m[i] = read_f32(file.data + 16 + 4 * i);
    if (!std::isfinite(m[i]))
      throw_at_byte(
          filename, 16 + 4 * (size_t)i, "grid2world element is not finite");
  }
  auto column_major = m[3] == 0 && m[7] == 0 && m[11] == 0 && m[15] == 1;
  auto row_major    = m[12] == 0 && m[13] == 0 && m[14] == 0 && m[15] == 1;
  if (!column_major && !row_major)
    throw_at_byte(filename, 16,
        "grid2world is not an affine matrix in column- or row-major order "
        "(no 0 0 0 1 row)");
  // a(r, c): element at row r, column c, whichever order the file uses.
  auto a = [&](int r, int c) {
    return column_major ? m[c * 4 + r] : m[r * 4 + c];
  };
  auto spacing =
      std::sqrt(a(0, 0) * a(0, 0) + a(1, 0) * a(1, 0) + a(2, 0) * a(2, 0));
  if (!(spacing > 0))
    throw_at_byte(filename, 16, "grid2world has a zero voxel size");
  for (auto r = 0; r < 3; r++) {
    for (auto c = 0; c < 3; c++) {
      auto expected = r == c ? spacing : 0.0f;
      if (std::abs(a(r, c) - expected) > 1e-4f * spacing)
        throw_at_byte(filename, 16,
            "grid2world is not a uniform positive scale (element (" +
                std::to_string(r) + "," + std::to_string(c) +
                ") = " + std::to_string(a(r, c)) +
                "); only axis-aligned grids with cubic voxels are supported");
    }
  }
  // The res field is not trusted (Scan2CAD's DFGen writes 1.0): the voxel
  // size comes from the matrix whenever the two disagree.
  auto grid    = grid_data{};
  grid.dims    = dims;
  grid.spacing = spacing;
  grid.origin  = {a(0, 3), a(1, 3), a(2, 3)};
  read_samples(filename, file, skanti_header, grid);
  return grid;
}

static void save_skanti(const std::string& filename, const grid_data& grid) {
  auto    out = output_file{filename};
  char    header[skanti_header];
  int32_t dims[3]            = {grid.dims.x, grid.dims.y, grid.dims.z};
  auto    h                  = grid.spacing;
  auto&   o                  = grid.origin;
  float   res_and_matrix[17] = {
        h, h, 0, 0, 0, 0, h, 0, 0, 0, 0, h, 0, o.x, o.y, o.z, 1};
  std::memcpy(header, dims, 12);
  std::memcpy(header + 12, res_and_matrix, 68);
  write_bytes(out, header, sizeof(header));
  write_bytes(out, grid.values.data(), grid.values.size() * 4);
  commit_file(out);
}

// -----------------------------------------------------------------------------
// MITSUBA VOL
// -----------------------------------------------------------------------------

// Header: "VOL", uint8 version 3, int32 encoding (1 = float32), int32 dims,
// int32 channels, float32 bbox[6]; then float32 data, x fastest.
static constexpr size_t vol_header = 48;

static grid_data load_mitsuba(const std::string& filename) {
  auto file = mapped_file{filename};
  if (file.size < vol_header)
    throw_io_error(filename, "truncated header: " + std::to_string(file.size) +
                                 " bytes, the header needs 48");
  auto d = file.data;
  if (d[0] != 'V' || d[1] != 'O' || d[2] != 'L')
    throw_at_byte(
        filename, 0, "magic '" + token_excerpt(d, d + 3) + "', expected 'VOL'");
  if (d[3] != 3)
    throw_at_byte(filename, 3,
        "version " + std::to_string((int)(unsigned char)d[3]) + ", expected 3");
  if (auto encoding = read_i32(d + 4); encoding != 1)
    throw_at_byte(filename, 4,
        "encoding " + std::to_string(encoding) + ", expected 1 (float32)");
  auto dims = check_binary_dims(
      filename, read_i32(d + 8), read_i32(d + 12), read_i32(d + 16), 8);
  if (auto channels = read_i32(d + 20); channels != 1)
    throw_at_byte(filename, 20,
        "channels " + std::to_string(channels) + ", an SDF grid needs 1");
  auto count = (size_t)grid_samples(dims);
  if (file.size != vol_header + 4 * count)
    throw_io_error(filename, "size " + std::to_string(file.size) +
                                 " bytes, but dims need 48+4N = " +
                                 std::to_string(vol_header + 4 * count));
  float box[6];
  for (auto i = 0; i < 6; i++) {
    box[i] = read_f32(d + 24 + 4 * i);
    if (!std::isfinite(box[i]))
      throw_at_byte(filename, 24 + 4 * (size_t)i, "bbox value is not finite");
  }
  // The bbox gives the voxel size (Mitsuba itself ignores it).
  float spacing[3];
  for (auto a = 0; a < 3; a++) {
    spacing[a] = (box[a + 3] - box[a]) / (float)((&dims.x)[a] - 1);
    if (!(spacing[a] > 0))
      throw_at_byte(
          filename, 24, "bbox is empty along axis " + std::to_string(a));
  }
  for (auto a = 1; a < 3; a++) {
    if (std::abs(spacing[a] - spacing[0]) > 1e-4f * spacing[0])
      throw_at_byte(filename, 24,
          "bbox gives voxel sizes " + std::to_string(spacing[0]) + ", " +
              std::to_string(spacing[1]) + ", " + std::to_string(spacing[2]) +
              "; only cubic voxels are supported");
  }
  auto grid    = grid_data{};
  grid.dims    = dims;
  grid.spacing = spacing[0];
  grid.origin  = {box[0], box[1], box[2]};
  read_samples(filename, file, vol_header, grid);
  return grid;
}

static void save_mitsuba(const std::string& filename, const grid_data& grid) {
  auto    out                = output_file{filename};
  char    header[vol_header] = {'V', 'O', 'L', 3};
  int32_t ints[5]            = {1, grid.dims.x, grid.dims.y, grid.dims.z, 1};
  auto    extent             = grid_bounds(grid).max;
  auto&   o                  = grid.origin;
  float   box[6]             = {
                    o.x, o.y, o.z, o.x + extent.x, o.y + extent.y, o.z + extent.z};
  std::memcpy(header + 4, ints, 20);
  std::memcpy(header + 24, box, 24);
  write_bytes(out, header, sizeof(header));
  write_bytes(out, grid.values.data(), grid.values.size() * 4);
  commit_file(out);
}

// -----------------------------------------------------------------------------
// DISPATCH
// -----------------------------------------------------------------------------

grid_data load_grid(const std::string& filename, grid_format format) {
  auto grid = grid_data{};
  try {
    switch (format) {
      case grid_format::sdfgen: grid = load_sdfgen(filename); break;
      case grid_format::skanti: grid = load_skanti(filename); break;
      case grid_format::vdb: grid = load_vdb_grid(filename); break;
      case grid_format::mitsuba: grid = load_mitsuba(filename); break;
    }
    update_grid_accel(grid);
  } catch (const std::bad_alloc&) {
    // Sizes are checked against the file size and the grid budget, so this
    // is a grid larger than the memory left: still an error naming the file.
    throw_io_error(filename, "out of memory loading the grid");
  }
  return grid;
}

void save_grid(
    const std::string& filename, const grid_data& grid, grid_format format) {
  auto error = check_grid_dims(grid.dims.x, grid.dims.y, grid.dims.z);
  if (!error.empty()) throw_io_error(filename, "cannot save: " + error);
  if ((int64_t)grid.values.size() != grid_samples(grid.dims))
    throw_io_error(
        filename, "cannot save: the sample count does not match the dims");
  switch (format) {
    case grid_format::sdfgen: save_sdfgen(filename, grid); break;
    case grid_format::skanti: save_skanti(filename, grid); break;
    case grid_format::vdb: save_vdb_grid(filename, grid); break;
    case grid_format::mitsuba: save_mitsuba(filename, grid); break;
  }
}

}  // namespace implicit
