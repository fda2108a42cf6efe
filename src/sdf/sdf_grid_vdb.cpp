// # implicit: SDF grid files: OpenVDB level sets
//
// A .vdb file is sparse; we densify the first float level set over its
// active voxels' bounding box (for a level set that is the narrow band, so
// the box already holds the surface with a positive border). Voxels without
// an active value read the tree's tile or background value, which OpenVDB
// keeps signed for level sets (-background inside, +background outside):
// a bound of the distance, as the band is the set of voxels closer than the
// background. The grid is placed by the file's index-to-world transform.
//
// Saving writes a level set as OpenVDB's own tools do (createLevelSet,
// meshToLevelSet): grid class level set, background = 3 voxels, active
// voxels only within that narrow band, inactive values +-background by
// sign, uniform regions pruned to tiles.

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Prune.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <mutex>
#include <sstream>

#include "../util/error.h"
#include "../util/file.h"
#include "../util/memory.h"
#include "sdf_grid_file.h"

namespace implicit {

// OpenVDB needs its grid types registered once per process; call_once keeps
// it thread-safe without global mutable state of ours.
void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

// Voxel size of a transform that only scales uniformly and translates, or
// 0 when it rotates, shears, scales unevenly or is not linear.
static float uniform_voxel_size(const openvdb::math::Transform& transform) {
  if (!transform.isLinear()) return 0;
  auto zero = transform.indexToWorld(openvdb::Vec3d(0, 0, 0));
  auto size = (transform.indexToWorld(openvdb::Vec3d(1, 0, 0)) - zero).length();
  if (!(size > 0)) return 0;
  for (auto axis = 0; axis < 3; axis++) {
    auto unit  = openvdb::Vec3d(0, 0, 0);
    unit[axis] = 1;
    auto edge  = transform.indexToWorld(unit) - zero;
    for (auto c = 0; c < 3; c++) {
      auto expected = c == axis ? size : 0.0;
      if (std::abs(edge[c] - expected) > 1e-5 * size) return 0;
    }
  }
  return (float)size;
}

// The grids of a .vdb file whose bytes check_vdb_file() has walked.
static openvdb::GridPtrVecPtr read_vdb_grids(
    const std::string& filename, const std::string& checked) {
  auto grids = openvdb::GridPtrVecPtr{};
  try {
    auto stream = std::istringstream(checked);
    stream.exceptions(std::ios::failbit | std::ios::badbit);
    grids = openvdb::io::Stream(stream, false).getGrids();
  } catch (const std::ios_base::failure&) {
    throw_io_error(filename,
        "not a readable OpenVDB file: truncated or corrupt "
        "(a read ran past the end)");
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& error) {
    // OpenVDB throws its own exceptions (e.g. corrupt compressed data).
    throw_io_error(
        filename, std::string("not a readable OpenVDB file: ") + error.what());
  }
  if (!grids) throw_io_error(filename, "not a readable OpenVDB file");
  return grids;
}

// The first float level set of the grids; the error lists what there is.
static openvdb::FloatGrid::Ptr find_level_set(
    const std::string& filename, const openvdb::GridPtrVec& grids) {
  auto level_set = openvdb::FloatGrid::Ptr{};
  auto found     = std::string{};
  for (auto& base : grids) {
    found += (found.empty() ? "" : ", ") + base->getName() + " (" +
             base->valueType() + ", " +
             openvdb::GridBase::gridClassToString(base->getGridClass()) + ")";
    if (level_set || base->getGridClass() != openvdb::GRID_LEVEL_SET) continue;
    level_set = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  }
  if (!level_set)
    throw_io_error(
        filename, "no float level set grid; found: " +
                      (found.empty() ? std::string("no grids") : found));
  return level_set;
}

grid_data load_vdb_grid(const std::string& filename) {
  init_openvdb();
  // Read through a stream that throws on a short read: io::File ignores
  // them, so a truncated file would load with garbage voxels. Without
  // delayed loading, since that copies the stream to a temporary file.
  // OpenVDB trusts the length fields it reads, so it only gets the bytes
  // that check_vdb_file() has walked.
  auto file      = mapped_file{filename};
  auto checked   = check_vdb_file(filename, file.data, file.size);
  auto grids     = read_vdb_grids(filename, checked);
  auto level_set = find_level_set(filename, *grids);
  auto name      = "grid '" + level_set->getName() + "': ";
  auto spacing   = uniform_voxel_size(level_set->transform());
  if (spacing == 0)
    throw_io_error(
        filename, name +
                      "the transform rotates, shears or scales unevenly; "
                      "only axis-aligned cubic voxels are supported");
  auto box = level_set->evalActiveVoxelBoundingBox();
  if (box.empty()) throw_io_error(filename, name + "no active voxels");
  auto lo    = box.min();
  auto dim   = box.dim();
  auto error = check_grid_dims(dim.x(), dim.y(), dim.z());
  if (!error.empty()) throw_io_error(filename, name + "active box " + error);
  auto samples = (int64_t)dim.x() * dim.y() * dim.z();
  if (samples / vdb_max_samples_per_byte > (int64_t)file.size)
    throw_io_error(filename, name + "active box " + std::to_string(dim.x()) +
                                 "x" + std::to_string(dim.y()) + "x" +
                                 std::to_string(dim.z()) +
                                 " is too large for a file of " +
                                 std::to_string(file.size) + " bytes");

  auto grid    = grid_data{};
  grid.dims    = {(int)dim.x(), (int)dim.y(), (int)dim.z()};
  grid.spacing = spacing;
  auto origin  = level_set->transform().indexToWorld(lo);
  grid.origin  = {(float)origin.x(), (float)origin.y(), (float)origin.z()};
  grid.placed_by_file     = true;
  grid.file_active_voxels = (int64_t)level_set->activeVoxelCount();
  grid.file_background    = level_set->background();
  assign_huge(grid.values, (size_t)grid_samples(grid.dims), 0.0f);
  // Values x fastest, as ours (OpenVDB's LayoutXYZ), copied in parallel.
  auto dense = openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ>(
      box, grid.values.data());
  openvdb::tools::copyToDense(*level_set, dense);
  for (auto n = size_t{0}; n < grid.values.size(); n++) {
    if (std::isfinite(grid.values[n])) continue;
    auto ijk = lo + dense.offsetToLocalCoord(n);
    throw_io_error(filename, name + "voxel (" + std::to_string(ijk.x()) + "," +
                                 std::to_string(ijk.y()) + "," +
                                 std::to_string(ijk.z()) + ") is not finite");
  }
  return grid;
}

// Half width of the narrow band of saved level sets, in voxels (OpenVDB's
// LEVEL_SET_HALF_WIDTH).
static constexpr int vdb_half_width = 3;

// The samples a saved level set keeps active: those within the band
// (|value| < background), every corner of a voxel whose corners change
// sign (so that a surface voxel keeps its values even where the data is no
// distance, e.g. skanti's voxel counts), and the negative samples on the
// box (where the box closes the surface). The rest only keep their sign,
// and the surface traced from the file is the same.
static std::vector<uint8_t> level_set_band(
    const grid_data& grid, float background) {
  auto  band = std::vector<uint8_t>(grid.values.size(), 0);
  auto& d    = grid.dims;
  auto  at   = [&](int i, int j, int k) {
    return (size_t)i + (size_t)d.x * ((size_t)j + (size_t)d.y * k);
  };
  for (auto k = 0; k < d.z; k++) {
    for (auto j = 0; j < d.y; j++) {
      for (auto i = 0; i < d.x; i++) {
        auto v        = grid.values[at(i, j, k)];
        auto boundary = i == 0 || j == 0 || k == 0 || i == d.x - 1 ||
                        j == d.y - 1 || k == d.z - 1;
        if (std::abs(v) < background || (boundary && v < 0))
          band[at(i, j, k)] = 1;
        if (i == d.x - 1 || j == d.y - 1 || k == d.z - 1) continue;
        auto negative = 0;
        for (auto c = 0; c < 8; c++)
          negative += grid_value(grid, i + (c & 1), j + ((c >> 1) & 1),
                          k + (c >> 2)) < 0;
        if (negative == 0 || negative == 8) continue;
        for (auto c = 0; c < 8; c++)
          band[at(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2))] = 1;
      }
    }
  }
  return band;
}

