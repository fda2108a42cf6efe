// # implicit: triangle meshes <-> SDF grids (implementation, OpenVDB)

#include "sdf_mesh.h"

#include <algorithm>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "../util/error.h"
#include "sdf_grid_file.h"

namespace implicit {

// -----------------------------------------------------------------------------
// MESH DATA
// -----------------------------------------------------------------------------

bbox3f mesh_bounds(const mesh_data& mesh) {
  auto bounds = bbox3f{};
  for (auto& t : mesh.triangles) {
    bounds = merge(bounds, mesh.positions[t.x]);
    bounds = merge(bounds, mesh.positions[t.y]);
    bounds = merge(bounds, mesh.positions[t.z]);
  }
  return bounds;
}

double mesh_volume(const mesh_data& mesh) {
  // Sum of signed tetrahedra against the origin (divergence theorem).
  auto volume = 0.0;
  for (auto& t : mesh.triangles) {
    auto a = mesh.positions[t.x], b = mesh.positions[t.y],
         c = mesh.positions[t.z];
    volume += (double)dot(a, cross(b, c));
  }
  return volume / 6;
}

// -----------------------------------------------------------------------------
// CONVERSIONS
// -----------------------------------------------------------------------------

// Half width, in voxels, of the exact band of mesh_to_grid().
static constexpr int grid_mesh_band = 3;

// One line of the exact squared Euclidean distance transform of sampled
// functions (Felzenszwalb & Huttenlocher, Theory of Computing 8, 2012):
// d[q] = min_p (q - p)^2 + f[p]. v, z are work arrays of n and n+1.
static void distance_transform_line(
    const double* f, int n, double* d, int* v, double* z) {
  auto k = 0;
  v[0]   = 0;
  z[0]   = -1e300;
  z[1]   = 1e300;
  for (auto q = 1; q < n; q++) {
    // Drop the parabolas the new one hides; z[0] is below any s.
    auto s = 0.0;
    for (;;) {
      auto p = v[k];
      s = ((f[q] + (double)q * q) - (f[p] + (double)p * p)) / (2.0 * (q - p));
      if (s > z[k]) break;
      k--;
    }
    k++;
    v[k]     = q;
    z[k]     = s;
    z[k + 1] = 1e300;
  }
  k = 0;
  for (auto q = 0; q < n; q++) {
    while (z[k + 1] < q) k++;
    d[q] = (double)(q - v[k]) * (q - v[k]) + f[v[k]];
  }
}

// In place: 0 at seeds, anything else becomes the squared distance in
// voxels to the nearest seed (three separable passes).
static void distance_transform(std::vector<float>& values, vec3i n) {
  // A finite "infinity" keeps the parabola intersections exact in double.
  auto infinity =
      16.0 * ((double)n.x * n.x + (double)n.y * n.y + (double)n.z * n.z);
  int stride[3] = {1, n.x, n.x * n.y};
  int length[3] = {n.x, n.y, n.z};
  for (auto axis = 0; axis < 3; axis++) {
    auto lines = (int)(values.size() / (size_t)length[axis]);
    tbb::parallel_for(tbb::blocked_range<int>(0, lines),
        [&](const tbb::blocked_range<int>& range) {
          auto m = length[axis];
          auto f = std::vector<double>(m), d = std::vector<double>(m),
               z = std::vector<double>(m + 1);
          auto v = std::vector<int>(m);
          for (auto line = range.begin(); line != range.end(); line++) {
            // The line's first sample: the other two coordinates.
            auto start = size_t{0};
            if (axis == 0) start = (size_t)line * n.x;
            if (axis == 1)
              start = (size_t)(line % n.x) + (size_t)(line / n.x) * n.x * n.y;
            if (axis == 2) start = (size_t)line;
            for (auto q = 0; q < m; q++) {
              auto value = values[start + (size_t)q * stride[axis]];
              f[q]       = value == flt_max ? infinity : value;
            }
            distance_transform_line(f.data(), m, d.data(), v.data(), z.data());
            for (auto q = 0; q < m; q++)
              values[start + (size_t)q * stride[axis]] =
                  (float)std::min(d[q], infinity);
          }
        });
  }
}

// The grid of the lattice voxel * (i, j, k) around the mesh's bounds, plus
// padding, and the OpenVDB coordinate of its first sample. Counts in double
// so that a tiny voxel is refused instead of overflowing.
static grid_data make_mesh_grid(const mesh_data& mesh, float voxel, int padding,
    openvdb::Coord& min_coord) {
  auto bounds = mesh_bounds(mesh);
  if (!is_finite(bounds)) throw io_error("mesh: positions are not finite");
  double lo[3], hi[3];
  for (auto a = 0; a < 3; a++) {
    lo[a] = std::floor((double)at(bounds.min, a) / voxel) - padding;
    hi[a] = std::ceil((double)at(bounds.max, a) / voxel) + padding;
    if (std::abs(lo[a]) > 1e9 || std::abs(hi[a]) > 1e9)
      throw io_error("mesh: the mesh is too large for voxel size " +
                     std::to_string(voxel));
  }
  auto error = check_grid_dims((int64_t)(hi[0] - lo[0] + 1),
      (int64_t)(hi[1] - lo[1] + 1), (int64_t)(hi[2] - lo[2] + 1));
  if (!error.empty()) throw io_error("mesh: " + error);
  min_coord = openvdb::Coord((int)lo[0], (int)lo[1], (int)lo[2]);
  return make_grid({(int)(hi[0] - lo[0] + 1), (int)(hi[1] - lo[1] + 1),
                       (int)(hi[2] - lo[2] + 1)},
      voxel, vec3f{(float)lo[0], (float)lo[1], (float)lo[2]} * voxel, 0);
}

// OpenVDB's narrow-band distance field of the mesh (unsigned for a shell).
// Exact distances in a narrow band only: OpenVDB grows the band in every
// direction, not just inside our box, so a band as wide as the grid costs
// minutes; the far samples get a distance bound (mesh_to_grid).
static openvdb::FloatGrid::Ptr make_mesh_level_set(
    const mesh_data& mesh, float voxel, bool shell) {
  init_openvdb();
  auto points = std::vector<openvdb::Vec3s>{};
  points.reserve(mesh.positions.size());
  for (auto& p : mesh.positions) points.emplace_back(p.x, p.y, p.z);
  auto triangles = std::vector<openvdb::Vec3I>{};
  triangles.reserve(mesh.triangles.size());
  for (auto& t : mesh.triangles)
    triangles.emplace_back((unsigned)t.x, (unsigned)t.y, (unsigned)t.z);
  auto quads     = std::vector<openvdb::Vec4I>{};
  auto transform = openvdb::math::Transform::createLinearTransform(voxel);
  auto band      = (float)grid_mesh_band;
  try {
    if (shell)
      return openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(
          *transform, points, triangles, quads, band);
    return openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
        *transform, points, triangles, quads, band, band);
  } catch (const std::exception& e) {
    throw io_error(std::string("mesh: OpenVDB conversion failed: ") + e.what());
  }
}

