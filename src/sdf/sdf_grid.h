// # implicit: SDF grids
//
// A signed distance grid: samples on a regular lattice, trilinearly
// interpolated. Grid space puts sample (i,j,k) at spacing*(i,j,k), so the
// first sample is the origin and the grid's box is [0, spacing*(dims-1)].
// Outside that box the distance is the distance to the box (plus the value
// at the closest boundary point when it is positive).
#pragma once

#include <cstdint>
#include <vector>

#include "../math/math.h"

namespace implicit {

// -----------------------------------------------------------------------------
// GRID DATA
// -----------------------------------------------------------------------------

// Samples x fastest: value(i,j,k) = values[i + dims.x*(j + dims.y*k)].
struct grid_data {
  vec3i              dims    = {0, 0, 0};
  float              spacing = 1;          // distance between samples
  vec3f              origin  = {0, 0, 0};  // file origin, informational only
  std::vector<float> values  = {};
};

// Sample value at integer coordinates (no bounds check beyond asserts).
inline float grid_value(const grid_data& grid, int i, int j, int k) {
  return grid.values[(size_t)i +
                     (size_t)grid.dims.x * ((size_t)j + (size_t)grid.dims.y * k)];
}

// Box of the grid in grid space: [0, spacing*(dims-1)].
bbox3f grid_bounds(const grid_data& grid);

// Trilinear interpolant at a grid-space point; outside the box, the distance
// to the box plus the interpolant at the closest box point.
float eval_grid(const grid_data& grid, vec3f p);

// Gradient of the trilinear interpolant at a grid-space point (normalized).
vec3f eval_grid_gradient(const grid_data& grid, vec3f p);

// First hit of the trilinear interpolant's zero set along a grid-space ray in
// [ray.tmin, ray.tmax]. `steps` counts the work done (voxels or evaluations).
bool intersect_grid(const grid_data& grid, const ray3f& ray, float& t, int& steps);

}  // namespace implicit
