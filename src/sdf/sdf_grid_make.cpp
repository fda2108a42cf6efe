// # implicit: SDF grids: statistics and baking of analytic SDFs

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>

#include "../util/error.h"
#include "sdf_field.h"
#include "sdf_grid.h"

namespace implicit {

// -----------------------------------------------------------------------------
// STATISTICS
// -----------------------------------------------------------------------------

grid_stats compute_grid_stats(const grid_data& grid) {
  auto stats = grid_stats{};
  if (grid.values.empty()) return stats;
  stats.min = flt_max;
  stats.max = flt_lowest;
  for (auto v : grid.values) {
    stats.min = std::min(stats.min, v);
    stats.max = std::max(stats.max, v);
    if (v < 0) stats.negative_samples++;
  }
  auto& n = grid.dims;
  if ((int64_t)grid.values.size() != grid_samples(n)) return stats;
  for (auto k = 0; k < n.z; k++) {
    for (auto j = 0; j < n.y; j++) {
      for (auto i = 0; i < n.x; i++) {
        auto on_box = i == 0 || j == 0 || k == 0 || i == n.x - 1 ||
                      j == n.y - 1 || k == n.z - 1;
        if (on_box && grid_value(grid, i, j, k) < 0) stats.negative_boundary++;
        if (i == n.x - 1 || j == n.y - 1 || k == n.z - 1) continue;
        auto negative = 0;
        for (auto c = 0; c < 8; c++) {
          negative += grid_value(grid, i + (c & 1), j + ((c >> 1) & 1),
                          k + ((c >> 2) & 1)) < 0;
        }
        if (negative != 0 && negative != 8) stats.surface_voxels++;
      }
    }
  }
  return stats;
}

// -----------------------------------------------------------------------------
// BAKING
// -----------------------------------------------------------------------------

grid_data bake_grid(const sdf_program& program, const frame3f& local_from_world,
    const bbox3f& bounds_world, float spacing,
    const std::function<void(int, int)>& progress) {
  if (program.nodes.empty()) throw io_error("bake: the SDF program is empty");
  if (!(spacing > 0) || !std::isfinite(spacing))
    throw io_error("bake: voxel size " + std::to_string(spacing) +
                   " must be positive and finite");
  if (is_empty(bounds_world) || !is_finite(bounds_world))
    throw io_error(
        "bake: the bounds are empty or infinite (an unbounded SDF such as a "
        "plane needs explicit bounds)");
  if (!is_invertible(local_from_world))
    throw io_error("bake: the frame is singular");
  // Whole voxels covering the bounds (within 1e-4 voxel, so that an extent
  // that is a multiple of the spacing up to rounding gets no extra sample);
  // counts in double so that a tiny voxel size is refused, not overflowed.
  auto extent = size(bounds_world);
  auto count  = [&](float e) {
    return (int64_t)std::min(std::ceil((double)e / spacing - 1e-4) + 1, 1e12);
  };
  auto nx    = std::max(count(extent.x), int64_t{2});
  auto ny    = std::max(count(extent.y), int64_t{2});
  auto nz    = std::max(count(extent.z), int64_t{2});
  auto error = check_grid_dims(nx, ny, nz);
  if (!error.empty()) throw io_error("bake: " + error);
  auto grid =
      make_grid({(int)nx, (int)ny, (int)nz}, spacing, bounds_world.min, 0);

  // A map that stretches by s scales distances by s: divide it out.
  auto scale = 1 / max_stretch(local_from_world);
  // The program pruned over the sampled box (samples reach one voxel past
  // the bounds), so each sample evaluates only the operands near it, also
  // far from the surface.
  auto params           = sdf_field_params{};
  params.split_one_side = true;
  auto sampled =
      transform_bbox(local_from_world, expand(bounds_world, 2 * spacing));
  auto  field = make_sdf_field(program, sampled, params);
  auto  bad   = std::atomic<bool>{false};
  auto& n     = grid.dims;
  auto  chunk = std::max(1, n.z / 64);
  for (auto k0 = 0; k0 < n.z; k0 += chunk) {
    auto k1 = std::min(k0 + chunk, n.z);
    tbb::parallel_for(tbb::blocked_range<int>(k0 * n.y, k1 * n.y),
        [&](const tbb::blocked_range<int>& rows) {
          for (auto row = rows.begin(); row != rows.end(); row++) {
            auto j = row % n.y, k = row / n.y;
            auto base = (size_t)n.x * ((size_t)j + (size_t)n.y * k);
            for (auto i = 0; i < n.x; i++) {
              auto p = bounds_world.min +
                       vec3f{(float)i, (float)j, (float)k} * spacing;
              auto v =
                  eval_sdf(field, transform_point(local_from_world, p)) * scale;
              if (!std::isfinite(v)) bad = true;
              grid.values[base + i] = v;
            }
          }
        });
    if (bad)
      throw io_error("bake: the SDF is not finite somewhere in the bounds");
    if (progress) progress(k1, n.z);
  }
  update_grid_accel(grid);
  return grid;
}

}  // namespace implicit
