// Level sets as OpenVDB writes them: files made by OpenVDB itself load and
// trace exactly and are placed by their own transform; the files we write
// are narrow bands that keep the surface.

#include <doctest/doctest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetSphere.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "math/random.h"
#include "math/sampling.h"
#include "sdf/sdf_grid.h"
#include "sdf/sdf_grid_io.h"
#include "sdf/sdf_program.h"
#include "trace/accel.h"
#include "util/file.h"

using namespace implicit;

namespace {

// A scratch file of this test.
std::string vdb_test_path(const std::string& name) {
  auto dir = std::filesystem::path{IMPLICIT_BINARY_DIR} / "vdb_level_set";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// OpenVDB's own narrow-band sphere (half width 3 voxels), written by
// OpenVDB's own writer.
openvdb::FloatGrid::Ptr write_openvdb_sphere(const std::string& filename,
    float radius, openvdb::Vec3f center, float voxel) {
  openvdb::initialize();
  auto sphere = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
      radius, center, voxel, 3.0f);
  sphere->setName("ls_sphere");
  auto file = openvdb::io::File(filename);
  file.write({sphere});
  file.close();
  return sphere;
}

// A scene with one grid instance; `frame` is the seed's local_from_world.
scene_data grid_scene(
    const grid_data& grid, float scale, const frame3f& local_from_world) {
  auto scene = scene_data{};
  scene.materials.push_back({});
  auto volume = volume_data{};
  volume.grid = std::make_shared<const grid_data>(grid);
  scene.volumes.push_back(volume);
  auto instance             = vol_instance_data{};
  instance.volume           = 0;
  instance.material         = 0;
  instance.scale            = scale;
  instance.local_from_world = local_from_world;
  scene.vol_instances.push_back(instance);
  return scene;
}

// Rays from far away toward random points near `center`: all hit the sphere
// of `radius` there, within `tolerance`; rays that pass it by 10% miss.
void check_traced_sphere(
    const accel_data& accel, vec3f center, float radius, float tolerance) {
  auto rng   = make_rng(7);
  auto worst = 0.0f;
  auto holes = 0, false_hits = 0;
  for (auto n = 0; n < 400; n++) {
    auto dir    = sample_sphere(rand2f(rng));
    auto origin = center + dir * (6 * radius);
    auto target = center + sample_sphere(rand2f(rng)) * (0.6f * radius);
    auto ray    = ray3f{origin, normalize(target - origin)};
    auto isec   = intersect_scene(accel, {}, ray);
    if (!isec.hit) {
      holes++;
      continue;
    }
    auto p = ray_point(ray, isec.distance);
    worst  = std::max(worst, std::abs(distance(p, center) - radius));
    // Parallel to it, 1.1 radii from the centre: no hit.
    auto side = normalize(cross(ray.d, sample_sphere(rand2f(rng))));
    auto miss =
        ray3f{center + side * (1.1f * radius) - ray.d * (6 * radius), ray.d};
    false_hits += intersect_scene(accel, {}, miss).hit;
  }
  CHECK(holes == 0);
  CHECK(false_hits == 0);
  CHECK(worst < tolerance);
}

// The index shift from `original`'s samples to `loaded`'s (the loaded
// box starts at the band's first sample).
vec3i sample_shift(const grid_data& original, const grid_data& loaded) {
  auto shift = (loaded.origin - original.origin) / original.spacing;
  return {(int)std::round(shift.x), (int)std::round(shift.y),
      (int)std::round(shift.z)};
}

// Whether sample (i,j,k) is a corner of a voxel whose corners change sign.
bool on_surface_voxel(const grid_data& grid, int i, int j, int k) {
  for (auto c = 0; c < 8; c++) {
    auto i0 = i - (c & 1), j0 = j - ((c >> 1) & 1), k0 = k - (c >> 2);
    if (i0 < 0 || j0 < 0 || k0 < 0 || i0 + 1 >= grid.dims.x ||
        j0 + 1 >= grid.dims.y || k0 + 1 >= grid.dims.z)
      continue;
    auto negative = 0;
    for (auto q = 0; q < 8; q++)
      negative += grid_value(grid, i0 + (q & 1), j0 + ((q >> 1) & 1),
                      k0 + (q >> 2)) < 0;
    if (negative != 0 && negative != 8) return true;
  }
  return false;
}

// The loaded narrow band has the original's surface: every sample keeps its
// sign, the corners of surface voxels their value, and samples past the
// loaded box are outside and off the surface.
void check_same_surface(const grid_data& original, const grid_data& loaded) {
  auto shift      = sample_shift(original, loaded);
  auto wrong_sign = 0, wrong_value = 0, lost = 0;
  for (auto k = 0; k < original.dims.z; k++) {
    for (auto j = 0; j < original.dims.y; j++) {
      for (auto i = 0; i < original.dims.x; i++) {
        auto v       = grid_value(original, i, j, k);
        auto surface = on_surface_voxel(original, i, j, k);
        auto l       = vec3i{i - shift.x, j - shift.y, k - shift.z};
        if (l.x < 0 || l.y < 0 || l.z < 0 || l.x >= loaded.dims.x ||
            l.y >= loaded.dims.y || l.z >= loaded.dims.z) {
          lost += v < 0 || surface;
          continue;
        }
        auto w = grid_value(loaded, l.x, l.y, l.z);
        wrong_sign += (v < 0) != (w < 0);
        wrong_value += surface && v != w;
      }
    }
  }
  CHECK(wrong_sign == 0);
  CHECK(wrong_value == 0);
  CHECK(lost == 0);
}

// A sphere of `radius` at the origin baked over `bounds`, values multiplied
// by `gain` (not a distance when gain != 1).
grid_data baked_sphere(
    float radius, float voxel, const bbox3f& bounds, float gain = 1) {
  auto node    = sdf_node{};
  node.type    = sdf_type::sphere;
  node.radius  = radius;
  auto program = make_primitive_program(node);
  auto grid    = bake_grid(program, identity_frame, bounds, voxel);
  for (auto& v : grid.values) v *= gain;
  update_grid_accel(grid);
  return grid;
}

// The same with `pad` voxels around the sphere.
grid_data baked_sphere(float radius, float voxel, float pad, float gain) {
  auto extent = radius + pad * voxel;
  return baked_sphere(radius, voxel,
      {{-extent, -extent, -extent}, {extent, extent, extent}}, gain);
}

}  // namespace