// Copy the level set into the grid, one z slice per task (each with its own
// accessor). Active voxels are the band; the others hold +-background with
// the right sign. Returns, per sample, 0 in the band and flt_max outside.
static std::vector<float> densify_level_set(const openvdb::FloatGrid& level_set,
    openvdb::Coord min_coord, grid_data& grid) {
  auto& n   = grid.dims;
  auto  far = std::vector<float>(grid.values.size(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, n.z),
      [&](const tbb::blocked_range<int>& slices) {
        auto accessor = level_set.getConstAccessor();
        for (auto k = slices.begin(); k != slices.end(); k++) {
          auto index = (size_t)n.x * (size_t)n.y * (size_t)k;
          for (auto j = 0; j < n.y; j++) {
            for (auto i = 0; i < n.x; i++, index++) {
              auto ijk           = min_coord.offsetBy(i, j, k);
              grid.values[index] = accessor.getValue(ijk);
              far[index]         = accessor.isValueOn(ijk) ? 0 : flt_max;
            }
          }
        }
      });
  return far;
}

grid_data mesh_to_grid(
    const mesh_data& mesh, float voxel, int padding, float shell) {
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw io_error("mesh: voxel size " + std::to_string(voxel) +
                   " must be positive and finite");
  if (padding < 1) throw io_error("mesh: padding must be at least 1 voxel");
  if (mesh.triangles.empty()) throw io_error("mesh: no triangles");
  auto min_coord = openvdb::Coord{};
  auto grid      = make_mesh_grid(mesh, voxel, padding, min_coord);
  auto level_set = make_mesh_level_set(mesh, voxel, shell > 0);
  // Squared voxels to the band.
  auto far = densify_level_set(*level_set, min_coord, grid);
  distance_transform(far, grid.dims);
  // Outside the band a lower bound: every sample with |d| < w is active
  // (OpenVDB keeps about w = band - 0.2 voxels; we assume band - 1). For p
  // outside, s its closest surface point and q on [p, s] with
  // |d(q)| = l < w - sqrt(3)/2 voxels, the sample c nearest to q is active,
  // so EDT(p) <= |p - c| <= |p - q| + sqrt(3)/2 = |d(p)| - l + sqrt(3)/2:
  // |d(p)| >= EDT(p) + w - sqrt(3) voxels (and >= w, being inactive).
  auto width = ((float)grid_mesh_band - 1) * voxel;
  for (auto i = size_t{0}; i < far.size(); i++) {
    if (far[i] == 0) {
      grid.values[i] -= shell;
      continue;
    }
    auto bound = width + std::max(0.0f, std::sqrt(far[i]) - 1.7320508f) * voxel;
    grid.values[i] = std::copysign(bound, grid.values[i]) - shell;
  }
  update_grid_accel(grid);
  if (shell <= 0) {
    // Samples lying on the faces of an open mesh come out as -1e-7: only a
    // sample clearly below zero shows an inside.
    auto inside = std::any_of(grid.values.begin(), grid.values.end(),
        [&](float v) { return v < -1e-3f * voxel; });
    if (!inside)
      throw io_error(
          "mesh: no sample is inside: the mesh is not closed (its holes let "
          "the outside in); use a shell thickness to make a closed shell");
  }
  return grid;
}

