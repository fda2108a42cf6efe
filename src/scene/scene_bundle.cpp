// # implicit: scene bundles (see scene_bundle.h)

#include "scene_bundle.h"

#include <stdlib.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <set>

#include "../util/error.h"
#include "../util/file.h"

namespace fs = std::filesystem;

namespace implicit {

// Number of leading ".." components of a normalized relative path.
static int count_parent_steps(const fs::path& path) {
  auto steps = 0;
  for (auto& part : path) {
    if (part != "..") break;
    steps++;
  }
  return steps;
}

scene_bundle make_scene_bundle(
    const std::string& scene_filename, const scene_data& scene) {
  auto uris = std::vector<std::string>{};
  for (auto& texture : scene.textures) uris.push_back(texture.uri);
  for (auto& volume : scene.volumes) uris.push_back(volume.uri);
  // The .vm files of expressions.
  for (auto& sdf : scene.sdfunctions)
    uris.insert(uris.end(), sdf.uris.begin(), sdf.uris.end());
  // A uri like "../grids/a.sdf" leaves the scene's folder: the scene goes
  // that many folders deep in the bundle, so every file stays inside it.
  auto depth = 0;
  for (auto& uri : uris) {
    if (fs::path(uri).is_absolute())
      throw_io_error(scene_filename,
          "uri \"" + uri +
              "\" is absolute; under mpirun referenced files must be "
              "relative to the scene (they are sent to every rank)");
    depth =
        std::max(depth, count_parent_steps(fs::path(uri).lexically_normal()));
  }
  auto scene_folder = fs::path{};
  for (auto level = 0; level < depth; level++) scene_folder /= "up";
  auto directory = fs::path(scene_filename).parent_path();
  auto bundle    = scene_bundle{};
  bundle.files.push_back(
      {(scene_folder / fs::path(scene_filename).filename()).string(),
          read_file(scene_filename)});
  auto seen = std::set<std::string>{};
  for (auto& uri : uris) {
    auto path = (scene_folder / uri).lexically_normal().string();
    if (!seen.insert(path).second) continue;
    bundle.files.push_back({path, read_file((directory / uri).string())});
  }
  return bundle;
}

// Append a length-prefixed string.
static void write_string(std::string& out, const std::string& value) {
  auto size = (uint64_t)value.size();
  out.append((const char*)&size, sizeof(size));
  out.append(value);
}

// Read a length-prefixed string at `offset`, advancing it.
static std::string read_string(const std::string& in, size_t& offset) {
  auto size = uint64_t{0};
  if (in.size() - offset < sizeof(size))
    throw io_error("scene bundle: truncated");
  std::memcpy(&size, in.data() + offset, sizeof(size));
  offset += sizeof(size);
  if (in.size() - offset < size) throw io_error("scene bundle: truncated");
  auto value = in.substr(offset, size);
  offset += size;
  return value;
}

std::string serialize_bundle(const scene_bundle& bundle) {
  auto out = std::string{};
  for (auto& file : bundle.files) {
    write_string(out, file.path);
    write_string(out, file.bytes);
  }
  return out;
}

scene_bundle deserialize_bundle(const std::string& bytes) {
  auto bundle = scene_bundle{};
  auto offset = size_t{0};
  while (offset < bytes.size()) {
    auto path  = read_string(bytes, offset);
    auto value = read_string(bytes, offset);
    bundle.files.push_back({path, value});
  }
  return bundle;
}

temporary_folder::~temporary_folder() {
  if (path.empty()) return;
  auto error = std::error_code{};
  fs::remove_all(path, error);  // best effort: nothing to report to
}

std::string write_scene_bundle(
    const scene_bundle& bundle, temporary_folder& folder) {
  if (bundle.files.empty()) throw io_error("scene bundle: empty");
  auto pattern = (fs::temp_directory_path() / "implicit-XXXXXX").string();
  if (!mkdtemp(pattern.data()))
    throw_io_error(pattern, "cannot create a temporary folder");
  folder.path = pattern;
  for (auto& file : bundle.files) {
    auto relative = fs::path(file.path).lexically_normal();
    if (relative.is_absolute() || count_parent_steps(relative) > 0)
      throw_io_error(file.path, "scene bundle: path leaves the bundle");
    auto path  = fs::path(folder.path) / relative;
    auto error = std::error_code{};
    fs::create_directories(path.parent_path(), error);
    write_file(path.string(), file.bytes);
  }
  return (fs::path(folder.path) / bundle.files.front().path).string();
}

}  // namespace implicit