TEST_CASE("vdb: a level set made by OpenVDB loads with its band and signs") {
  auto filename = vdb_test_path("openvdb_sphere.vdb");
  auto sphere   = write_openvdb_sphere(filename, 0.5f, {1, 2, 3}, 0.02f);
  auto grid     = load_grid(filename, grid_format::vdb);
  CHECK(grid.placed_by_file);
  CHECK(grid.spacing == doctest::Approx(0.02f));
  CHECK(grid.file_background == doctest::Approx(0.06f));
  CHECK(grid.file_active_voxels == (int64_t)sphere->activeVoxelCount());
  // Every sample is the tree's value there: the band's, or +-background
  // with the right sign (inside the sphere the tiles are negative).
  auto box       = sphere->evalActiveVoxelBoundingBox();
  auto accessor  = sphere->getConstAccessor();
  auto different = 0, inside = 0;
  for (auto k = 0; k < grid.dims.z; k++)
    for (auto j = 0; j < grid.dims.y; j++)
      for (auto i = 0; i < grid.dims.x; i++) {
        auto v = grid_value(grid, i, j, k);
        different += v != accessor.getValue(box.min().offsetBy(i, j, k));
        inside += v == -grid.file_background;
      }
  CHECK(different == 0);
  CHECK(inside > 1000);
  // Sample (0,0,0) sits where the file's transform puts the box's first
  // voxel.
  auto first = sphere->transform().indexToWorld(box.min());
  CHECK(distance(grid.origin, vec3f{(float)first.x(), (float)first.y(),
                                  (float)first.z()}) < 1e-6f);
  // Outside the band the samples bound the distance: never above it, never
  // of the wrong sign.
  auto rng = make_rng(3);
  for (auto n = 0; n < 2000; n++) {
    auto p_file = vec3f{1, 2, 3} +
                  sample_sphere(rand2f(rng)) * (0.57f + 0.3f * rand1f(rng));
    auto d = eval_grid(grid, p_file - grid.origin);
    CHECK(d > 0);
    CHECK(d <= distance(p_file, vec3f{1, 2, 3}) - 0.5f + 1e-4f);
  }
}

