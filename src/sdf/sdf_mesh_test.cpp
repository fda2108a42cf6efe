// Tests of mesh files and mesh <-> grid conversion.

#include "sdf_mesh.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "../../tests/shared_data.h"
#include "../util/error.h"
#include "sdf_mesh_io.h"

using namespace implicit;

namespace {

std::string temp_path(const std::string& name) {
  auto dir = std::string(IMPLICIT_BINARY_DIR) + "/grid_mesh_test";
  std::filesystem::create_directories(dir);
  return dir + "/" + name;
}

void write_file(const std::string& filename, const std::string& bytes) {
  auto out = std::ofstream(filename, std::ios::binary);
  out.write(bytes.data(), (std::streamsize)bytes.size());
}

template <typename T>
void append(std::string& bytes, T value) {
  char buffer[sizeof(T)];
  std::memcpy(buffer, &value, sizeof(T));
  bytes.append(buffer, sizeof(T));
}

// Closed unit cube [0,1]^3 scaled by s and moved by o, faces outwards;
// `open` drops the top face.
mesh_data cube_mesh(float s, vec3f o, bool open = false) {
  auto mesh = mesh_data{};
  for (auto c = 0; c < 8; c++)
    mesh.positions.push_back(o + vec3f{(float)(c & 1), (float)((c >> 1) & 1),
                                     (float)((c >> 2) & 1)} *
                                     s);
  // Quads (outward, counter-clockwise): -x +x -y +y -z +z.
  int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3},
      {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (auto f = 0; f < 6; f++) {
    if (open && f == 3) continue;
    auto& q = quads[f];
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

std::string load_error(const std::string& name, const std::string& bytes) {
  auto filename = temp_path(name);
  write_file(filename, bytes);
  try {
    load_mesh(filename);
  } catch (const io_error& error) { return error.what(); }
  return "";
}

}  // namespace

TEST_CASE("grid mesh OBJ and PLY readers") {
  // OBJ: quads, negative indices, v/vt/vn, CRLF, comments.
  write_file(temp_path("quad.obj"),
      "# comment\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nvt 0 0\r\n"
      "vn 0 0 1\r\nf 1/1/1 2/1/1 3//1 4\r\nv 0 0 2e0\r\nf -4 -3 -1\r\n");
  auto obj = load_mesh(temp_path("quad.obj"));
  REQUIRE(obj.positions.size() == 5);
  REQUIRE(obj.triangles.size() == 3);
  CHECK(obj.triangles[1] == vec3i{0, 2, 3});
  CHECK(obj.triangles[2] == vec3i{1, 2, 4});
  CHECK(obj.positions[4] == vec3f{0, 0, 2});

  // ascii PLY with extra properties and an extra element.
  write_file(temp_path("ascii.ply"),
      "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\n"
      "property float nx\nproperty double y\nproperty float z\n"
      "element material 1\nproperty list uchar float rgb\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 9 0 0\n1 9 0 0\n1 9 1 0\n0 9 1 3.5\n3 0.1 0.2 0.3\n4 0 1 2 3\n");
  auto ascii = load_mesh(temp_path("ascii.ply"));
  REQUIRE(ascii.positions.size() == 4);
  CHECK(ascii.positions[3] == vec3f{0, 1, 3.5f});
  REQUIRE(ascii.triangles.size() == 2);
  CHECK(ascii.triangles[1] == vec3i{0, 2, 3});

  // Binary PLY by hand: double positions, ushort count, uint indices.
  auto bytes = std::string{
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
      "property double x\nproperty double y\nproperty double z\nproperty uchar "
      "flag\n"
      "element face 1\nproperty list ushort uint vertex_index\nend_header\n"};
  for (auto c = 0; c < 3; c++) {
    append(bytes, (double)c);
    append(bytes, (double)(c * c));
    append(bytes, 0.5);
    append(bytes, (uint8_t)7);
  }
  append(bytes, (uint16_t)3);
  for (auto i : {2u, 1u, 0u}) append(bytes, i);
  write_file(temp_path("binary.ply"), bytes);
  auto binary = load_mesh(temp_path("binary.ply"));
  REQUIRE(binary.positions.size() == 3);
  CHECK(binary.positions[2] == vec3f{2, 4, 0.5f});
  REQUIRE(binary.triangles.size() == 1);
  CHECK(binary.triangles[0] == vec3i{2, 1, 0});

  // Our writers read back exactly.
  auto cube = cube_mesh(0.3f, {0.1f, -0.2f, 0.05f});
  for (auto name : {"cube.obj", "cube.ply"}) {
    save_mesh(temp_path(name), cube);
    auto loaded = load_mesh(temp_path(name));
    CHECK(loaded.positions.size() == 8);
    CHECK(loaded.triangles.size() == 12);
    auto same = true;
    for (auto i = 0; i < 8; i++)
      same = same && loaded.positions[i] == cube.positions[i];
    for (auto i = 0; i < 12; i++)
      same = same && loaded.triangles[i] == cube.triangles[i];
    CHECK(same);
  }
  CHECK(mesh_volume(cube) == doctest::Approx(0.027).epsilon(1e-5).scale(0));
}

TEST_CASE("grid mesh readers refuse bad files") {
  CHECK(load_error("empty.obj", "").find("file is empty") != std::string::npos);
  CHECK(
      load_error("index.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n")
          .find(":3: face: vertex index 3 out of range") != std::string::npos);
  CHECK(load_error("zero.obj", "v 0 0 0\nf 0 1 1\n")
            .find("is not a vertex index") != std::string::npos);
  CHECK(load_error("nan.obj", "v 0 nan 0\n")
            .find(":1: vertex: 'nan' is not a finite") != std::string::npos);
  CHECK(load_error("short.obj", "v 0 0\n").find(":1: vertex") !=
        std::string::npos);
  CHECK(load_error("mesh.stl", "solid").find("unknown mesh extension '.stl'") !=
        std::string::npos);
  CHECK(load_error("magic.ply", "plx\n").find(":1: not a PLY file") !=
        std::string::npos);
  CHECK(load_error("big.ply", "ply\nformat binary_big_endian 1.0\n")
            .find(":2: binary big endian PLY is not supported") !=
        std::string::npos);
  CHECK(load_error("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n")
            .find("no end_header") != std::string::npos);
  auto header = std::string{
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n"};
  CHECK(load_error("huge.ply", header + "abc").find("do not fit in the file") !=
        std::string::npos);
  auto tri = std::string{
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"};
  auto truncated = tri + std::string(30, '\0');
  CHECK(load_error("truncated.ply", truncated).find("unexpected end of file") !=
        std::string::npos);
  auto bad_index = tri + std::string(36, '\0') + "\x03";
  append(bad_index, 0);
  append(bad_index, 1);
  append(bad_index, 5);
  CHECK(load_error("bad_index.ply", bad_index)
            .find("vertex index 5.000000 out of range") != std::string::npos);
  CHECK(load_error("ascii_junk.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float "
            "x\nproperty float y\n"
            "property float z\nend_header\n1 zz 3\n")
            .find("'zz' is not a number") != std::string::npos);
}

TEST_CASE("grid mesh to grid and back") {
  // A closed cube: exact distances to a box.
  auto cube  = cube_mesh(0.5f, {0.1f, 0.2f, 0.3f});
  auto voxel = 0.05f;
  auto grid  = mesh_to_grid(cube, voxel, 3);
  REQUIRE(has_grid_accel(grid));
  // The lattice voxel*(i,j,k) around the cube plus 3 voxels (16 or 17
  // voxels depending on how 0.1/0.05 rounds).
  CHECK(grid.dims.x >= 17);
  CHECK(grid.dims.x <= 18);
  CHECK(grid.origin.x <= 0.1f - 3 * voxel + 1e-6f);
  CHECK(grid.origin.x >= 0.1f - 4 * voxel - 1e-6f);
  CHECK(std::abs(grid.origin.x / voxel - std::round(grid.origin.x / voxel)) <
        1e-4f);
  // Exact in the band; beyond it a lower bound about 2 voxels short.
  auto worst_band = 0.0f, worst_over = 0.0f, worst_under = 0.0f;
  auto wrong_sign = 0;
  for (auto k = 0; k < grid.dims.z; k++)
    for (auto j = 0; j < grid.dims.y; j++)
      for (auto i = 0; i < grid.dims.x; i++) {
        auto p = grid.origin + vec3f{(float)i, (float)j, (float)k} * voxel -
                 vec3f{0.35f, 0.45f, 0.55f};
        auto d     = abs(p) - 0.25f;
        auto exact = std::min(max(d), 0.0f) + length(max(d, 0.0f));
        auto value = grid_value(grid, i, j, k);
        if (std::abs(exact) < 2.5f * voxel)
          worst_band = std::max(worst_band, std::abs(value - exact));
        worst_over  = std::max(worst_over, std::abs(value) - std::abs(exact));
        worst_under = std::max(worst_under, std::abs(exact) - std::abs(value));
        if (std::abs(exact) > 0.1f * voxel && (value < 0) != (exact < 0))
          wrong_sign++;
      }
  CHECK(worst_band < 0.05f * voxel);
  CHECK(worst_over < 0.05f * voxel);
  CHECK(worst_under < 2.5f * voxel);
  CHECK(wrong_sign == 0);

  // Back to a mesh: closed, outward, the cube's volume.
  auto back = grid_to_mesh(grid);
  CHECK(back.triangles.size() > 100);
  CHECK(mesh_volume(back) == doctest::Approx(0.125).epsilon(0.01).scale(0));
  auto bounds = mesh_bounds(back);
  CHECK(distance(bounds.min, vec3f{0.1f, 0.2f, 0.3f}) < 0.01f);

  // An open cube has no inside; a shell makes one.
  auto open    = cube_mesh(0.5f, {0, 0, 0}, true);
  auto message = std::string{};
  try {
    mesh_to_grid(open, voxel, 3);
  } catch (const io_error& error) { message = error.what(); }
  CHECK(message.find("the mesh is not closed") != std::string::npos);
  auto shell = mesh_to_grid(open, voxel, 3, 0.5f * voxel);
  CHECK(compute_grid_stats(shell).surface_voxels > 0);
  CHECK(compute_grid_stats(shell).min == doctest::Approx(-0.5f * voxel));
  CHECK_THROWS_AS(mesh_to_grid(cube, 1e-9f, 3), io_error);
  CHECK_THROWS_AS(mesh_to_grid(mesh_data{}, voxel, 3), io_error);

  // A grid clipped by its box meshes to a closed solid: a sphere of radius
  // 0.5 cut by the x = 0.8 face, 0.3 from the centre (a cap of height 0.2
  // removed).
  auto clipped = make_grid({17, 25, 25}, 0.05f, {0, 0, 0}, 0);
  for (auto k = 0; k < 25; k++)
    for (auto j = 0; j < 25; j++)
      for (auto i = 0; i < 17; i++)
        clipped.values[i + 17 * (j + 25 * k)] =
            length(vec3f{(float)i, (float)j, (float)k} * 0.05f -
                   vec3f{0.5f, 0.6f, 0.6f}) -
            0.5f;
  update_grid_accel(clipped);
  auto cap      = pif * 0.2 * 0.2 * (3 * 0.5 - 0.2) / 3;
  auto expected = 4 * pif * 0.125 / 3 - cap;
  CHECK(mesh_volume(grid_to_mesh(clipped)) ==
        doctest::Approx(expected).epsilon(0.02).scale(0));
}

TEST_CASE("grid mesh loads the shared bunny") {
  IMPLICIT_SKIP_WITHOUT_SHARED("bunny mesh; the PLY tests make their own");
  auto mesh = load_mesh(std::string(IMPLICIT_SHARED_DIR) + "/meshes/bunny.ply");
  CHECK(mesh.positions.size() == 72378);
  CHECK(mesh.triangles.size() == 144046);
  CHECK(mesh_volume(mesh) == doctest::Approx(8.792e-4).epsilon(1e-3).scale(0));
  auto bounds = mesh_bounds(mesh);
  CHECK(bounds.max.y == doctest::Approx(0.16208f).epsilon(1e-4).scale(0));
}

TEST_CASE("grid mesh PLY elements without properties take no time") {
  // A fuzz finding (issue 12): no properties and a count of 9e18 skipped
  // the size check, and the loader looped over the count for ever.
  auto mesh = load_mesh(std::string(IMPLICIT_SOURCE_DIR) +
                        "/tests/data/ply_empty_element_huge_count.ply");
  CHECK(mesh.positions.empty());
  CHECK(mesh.triangles.empty());
  auto ascii = std::string{
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement nothing "
      "9000000000000000000\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"};
  write_file(temp_path("empty_element.ply"), ascii);
  auto triangle = load_mesh(temp_path("empty_element.ply"));
  CHECK(triangle.positions.size() == 3);
  CHECK(triangle.triangles.size() == 1);
}
