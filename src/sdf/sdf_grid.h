// # implicit: SDF grids
//
// A signed distance grid: samples on a regular lattice, trilinearly
// interpolated. Grid space puts sample (i,j,k) at spacing*(i,j,k), so the
// first sample is the origin and the grid's box is [0, spacing*(dims-1)].
// Negative values are inside.
//
// The surface is the zero set of the trilinear interpolant closed by the
// grid's box: the solid is {interpolant < 0} intersected with the box, so
// where the interpolant is negative on the boundary (SDFGen clips the + side
// when the padding is small) the box face is the surface.
//
// Outside the box, eval_grid() returns sqrt(|p-q|^2 + max(f(q),0)^2), q the
// closest box point: a valid lower bound of the distance to the solid, since
// for a convex set |p-s|^2 >= |p-q|^2 + |q-s|^2 for every s in it.
//
// Intersection is exact: the first root of the cubic that the interpolant
// makes along the ray inside each candidate voxel, found by a 3D-DDA that
// jumps over empty space: each block of 2^3 voxels stores its chessboard
// distance to the nearest block with a voxel whose corners change sign, so
// the walk leaves a whole cube of empty blocks in one step; in the other
// blocks a bit per voxel skips those that can not hold a crossing, without
// fetching their corners.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "../math/math.h"
#include "sdf_program.h"

namespace implicit {

// -----------------------------------------------------------------------------
// GRID DATA
// -----------------------------------------------------------------------------

// Largest empty-space distance kept per block (4 bits each way).
inline constexpr int grid_skip_max = 15;

// Memory budget of one grid: 2^31 samples (8 GiB of float32). Loaders refuse
// larger grids before allocating anything.
inline constexpr int64_t grid_max_samples = int64_t{1} << 31;

// Samples x fastest: value(i,j,k) = values[i + dims.x*(j + dims.y*k)].
// The skip distances are made by update_grid_accel(), which every loader and
// maker calls; tracing asserts it is current.
struct grid_data {
  vec3i              dims    = {0, 0, 0};
  float              spacing = 1;          // distance between samples
  vec3f              origin  = {0, 0, 0};  // sample (0,0,0) in file space
  std::vector<float> values  = {};

  // How a scene places the grid. The seed's rule, for .sdf (and .vol): the
  // first sample is the instance's local origin, so `origin` is only
  // informational. A .vdb is placed by its own index-to-world transform,
  // as Blender and Houdini place it: sample (i,j,k) sits at
  // origin + spacing*(i,j,k) in the instance's local space.
  bool placed_by_file = false;
  // Of a level set file (.vdb): its active voxels and its background, the
  // half width of the narrow band in world units (outside the band the
  // samples hold +-background, a bound of the distance); -1 and 0 for the
  // dense formats.
  int64_t file_active_voxels = -1;
  float   file_background    = 0;

