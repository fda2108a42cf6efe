// # implicit: scene files
//
// Yocto/GL 4.2 JSON scenes with the seed's `sdfunctions`, `volumes` and
// `vol_instances`. Every problem throws io_error with a message of the form
// `file[:line:column]: array[i] ("name").key: problem`.
#pragma once

#include <string>

#include "scene.h"

namespace implicit {

// Load a scene, its textures and its grids (paths relative to the scene).
scene_data load_scene(const std::string& filename);

// Parse a scene from JSON text; `filename` names it in errors and anchors
// relative paths. Files referenced by the scene are loaded.
scene_data parse_scene(const std::string& text, const std::string& filename);

}  // namespace implicit
