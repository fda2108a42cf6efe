// # implicit: scene files
//
// Yocto/GL 4.2 JSON scenes with the seed's `sdfunctions`, `volumes` and
// `vol_instances`. Every problem throws io_error with a message of the form
// `file[:line:column]: array[i] ("name").key: problem`.
#pragma once

#include <string>
#include <vector>

#include "../sdf/sdf_program.h"
#include "scene.h"

namespace implicit {

// Load a scene, its textures and its grids (paths relative to the scene).
// Problems that do not stop the load (e.g. a material naming a texture that
// does not exist, as the seed scenes do) are appended to `warnings`, each
// formatted like an error; the overload without it drops them.
scene_data load_scene(const std::string& filename);
scene_data load_scene(
    const std::string& filename, std::vector<std::string>& warnings);

// Parse a scene from JSON text; `filename` names it in errors and anchors
// relative paths. The whole JSON is validated first; then, when `load_files`
// is true, the grids and textures it references are loaded (with false they
// stay empty: for checking a file, and for tests). With `check_bounds`
// (and `load_files`) an sdfunction that is no distance bound and whose
// surface is unbounded is refused (it could not be traced); evaluating
// functions at points needs no box (Python's f(points)).
scene_data parse_scene(const std::string& text, const std::string& filename);
scene_data parse_scene(const std::string& text, const std::string& filename,
    std::vector<std::string>& warnings, bool load_files = true,
    bool check_bounds = true);

// A primitive written as a type and `key=value` texts (ysdf's --shape
// "capsule radius=0.2 height=1"), read as the scene loader reads a
// primitive sdfunction object: each text becomes a JSON value (a number,
// an array of numbers for "x,y,z", else a string), and the same keys,
// ranges and cross checks apply (the primitive table). Errors read
// "`source`: key: problem". Returns the primitive's program.
sdf_program parse_primitive_text(const std::string&         type,
    const std::vector<std::pair<std::string, std::string>>& values,
    const std::string&                                      source);

}  // namespace implicit