  // Acceleration data (update_grid_accel), over blocks of 2x2x2 voxels (x
  // fastest, dims/2 blocks per axis; voxels past the box count as empty).
  // voxel_masks: bit x + 2y + 4z marks the block's voxels with a corner < 0
  // (a ray outside the solid may cross there), bit 8 + x + 2y + 4z those
  // with a corner >= 0 (a ray inside may leave there). block_skips: the
  // chessboard distance, in blocks, to the nearest block with a bit of the
  // first kind (low 4 bits) and of the second (high 4 bits), capped at
  // grid_skip_max. A distance d > 0 lets a ray skip the cube of blocks
  // within d-1 steps of its own without fetching a sample. Both fit in
  // cache next to the samples (3 bytes per 8 voxels).
  std::vector<uint8_t>  block_skips = {};
  std::vector<uint16_t> voxel_masks = {};
  // Box (grid space) of the voxels with a corner < 0, which holds the whole
  // solid; invalid_bbox when there is none. Rays are clipped to it.
  bbox3f solid_bounds = invalid_bbox;
};

// Sample value at integer coordinates (no bounds check beyond asserts).
inline float grid_value(const grid_data& grid, int i, int j, int k) {
  return grid.values[(size_t)i + (size_t)grid.dims.x *
                                     ((size_t)j + (size_t)grid.dims.y * k)];
}

// Number of samples as a 64-bit count.
inline int64_t grid_samples(vec3i dims) {
  return (int64_t)dims.x * (int64_t)dims.y * (int64_t)dims.z;
}

// Why `dims` can not make a grid (each axis in [2, 2^31), product within
// grid_max_samples), or an empty string when it can.
std::string check_grid_dims(int64_t nx, int64_t ny, int64_t nz);

// Build the acceleration data; call after changing dims or values.
void update_grid_accel(grid_data& grid);
// Whether the acceleration data matches the grid's dims.
bool has_grid_accel(const grid_data& grid);

// A grid of `dims` samples, all `value`, with its acceleration data.
grid_data make_grid(vec3i dims, float spacing, vec3f origin, float value);

// Where grid space's origin sits in the instance's local space: `origin`
// for grids placed by their file, else (0,0,0).
inline vec3f grid_placement(const grid_data& grid) {
  return grid.placed_by_file ? grid.origin : vec3f{0, 0, 0};
}

// Box of the grid in grid space: [0, spacing*(dims-1)].
bbox3f grid_bounds(const grid_data& grid);
// Box that holds the grid's solid (update_grid_accel's solid_bounds), for
// culling; the grid's box while the acceleration data is missing.
bbox3f grid_solid_bounds(const grid_data& grid);

// Bytes used by a grid (samples and acceleration data).
size_t grid_memory(const grid_data& grid);

// -----------------------------------------------------------------------------
// EVALUATION (never throws, never allocates)
// -----------------------------------------------------------------------------

// Trilinear interpolant inside the box; outside, the lower bound
// sqrt(|p-q|^2 + max(f(q),0)^2) with q the closest box point.
float eval_grid(const grid_data& grid, vec3f p);

// Normal at a surface point: the normalized gradient of the trilinear
// interpolant in the voxel that holds p; at a hit on the box (p on a face,
// interpolant negative there) the face's outward normal.
vec3f eval_grid_gradient(const grid_data& grid, vec3f p);

// Normal that is continuous across voxels: the trilinear interpolation of
// central-difference gradients at the 8 surrounding samples (the "gradient
// volume" of Höhne & Bernstein 1986 and Levoy 1988), normalized; box faces
// as in eval_grid_gradient().
vec3f eval_grid_gradient_smooth(const grid_data& grid, vec3f p);

// First crossing of the surface along a grid-space ray in
// [ray.tmin, ray.tmax] (the direction need not be unit length; t keeps its
// meaning). A ray that starts inside the solid stops where it leaves it: the
// interpolant crossing zero or the box exit. `steps` counts the DDA steps
// (each empty cube skipped once, each voxel that may hold a crossing once).
bool intersect_grid(
    const grid_data& grid, const ray3f& ray, float& t, int& steps);

// -----------------------------------------------------------------------------
// STATISTICS AND BAKING
// -----------------------------------------------------------------------------

// Summary of a grid's values.
struct grid_stats {
  float   min               = 0;
  float   max               = 0;
  int64_t negative_samples  = 0;  // samples < 0
  int64_t surface_voxels    = 0;  // voxels with corners < 0 and >= 0
  int64_t negative_boundary = 0;  // samples < 0 on the box (closed by it)
};

// Value range and zero-crossing counts.
grid_stats compute_grid_stats(const grid_data& grid);

// Sample an SDF program on a grid: sample (i,j,k) is at
// bounds_world.min + spacing*(i,j,k) in world space and holds
// eval_sdf(make_sdf_tape(program), local_from_world * p) divided by the largest
// stretch of local_from_world, so values stay distances (bounds) in world
// units. The grid covers bounds_world (rounded up to whole voxels); `progress`,
// when set, is called from the calling thread with (slices done, slices total).
// Throws io_error for empty or infinite bounds, a bad spacing or a grid over
// budget.
grid_data bake_grid(const sdf_program& program, const frame3f& local_from_world,
    const bbox3f& bounds_world, float spacing,
    const std::function<void(int, int)>& progress = {});

}  // namespace implicit
