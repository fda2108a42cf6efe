// # implicit: SDF grid files: shared helpers of the grid and mesh loaders
//
// Internal to src/sdf: little-endian reads and token excerpts for messages,
// plus the OpenVDB entry points that live in their own translation unit
// (OpenVDB's headers are heavy). Files are read and written through
// util/file.h.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

#include "sdf_grid.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
    "grid files are little-endian; add byte swapping for this host");

namespace implicit {

// -----------------------------------------------------------------------------
// BYTES
// -----------------------------------------------------------------------------

// Little-endian reads from a byte buffer (the host is little-endian).
inline int32_t read_i32(const char* p) {
  auto v = int32_t{0};
  std::memcpy(&v, p, 4);
  return v;
}
inline float read_f32(const char* p) {
  auto v = 0.0f;
  std::memcpy(&v, p, 4);
  return v;
}

// A short printable excerpt of a token for error messages.
std::string token_excerpt(const char* begin, const char* end);

// -----------------------------------------------------------------------------
// OPENVDB (sdf_grid_vdb.cpp)
// -----------------------------------------------------------------------------

// Register OpenVDB's types, once per process (thread-safe).
void init_openvdb();
// Check a .vdb file as OpenVDB would read it, every count and length
// against the bytes that follow (sdf_grid_vdb_check.cpp); returns the bytes
// to hand OpenVDB: the file with only its float grids, without delayed-load
// metadata. Throws io_error naming the file and the byte offset.
std::string check_vdb_file(
    const std::string& filename, const char* data, size_t size);
// Dense samples a .vdb file may expand to per byte of the file: a level
// set's narrow band holds far more than this, while a tiny file with two
// far-apart voxels can not make us allocate gigabytes.
inline constexpr int64_t vdb_max_samples_per_byte = int64_t{1} << 16;
// Load the first float level set of a .vdb file as a dense grid.
grid_data load_vdb_grid(const std::string& filename);
// Save a grid as a float level set.
void save_vdb_grid(const std::string& filename, const grid_data& grid);

}  // namespace implicit
