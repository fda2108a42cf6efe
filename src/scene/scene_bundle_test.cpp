// Tests of scene bundles (what rank 0 sends the other ranks): a scene and
// its files, one folder up included, go through bytes into a temporary
// folder and load the same; bad bytes and paths that leave the bundle are
// refused.

#include "scene_bundle.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include "../util/error.h"
#include "scene_io.h"

using namespace implicit;
namespace fs = std::filesystem;

namespace {

// A scene in `dir`/scene with a texture one folder up.
std::string write_scene(const fs::path& dir) {
  fs::create_directories(dir / "scene");
  fs::create_directories(dir / "textures");
  std::ofstream(dir / "textures" / "sky.hdr") << "not read by the bundle";
  std::ofstream(dir / "scene" / "scene.json") << R"({
    "asset": {"version": "4.2"},
    "textures": [{"name": "sky", "uri": "../textures/sky.hdr"}],
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [{"name": "ball", "type": "sphere", "radius": 1, "material": 0,
                     "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,0]}]
  })";
  return (dir / "scene" / "scene.json").string();
}

}  // namespace

TEST_CASE("scene bundle: files travel as bytes into a private folder") {
  auto dir = fs::path{IMPLICIT_BINARY_DIR} / "test_outputs" / "scene_bundle";
  fs::remove_all(dir);
  auto filename = write_scene(dir);
  // Parsed without its files: the bundle reads them itself.
  auto stream   = std::ifstream(filename);
  auto text     = std::string{std::istreambuf_iterator<char>(stream), {}};
  auto warnings = std::vector<std::string>{};
  auto scene    = parse_scene(text, filename, warnings, false);
  auto bundle   = make_scene_bundle(filename, scene);
  REQUIRE(bundle.files.size() == 2);
  // The scene goes one folder deep, so that "../textures" stays inside.
  CHECK(bundle.files[0].path == "up/scene.json");
  CHECK(bundle.files[1].path == "textures/sky.hdr");
  auto bytes = serialize_bundle(bundle);
  auto back  = deserialize_bundle(bytes);
  REQUIRE(back.files.size() == 2);
  CHECK(back.files[1].bytes == "not read by the bundle");
  auto copied      = std::string{};
  auto folder_path = std::string{};
  {
    auto folder = temporary_folder{};
    copied      = write_scene_bundle(back, folder);
    folder_path = folder.path;
    CHECK(fs::exists(
        fs::path(copied).parent_path().parent_path() / "textures" / "sky.hdr"));
    auto again = std::ifstream(copied);
    CHECK(std::string{std::istreambuf_iterator<char>(again), {}} ==
          bundle.files[0].bytes);
  }
  CHECK_FALSE(fs::exists(folder_path));  // removed with its files
  // Truncated bytes, and a path that would leave the folder.
  CHECK_THROWS_AS(
      deserialize_bundle(bytes.substr(0, bytes.size() - 1)), io_error);
  auto escape          = bundle;
  escape.files[1].path = "../outside.hdr";
  auto folder          = temporary_folder{};
  CHECK_THROWS_AS(write_scene_bundle(escape, folder), io_error);
  // An absolute uri cannot be mirrored.
  scene.textures[0].uri = "/tmp/sky.hdr";
  CHECK_THROWS_AS(make_scene_bundle(filename, scene), io_error);
}