mesh_data grid_to_mesh(const grid_data& grid) {
  auto error = check_grid_dims(grid.dims.x, grid.dims.y, grid.dims.z);
  if (!error.empty()) throw io_error("grid: " + error);
  init_openvdb();
  // Voxels outside the grid read a huge positive background, so the
  // crossing between a negative boundary sample and the outside sits on
  // the box face: the box closes the surface as in tracing.
  auto outside = 1e6f * grid.spacing;
  auto vdb     = openvdb::FloatGrid::create(outside);
  auto transform =
      openvdb::math::Transform::createLinearTransform(grid.spacing);
  transform->postTranslate(
      openvdb::Vec3d(grid.origin.x, grid.origin.y, grid.origin.z));
  vdb->setTransform(transform);
  auto box   = openvdb::CoordBBox(openvdb::Coord(0, 0, 0),
        openvdb::Coord(grid.dims.x - 1, grid.dims.y - 1, grid.dims.z - 1));
  auto dense = openvdb::tools::Dense<const float, openvdb::tools::LayoutXYZ>(
      box, grid.values.data());
  openvdb::tools::copyFromDense(dense, *vdb, 0.0f);

  auto points    = std::vector<openvdb::Vec3s>{};
  auto triangles = std::vector<openvdb::Vec3I>{};
  auto quads     = std::vector<openvdb::Vec4I>{};
  try {
    openvdb::tools::volumeToMesh(*vdb, points, triangles, quads, 0.0, 0.0);
  } catch (const std::exception& e) {
    throw io_error(std::string("grid: OpenVDB meshing failed: ") + e.what());
  }
  auto mesh = mesh_data{};
  mesh.positions.reserve(points.size());
  for (auto& p : points) mesh.positions.push_back({p.x(), p.y(), p.z()});
  mesh.triangles.reserve(triangles.size() + 2 * quads.size());
  for (auto& t : triangles)
    mesh.triangles.push_back({(int)t[0], (int)t[1], (int)t[2]});
  for (auto& q : quads) {
    mesh.triangles.push_back({(int)q[0], (int)q[1], (int)q[2]});
    mesh.triangles.push_back({(int)q[0], (int)q[2], (int)q[3]});
  }
  // Face outwards whatever OpenVDB's winding convention is.
  if (mesh_volume(mesh) < 0) {
    for (auto& t : mesh.triangles) std::swap(t.y, t.z);
  }
  return mesh;
}

}  // namespace implicit
