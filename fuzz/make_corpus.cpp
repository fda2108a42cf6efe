// # implicit: write the fuzz seed corpora with the project's own savers
//
// Usage: fuzz_make_corpus <directory>; writes <directory>/<target>/<seed>
// for every fuzz target (fuzz/make_corpus.sh runs it and adds the example
// scenes). Seeds are small so that the fuzzers mutate them quickly.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "../src/image/image_io.h"
#include "../src/sdf/sdf_grid_io.h"
#include "../src/sdf/sdf_mesh_io.h"
#include "../src/util/error.h"

using namespace implicit;

// Write text to a file; exits on failure (this is a build tool).
static void write_text(const std::string& filename, const std::string& text) {
  auto file = std::fopen(filename.c_str(), "wb");
  if (!file || std::fwrite(text.data(), 1, text.size(), file) != text.size() ||
      std::fclose(file) != 0) {
    std::fprintf(stderr, "cannot write %s\n", filename.c_str());
    std::exit(1);
  }
}

// A small gradient with varying alpha and some HDR values.
static image_data seed_image(int width, int height) {
  auto image = make_image(width, height);
  for (auto j = 0; j < height; j++) {
    for (auto i = 0; i < width; i++) {
      image.pixels[(size_t)j * width + i] = {
          (float)i / width, (float)j / height, 2.5f * i * j, 0.5f + 0.1f * i};
    }
  }
  return image;
}

// A sphere of radius 0.4 sampled on n^3 points of spacing 1/(n-1).
static grid_data seed_grid(int n) {
  auto grid    = grid_data{};
  grid.dims    = {n, n, n};
  grid.spacing = 1.0f / (float)(n - 1);
  grid.origin  = {-0.5f, -0.5f, -0.5f};
  grid.values.resize((size_t)n * n * n);
  auto index = size_t{0};
  for (auto k = 0; k < n; k++) {
    for (auto j = 0; j < n; j++) {
      for (auto i = 0; i < n; i++) {
        auto p = vec3f{grid.origin.x + i * grid.spacing,
            grid.origin.y + j * grid.spacing, grid.origin.z + k * grid.spacing};
        grid.values[index++] =
            std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) - 0.4f;
      }
    }
  }
  return grid;
}

// A tetrahedron.
static mesh_data seed_mesh() {
  auto mesh      = mesh_data{};
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return mesh;
}

// A scene around one sdfunction (JSON text).
static std::string seed_scene(const std::string& sdfunction) {
  return R"({"cameras": [{"name": "c", "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,3],
  "aspect": 1, "lens": 0.05}],
 "environments": [{"name": "sky", "emission": [0.5, 0.5, 0.5]}],
 "materials": [{"name": "m", "type": "glossy", "color": [0.8, 0.2, 0.2],
  "roughness": 0.3}, {"name": "l", "emission": [5, 5, 5]}],
 "sdfunctions": [)" +
         sdfunction + R"(,
  {"name": "light", "type": "sphere", "radius": 0.2, "material": 1,
   "world_from_local": [1,0,0, 0,1,0, 0,0,1, 1,1,1]}]}
)";
}

// CSG with `operands` spheres under one union, nested `depth` deep.
static std::string csg_scene(int operands, int depth) {
  auto csg = std::string{R"({"type": "sphere", "radius": 0.3})"};
  for (auto d = 0; d < depth; d++)
    csg = R"({"type": "union", "operands": [)" + csg +
          R"(, {"type": "box", "whd": [0.1, 0.1, 0.1]}]})";
  auto list = std::string{};
  for (auto i = 0; i < operands; i++)
    list += (i == 0 ? "" : ",") +
            std::string{R"({"type": "sphere", "radius": 0.01})"};
  return seed_scene(R"({"name": "csg", "type": "union", "material": 0,
   "operands": [)" + csg +
                    (list.empty() ? "" : "," + list) + "]}");
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_corpus <directory>\n");
    return 1;
  }
  auto root = std::filesystem::path(argv[1]);
  auto dir  = [&](const std::string& target) {
    std::filesystem::create_directories(root / target);
    return (root / target).string() + "/";
  };
  try {
    for (auto format : {"png", "jpg", "hdr", "exr", "tga", "bmp"}) {
      auto d = dir(std::string("fuzz_") + format);
      save_image(d + "gradient." + format, seed_image(5, 3));
      save_image(d + "pixel." + format, seed_image(1, 1));
    }
    struct grid_target {
      const char* target;
      grid_format format;
      const char* extension;
    };
    for (auto [target, format, extension] :
        {grid_target{"fuzz_sdfgen", grid_format::sdfgen, ".sdf"},
            grid_target{"fuzz_skanti", grid_format::skanti, ".df"},
            grid_target{"fuzz_vol", grid_format::mitsuba, ".vol"},
            grid_target{"fuzz_vdb", grid_format::vdb, ".vdb"}}) {
      save_grid(dir(target) + "sphere3" + extension, seed_grid(3), format);
      save_grid(dir(target) + "sphere5" + extension, seed_grid(5), format);
    }
    save_mesh(dir("fuzz_obj") + "tetra.obj", seed_mesh());
    write_text(dir("fuzz_obj") + "quads.obj",
        "# quads, negative indices, normals\nv 0 0 0\nv 1 0 0\nv 1 1 0\n"
        "v 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4/1 -2/2 -1/3\n");
    save_mesh(dir("fuzz_ply") + "tetra.ply", seed_mesh());
    write_text(dir("fuzz_ply") + "ascii.ply",
        "ply\nformat ascii 1.0\ncomment seed\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property uchar red\nelement face 1\n"
        "property list uchar int vertex_indices\nelement extra 1\n"
        "property list int double values\nend_header\n"
        "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n4 0 1 2 3\n2 0.5 1e3\n");
    auto scenes = dir("fuzz_scene");
    write_text(scenes + "sphere.json",
        seed_scene(R"({"name": "s", "type": "sphere", "radius": 0.5,
   "material": 0})"));
    write_text(scenes + "csg_deep.json", csg_scene(0, 60));
    write_text(scenes + "csg_wide.json", csg_scene(1500, 2));
  } catch (const io_error& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
  return 0;
}
