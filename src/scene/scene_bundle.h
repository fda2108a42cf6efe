// # implicit: scene bundles
//
// Under mpirun no shared filesystem is assumed: rank 0 packs the scene file
// and every file it references (grids, textures, environment maps) into one
// byte buffer, broadcasts it, and the other ranks unpack it into a private
// temporary folder that mirrors the relative paths, then load the scene from
// there with the ordinary loader.
#pragma once

#include <string>
#include <vector>

#include "scene.h"

namespace implicit {

// One file of a bundle: its path relative to the bundle's root, its bytes.
struct bundle_file {
  std::string path  = "";
  std::string bytes = "";
};

// A scene file and the files it references. The scene is the first file.
struct scene_bundle {
  std::vector<bundle_file> files = {};
};

// Read the scene file and the files named by the uris of its textures,
// volumes and expressions' .vm files (relative to the scene's directory).
// Throws io_error for an unreadable file or an absolute uri (it could not be
// mirrored).
scene_bundle make_scene_bundle(
    const std::string& scene_filename, const scene_data& scene);

// Bundle <-> bytes (length-prefixed paths and contents).
std::string  serialize_bundle(const scene_bundle& bundle);
scene_bundle deserialize_bundle(const std::string& bytes);

// A private temporary folder, removed with its contents on destruction.
struct temporary_folder {
  std::string path                                     = "";
  temporary_folder()                                   = default;
  temporary_folder(const temporary_folder&)            = delete;
  temporary_folder& operator=(const temporary_folder&) = delete;
  ~temporary_folder();
};

// Write the bundle's files under a new temporary folder; returns the path of
// the scene file in it. Throws io_error when a file cannot be written.
std::string write_scene_bundle(
    const scene_bundle& bundle, temporary_folder& folder);

}  // namespace implicit
