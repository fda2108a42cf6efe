// # implicit: SDF grid files: OpenVDB files checked before OpenVDB reads them
//
// OpenVDB trusts the length fields it reads: a string length, a metadata
// size, a grid count or a compressed chunk size of a few GB makes it
// allocate that much (up to 8 GB measured) before a read fails, and a read
// that fails part-way through a tree leaks nodes. So the loader walks the
// file first, byte by byte as OpenVDB would read it (io/Archive.cc,
// io/GridDescriptor.cc, MetaMap, math/Maps.h, tree/RootNode.h,
// InternalNode.h, LeafNode.h and io/Compression.h of OpenVDB 10), and
// checks every count and length against the bytes that follow. What it
// hands OpenVDB is a copy with only the float grids it could check (other
// grid types are skipped by their offsets) and without delayed-load
// metadata (its counts are not checked by OpenVDB, and we never load
// lazily). Files older than format 222 (OpenVDB 3, 2014) are refused.

#include <openvdb/openvdb.h>

#include <array>
#include <set>

#include "../util/error.h"
#include "sdf_grid_file.h"

namespace implicit {

namespace {

// OpenVDB's per-grid compression flags (io/Compression.h).
constexpr uint32_t vdb_zip = 0x1, vdb_active_mask = 0x2, vdb_blosc = 0x4;
// The per-node compression modes that readCompressedValues() knows.
constexpr int8_t vdb_one_inactive = 2, vdb_mask_no_inactive = 3,
                 vdb_mask_one_inactive = 4, vdb_mask_two_inactive = 5,
                 vdb_all_values = 6;
// The oldest file format we check (per-grid compression, node masks).
constexpr uint32_t vdb_min_version = 222;

// A cursor over the file; every read checks that the bytes are there.
struct vdb_reader {
  std::string filename = "";
  const char* begin    = nullptr;
  const char* p        = nullptr;
  const char* end      = nullptr;
};

[[noreturn]] void vdb_fail(const vdb_reader& r, const std::string& problem) {
  throw_io_error(r.filename, "not a readable OpenVDB file: byte " +
                                 std::to_string(r.p - r.begin) + ": " +
                                 problem);
}

uint64_t vdb_remaining(const vdb_reader& r) { return (uint64_t)(r.end - r.p); }

void vdb_skip(vdb_reader& r, uint64_t size, const std::string& what) {
  if (size > vdb_remaining(r))
    vdb_fail(r, what + " (" + std::to_string(size) +
                    " bytes) runs past the end: truncated or corrupt");
  r.p += size;
}

template <typename T>
T vdb_read(vdb_reader& r, const std::string& what) {
  auto start = r.p;
  vdb_skip(r, sizeof(T), what);
  auto value = T{};
  std::memcpy(&value, start, sizeof(T));
  return value;
}

std::string vdb_string(vdb_reader& r, const std::string& what) {
  auto size  = vdb_read<uint32_t>(r, what + " length");
  auto start = r.p;
  vdb_skip(r, size, what);
  return {start, size};
}

// Bytes of a metadata value of a registered fixed-size type (OpenVDB reads
// sizeof(T) whatever the size field says); -1 for strings and unknown
// types, which it reads by the size field.
int64_t vdb_metadata_size(const std::string& type) {
  static const std::pair<const char*, int64_t> sizes[] = {{"bool", 1},
      {"int32", 4}, {"int64", 8}, {"float", 4}, {"double", 8}, {"vec2i", 8},
      {"vec2s", 8}, {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24},
      {"vec4i", 16}, {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64},
      {"mat4d", 128}};
  for (auto& [name, size] : sizes) {
    if (type == name) return size;
  }
  return -1;
}

// Append raw bytes of a value.
template <typename T>
void vdb_append(std::string& out, T value) {
  out.append((const char*)&value, sizeof(T));
}

// Check a metadata map and copy it to `out` without delayed-load entries.
void vdb_metadata(vdb_reader& r, std::string& out, const std::string& what) {
  auto count = vdb_read<int32_t>(r, what + " count");
  // Each entry takes at least two lengths and a size.
  if (count < 0 || (uint64_t)count > vdb_remaining(r) / 12)
    vdb_fail(r,
        what + " count " + std::to_string(count) + " does not fit in the file");
  auto kept       = std::string{};
  auto kept_count = int32_t{0};
  for (auto i = 0; i < count; i++) {
    auto start    = r.p;
    auto name     = vdb_string(r, what + " name");
    auto type     = vdb_string(r, what + " type");
    auto size     = vdb_read<uint32_t>(r, what + " size");
    auto expected = vdb_metadata_size(type);
    if (expected >= 0 && size != expected)
      vdb_fail(r, what + " '" +
                      token_excerpt(name.data(), name.data() + name.size()) +
                      "' of type " + type + " has " + std::to_string(size) +
                      " bytes, expected " + std::to_string(expected));
    vdb_skip(r, size, what + " value");
    if (type == "__delayedload") continue;
    kept.append(start, r.p);
    kept_count++;
  }
  vdb_append(out, kept_count);
  out += kept;
}

// Check a transform: a map type and its fixed-size parameters.
void vdb_transform(vdb_reader& r) {
  static const std::pair<const char*, uint64_t> sizes[] = {{"AffineMap", 128},
      {"UnitaryMap", 128}, {"ScaleMap", 120}, {"UniformScaleMap", 120},
      {"TranslationMap", 24}, {"ScaleTranslateMap", 144},
      {"UniformScaleTranslateMap", 144}};
  auto type = vdb_string(r, "transform type");
  for (auto& [name, size] : sizes) {
    if (type == name) return vdb_skip(r, size, "transform " + type);
  }
  vdb_fail(r, "unsupported transform '" +
                  token_excerpt(type.data(), type.data() + type.size()) + "'");
}

// Set bits in a node mask of `bytes` bytes.
uint64_t vdb_count_on(const char* mask, uint64_t bytes) {
  auto count = uint64_t{0};
  for (auto i = uint64_t{0}; i < bytes; i += 8) {
    auto word = uint64_t{0};
    std::memcpy(&word, mask + i, 8);
    count += (uint64_t)__builtin_popcountll(word);
  }
  return count;
}

// How a grid stores its values.
struct vdb_grid_format {
  uint32_t compression = 0;
  uint64_t value_size  = 4;  // 2 for half floats
};

// Check the values of a node as readCompressedValues() reads them:
// `count` values, `active` of them on in its mask of `mask_bytes` bytes.
void vdb_values(vdb_reader& r, const vdb_grid_format& grid, uint64_t count,
    uint64_t active, uint64_t mask_bytes) {
  auto mode = vdb_read<int8_t>(r, "node compression mode");
  if (mode < 0 || mode > vdb_all_values)
    vdb_fail(r, "node compression mode " + std::to_string(mode));
  if (mode == vdb_one_inactive || mode == vdb_mask_one_inactive ||
      mode == vdb_mask_two_inactive)
    vdb_skip(r, mode == vdb_mask_two_inactive ? 8 : 4, "inactive values");
  if (mode == vdb_mask_no_inactive || mode == vdb_mask_one_inactive ||
      mode == vdb_mask_two_inactive)
    vdb_skip(r, mask_bytes, "selection mask");
  auto values = (grid.compression & vdb_active_mask) && mode != vdb_all_values
                    ? active
                    : count;
  // Half floats skip an empty chunk altogether (HalfReader).
  if (grid.value_size == 2 && values == 0) return;
  auto bytes = values * grid.value_size;
  if (!(grid.compression & (vdb_zip | vdb_blosc)))
    return vdb_skip(r, bytes, "node values");
  auto chunk = vdb_read<int64_t>(r, "compressed chunk size");
  if (chunk > 0) return vdb_skip(r, (uint64_t)chunk, "compressed chunk");
  // Stored uncompressed: OpenVDB reads this many bytes into a buffer of
  // `bytes` before it compares the two.
  if ((uint64_t)0 - (uint64_t)chunk != bytes)
    vdb_fail(r, "uncompressed chunk of " +
                    std::to_string((uint64_t)0 - (uint64_t)chunk) +
                    " bytes, expected " + std::to_string(bytes));
  vdb_skip(r, bytes, "node values");
}

// Check a float tree (Tree4<float, 5, 4, 3>): its topology, then the
// buffers of its leaves.
void vdb_float_tree(vdb_reader& r, const vdb_grid_format& grid) {
  constexpr uint64_t mask5 = 32768 / 8, mask4 = 4096 / 8, mask3 = 512 / 8;
  vdb_read<int32_t>(r, "buffer count");
  vdb_read<float>(r, "background");
  auto tiles    = vdb_read<uint32_t>(r, "root tile count");
  auto children = vdb_read<uint32_t>(r, "root child count");
  if (tiles > vdb_remaining(r) / 17)
    vdb_fail(r, std::to_string(tiles) + " root tiles do not fit in the file");
  if (children > vdb_remaining(r) / (12 + 2 * mask5))
    vdb_fail(
        r, std::to_string(children) + " root children do not fit in the file");
  // Root entries are keyed by origin: a repeated one would replace (and
  // leak) a node, an unaligned one would be looked up wrongly.
  auto origins = std::set<std::array<int32_t, 3>>{};
  auto origin  = [&](const char* what) {
    auto o = std::array<int32_t, 3>{};
    for (auto& c : o) {
      c = vdb_read<int32_t>(r, what);
      if (c % 4096 != 0) vdb_fail(r, std::string(what) + " is not aligned");
    }
    if (!origins.insert(o).second)
      vdb_fail(r, std::string(what) + " repeats another");
  };
  for (auto t = uint32_t{0}; t < tiles; t++) {
    origin("root tile origin");
    vdb_read<float>(r, "root tile value");
    if (vdb_read<uint8_t>(r, "root tile state") > 1)
      vdb_fail(r, "root tile state is not 0 or 1");
  }
  auto leaves = uint64_t{0};
  for (auto c = uint32_t{0}; c < children; c++) {
    origin("root child origin");
    auto child5 = r.p;
    vdb_skip(r, 2 * mask5, "node masks");
    vdb_values(r, grid, 32768, vdb_count_on(child5 + mask5, mask5), mask5);
    for (auto i = uint64_t{0}; i < vdb_count_on(child5, mask5); i++) {
      auto child4 = r.p;
      vdb_skip(r, 2 * mask4, "node masks");
      vdb_values(r, grid, 4096, vdb_count_on(child4 + mask4, mask4), mask4);
      auto count = vdb_count_on(child4, mask4);
      vdb_skip(r, count * mask3, "leaf masks");
      leaves += count;
    }
  }
  for (auto l = uint64_t{0}; l < leaves; l++) {
    auto mask = r.p;
    vdb_skip(r, mask3, "leaf mask");
    vdb_values(r, grid, 512, vdb_count_on(mask, mask3), mask3);
  }
}

}  // namespace

std::string check_vdb_file(
    const std::string& filename, const char* data, size_t size) {
  auto r   = vdb_reader{filename, data, data, data + size};
  auto out = std::string{};
  if (vdb_read<int64_t>(r, "magic") != openvdb::OPENVDB_MAGIC)
    vdb_fail(r, "no VDB magic number");
  auto version = vdb_read<uint32_t>(r, "file version");
  if (version < vdb_min_version || version > openvdb::OPENVDB_FILE_VERSION)
    vdb_fail(r, "file format version " + std::to_string(version) +
                    " (supported: " + std::to_string(vdb_min_version) + " to " +
                    std::to_string(openvdb::OPENVDB_FILE_VERSION) + ")");
  vdb_skip(r, 8, "library version");
  auto offsets = vdb_read<uint8_t>(r, "grid offsets flag") != 0;
  // The UUID as text: 36 characters, hex digits and dashes.
  auto uuid = r.p;
  vdb_skip(r, 36, "UUID");
  for (auto i = 0; i < 36; i++) {
    auto c    = uuid[i];
    auto dash = i == 8 || i == 13 || i == 18 || i == 23;
    if (dash ? c != '-' : !std::isxdigit((unsigned char)c))
      vdb_fail(r, "the UUID is not 36 characters of hex digits and dashes");
  }
  out.append(data, r.p);
  vdb_metadata(r, out, "file metadata");
  auto count = vdb_read<int32_t>(r, "grid count");
  // Each grid takes at least its descriptor: three lengths, three offsets.
  if (count < 0 || (uint64_t)count > vdb_remaining(r) / 36)
    vdb_fail(
        r, "grid count " + std::to_string(count) + " does not fit in the file");
  auto grids      = std::string{};
  auto kept       = int32_t{0};
  auto float_tree = openvdb::FloatGrid::gridType();
  for (auto g = 0; g < count; g++) {
    auto start  = r.p;
    auto name   = vdb_string(r, "grid name");
    auto type   = vdb_string(r, "grid type");
    auto grid   = vdb_grid_format{};
    auto suffix = std::string{"_HalfFloat"};
    if (type.size() > suffix.size() &&
        type.compare(type.size() - suffix.size(), suffix.size(), suffix) == 0) {
      type.resize(type.size() - suffix.size());
      grid.value_size = 2;
    }
    auto instance = !vdb_string(r, "instance parent name").empty();
    auto position = vdb_read<int64_t>(r, "grid offset");
    vdb_read<int64_t>(r, "grid block offset");
    auto end_position = vdb_read<int64_t>(r, "grid end offset");
    if (offsets && end_position > (int64_t)size)
      vdb_fail(r,
          "the grid ends past the end of the file: truncated or "
          "corrupt");
    if (offsets && (position != r.p - data || end_position < position))
      vdb_fail(r, "grid offsets do not match the file");
    if (type != float_tree) {
      // Not a grid we load: skip it by its offsets, unchecked, and leave it
      // out of what OpenVDB reads.
      if (!offsets)
        vdb_fail(r, "grid of type '" +
                        token_excerpt(type.data(), type.data() + type.size()) +
                        "' in a file without grid offsets");
      r.p = data + end_position;
      continue;
    }
    grid.compression = vdb_read<uint32_t>(r, "grid compression");
    auto checked     = std::string(start, r.p);
    vdb_metadata(r, checked, "grid metadata");
    auto rest = r.p;
    vdb_transform(r);
    if (!instance) vdb_float_tree(r, grid);
    if (offsets && r.p != data + end_position)
      vdb_fail(r, "grid ends at another offset than its descriptor says");
    checked.append(rest, r.p);
    grids += checked;
    kept++;
  }
  vdb_append(out, kept);
  out += grids;
  return out;
}

}  // namespace implicit