// The samples [start, start + 8)^3 of the grid into the level set's tree
// (one leaf's extent): a leaf when the block has a band sample, else a tile
// of -background when it is inside, else nothing (the background). A block
// without a band sample has one sign (a sign change marks its voxel's
// corners), and a negative one never reaches past the box (negative box
// samples are in the band).
static void add_level_set_block(openvdb::FloatGrid& level_set,
    const grid_data& grid, const std::vector<uint8_t>& band, vec3i start) {
  auto  background = level_set.background();
  auto  size       = (int)openvdb::FloatTree::LeafNodeType::DIM;
  auto& d          = grid.dims;
  auto end = vec3i{std::min(start.x + size, d.x), std::min(start.y + size, d.y),
      std::min(start.z + size, d.z)};
  auto index = [&](int i, int j, int k) {
    return (size_t)i + (size_t)d.x * ((size_t)j + (size_t)d.y * k);
  };
  auto active = false;
  for (auto k = start.z; k < end.z; k++)
    for (auto j = start.y; j < end.y; j++)
      for (auto i = start.x; i < end.x; i++) active |= band[index(i, j, k)];
  if (!active) {
    if (grid.values[index(start.x, start.y, start.z)] < 0)
      level_set.tree().addTile(
          1, openvdb::Coord(start.x, start.y, start.z), -background, false);
    return;
  }
  auto leaf =
      level_set.tree().touchLeaf(openvdb::Coord(start.x, start.y, start.z));
  for (auto k = start.z; k < end.z; k++) {
    for (auto j = start.y; j < end.y; j++) {
      for (auto i = start.x; i < end.x; i++) {
        auto n   = index(i, j, k);
        auto v   = grid.values[n];
        auto ijk = openvdb::Coord(i, j, k);
        if (band[n]) {
          leaf->setValueOn(ijk, v);
        } else {
          leaf->setValueOff(ijk, v < 0 ? -background : background);
        }
      }
    }
  }
}

