// # implicit: triangle meshes <-> SDF grids
//
// Conversions for the `ysdf` tool, both through OpenVDB: meshToVolume for
// mesh -> grid (so users need neither SDFGen nor a CUDA tool) and
// volumeToMesh for grid -> mesh. Meshes live in the same world units as the
// grid's file origin and spacing.
#pragma once

#include <vector>

#include "../math/math.h"
#include "sdf_grid.h"

namespace implicit {

// -----------------------------------------------------------------------------
// MESH DATA
// -----------------------------------------------------------------------------

// An indexed triangle mesh; triangles are counter-clockwise seen from outside.
struct mesh_data {
  std::vector<vec3f> positions = {};
  std::vector<vec3i> triangles = {};
};

// Bounding box of the positions used by triangles.
bbox3f mesh_bounds(const mesh_data& mesh);

// Signed volume (positive for a closed mesh oriented outwards).
double mesh_volume(const mesh_data& mesh);

// -----------------------------------------------------------------------------
// CONVERSIONS
// -----------------------------------------------------------------------------

// Signed distance grid of a closed mesh: samples every `voxel` on the
// lattice voxel*(i,j,k) of world space, covering the mesh's bounds plus
// `padding` voxels; the grid's origin is its first sample. Distances are
// exact within 3 voxels of the surface (OpenVDB meshToSignedDistanceField);
// farther samples get a lower bound, about 2 voxels short, from an exact
// Euclidean distance transform to the band (so sphere tracing stays safe).
// The sign of a non-closed mesh is undefined: OpenVDB floods the outside in
// through the holes, so the solid shrinks or vanishes; when no sample ends
// up clearly inside (below -0.001 voxel), this throws an io_error that says
// so. With `shell` > 0 the grid is instead the unsigned distance minus
// `shell`: a closed shell of that half thickness around any mesh, open or
// not.
grid_data mesh_to_grid(
    const mesh_data& mesh, float voxel, int padding, float shell = 0);

// Triangle mesh of the grid's surface (OpenVDB volumeToMesh at iso 0), in
// world units (origin + spacing*(i,j,k)). The grid's box closes the surface
// where the interpolant is negative on it, as in tracing; triangles face
// outwards.
mesh_data grid_to_mesh(const grid_data& grid);

}  // namespace implicit
