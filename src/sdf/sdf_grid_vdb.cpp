// # implicit: SDF grid files: OpenVDB level sets
//
// A .vdb file is sparse; we densify the first float level set over its
// active voxels' bounding box (for a level set that is the narrow band, so
// the box already holds the surface with a positive border). Voxels without
// an active value read the tree's tile or background value, which OpenVDB
// keeps signed for level sets (-background inside, +background outside).

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

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

grid_data load_vdb_grid(const std::string& filename) {
  init_openvdb();
  // Read through a stream that throws on a short read: io::File ignores
  // them, so a truncated file would load with garbage voxels. Without
  // delayed loading, since that copies the stream to a temporary file.
  // OpenVDB trusts the length fields it reads, so it only gets the bytes
  // that check_vdb_file() has walked.
  auto file    = mapped_file{filename};
  auto checked = check_vdb_file(filename, file.data, file.size);
  auto grids   = openvdb::GridPtrVecPtr{};
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
  auto level_set = openvdb::FloatGrid::Ptr{};
  auto found     = std::string{};
  for (auto& base : *grids) {
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
  auto name    = "grid '" + level_set->getName() + "': ";
  auto spacing = uniform_voxel_size(level_set->transform());
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
  assign_huge(grid.values, (size_t)grid_samples(grid.dims), 0.0f);
  auto accessor = level_set->getConstAccessor();
  auto index    = size_t{0};
  for (auto k = 0; k < grid.dims.z; k++) {
    for (auto j = 0; j < grid.dims.y; j++) {
      for (auto i = 0; i < grid.dims.x; i++) {
        auto v = accessor.getValue(lo.offsetBy(i, j, k));
        if (!std::isfinite(v))
          throw_io_error(
              filename, name + "voxel (" + std::to_string(lo.x() + i) + "," +
                            std::to_string(lo.y() + j) + "," +
                            std::to_string(lo.z() + k) + ") is not finite");
        grid.values[index++] = v;
      }
    }
  }
  return grid;
}

void save_vdb_grid(const std::string& filename, const grid_data& grid) {
  init_openvdb();
  // Every sample becomes an active voxel, so that the file reads back to
  // the same dense grid; voxels beyond it read +3 voxels (the usual
  // level-set half width), which is outside.
  auto level_set = openvdb::FloatGrid::create(3 * grid.spacing);
  level_set->setName("sdf");
  level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  auto transform =
      openvdb::math::Transform::createLinearTransform(grid.spacing);
  transform->postTranslate(
      openvdb::Vec3d(grid.origin.x, grid.origin.y, grid.origin.z));
  level_set->setTransform(transform);
  auto accessor = level_set->getAccessor();
  auto index    = size_t{0};
  for (auto k = 0; k < grid.dims.z; k++) {
    for (auto j = 0; j < grid.dims.y; j++) {
      for (auto i = 0; i < grid.dims.x; i++) {
        accessor.setValueOn(openvdb::Coord(i, j, k), grid.values[index++]);
      }
    }
  }
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