void save_vdb_grid(const std::string& filename, const grid_data& grid) {
  init_openvdb();
  auto level_set = openvdb::FloatGrid::create(vdb_half_width * grid.spacing);
  level_set->setName("sdf");
  level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  auto transform =
      openvdb::math::Transform::createLinearTransform(grid.spacing);
  transform->postTranslate(
      openvdb::Vec3d(grid.origin.x, grid.origin.y, grid.origin.z));
  level_set->setTransform(transform);
  auto band = level_set_band(grid, level_set->background());
  auto size = (int)openvdb::FloatTree::LeafNodeType::DIM;
  for (auto k = 0; k < grid.dims.z; k += size)
    for (auto j = 0; j < grid.dims.y; j += size)
      for (auto i = 0; i < grid.dims.x; i += size)
        add_level_set_block(*level_set, grid, band, {i, j, k});
  openvdb::tools::pruneLevelSet(level_set->tree());
  // OpenVDB writes by name: the whole file goes to the temporary of the
  // file layer, renamed only when complete.
  auto out = output_file{filename};
  try {
    auto file = openvdb::io::File(out.temporary);
    file.write({level_set});
    file.close();
  } catch (const std::exception& error) {
    throw_io_error(
        filename, std::string("cannot write (") + error.what() + ")");
  }
  commit_file(out);
}

}  // namespace implicit