TEST_CASE("vdb: a level set made by OpenVDB traces exactly where it is") {
  auto filename = vdb_test_path("openvdb_sphere_trace.vdb");
  write_openvdb_sphere(filename, 0.5f, {1, 2, 3}, 0.02f);
  auto grid = load_grid(filename, grid_format::vdb);
  for (auto type : {accel_type::bvh, accel_type::none}) {
    // Placed by its own transform: the sphere is at (1,2,3) in the scene.
    auto accel = make_accel(grid_scene(grid, 1, identity_frame), type);
    check_traced_sphere(accel, {1, 2, 3}, 0.5f, 2e-3f);
    // The instance's scale and frame apply on top: world_from_local
    // translates by (10,0,0), so the centre goes to (10,0,0) + 2*(1,2,3).
    auto local_from_world =
        frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-10, 0, 0}};
    auto moved = make_accel(grid_scene(grid, 2, local_from_world), type);
    check_traced_sphere(moved, {12, 4, 6}, 1.0f, 4e-3f);
  }
  // The seed's formats keep their rule: saved as .sdf, the same samples put
  // their first one at the instance's origin.
  auto sdf_name = vdb_test_path("openvdb_sphere.sdf");
  save_grid(sdf_name, grid, grid_format::sdfgen);
  auto sdf = load_grid(sdf_name, grid_format::sdfgen);
  CHECK(!sdf.placed_by_file);
  auto seed_rule =
      make_accel(grid_scene(sdf, 1, identity_frame), accel_type::bvh);
  check_traced_sphere(seed_rule, vec3f{1, 2, 3} - grid.origin, 0.5f, 2e-3f);
}

TEST_CASE("vdb: saved level sets are narrow bands with the same surface") {
  auto grid     = baked_sphere(0.5f, 0.02f, 12, 1);
  auto filename = vdb_test_path("narrow_band.vdb");
  save_grid(filename, grid, grid_format::vdb);
  // As OpenVDB reads it: a level set with a 3-voxel background, active
  // voxels only within the band, and every band sample active.
  openvdb::initialize();
  auto file = openvdb::io::File(filename);
  file.open();
  auto base = file.readGrid("sdf");
  file.close();
  REQUIRE(base->getGridClass() == openvdb::GRID_LEVEL_SET);
  auto level_set = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  REQUIRE(level_set);
  auto background = level_set->background();
  CHECK(background == doctest::Approx(0.06f));
  auto outside_band = 0;
  for (auto on = level_set->cbeginValueOn(); on; ++on)
    outside_band += !(std::abs(*on) < background);
  CHECK(outside_band == 0);
  auto in_band = int64_t{0};
  for (auto v : grid.values) in_band += std::abs(v) < background;
  CHECK((int64_t)level_set->activeVoxelCount() == in_band);
  CHECK(in_band * 3 < grid_samples(grid.dims));
  // Far smaller than the dense samples, and the same surface once loaded.
  CHECK(std::filesystem::file_size(filename) * 4 <
        (size_t)grid_samples(grid.dims) * 4);
  auto loaded = load_grid(filename, grid_format::vdb);
  check_same_surface(grid, loaded);
  // Traced at the same place (both placed where the samples were baked).
  auto dense           = grid;
  dense.placed_by_file = true;
  for (auto g : {&dense, &loaded}) {
    auto accel = make_accel(grid_scene(*g, 1, identity_frame), accel_type::bvh);
    check_traced_sphere(accel, {0, 0, 0}, 0.5f, 2e-3f);
  }
}

TEST_CASE("vdb: saving keeps surfaces of data that is no distance") {
  // Values ten times a distance (as voxel counts are): the band of 3
  // voxels holds less than a voxel of surface, yet the corners of every
  // voxel the surface crosses keep their values.
  auto steep = baked_sphere(0.5f, 0.02f, 6, 10);
  save_grid(vdb_test_path("steep.vdb"), steep, grid_format::vdb);
  check_same_surface(
      steep, load_grid(vdb_test_path("steep.vdb"), grid_format::vdb));
  // A sphere clipped by the grid's box, whose face x = 0.2 lies wholly
  // inside it, far from its surface: negative samples on the box keep the
  // box closing the solid there.
  auto clipped =
      baked_sphere(0.5f, 0.02f, {{-0.6f, -0.2f, -0.2f}, {0.2f, 0.2f, 0.2f}});
  auto negative_boundary = compute_grid_stats(clipped).negative_boundary;
  REQUIRE(negative_boundary > 0);
  save_grid(vdb_test_path("clipped.vdb"), clipped, grid_format::vdb);
  auto loaded = load_grid(vdb_test_path("clipped.vdb"), grid_format::vdb);
  check_same_surface(clipped, loaded);
  CHECK(compute_grid_stats(loaded).negative_boundary == negative_boundary);
}
