// # implicit: sdfunction objects in scene files
//
// The reader of one `sdfunctions` element and the objects nested in it
// (operands), shared by the scene loader (scene_io.cpp) and its tests. The
// keys of primitives come from sdf_primitive_table.h, those of operators from
// sdf_operator_table.h; the summary of both is at the top of scene_io.cpp.
// Internal to the scene module.
#pragma once

#include <string>
#include <vector>

#include "../sdf/sdf_program.h"
#include "json_check.h"

namespace implicit {

// Where the `.vm` files of `expression` objects are read from.
struct sdf_file_context {
  std::string directory    = "";    // uris are relative to it
  bool        load_files   = true;  // false: not read (the constant 1 instead)
  bool        check_bounds = true;  // refuse unbounded functions (parse_scene)
};

// Parse an sdfunction object (its type, parameters and nested operands, not
// its own frame or material) into `program`; returns its root. Objects are
// walked with an explicit stack, so nesting costs no call stack (JSON text
// is nested at most max_json_depth levels: json_check.h). The `.vm` files
// read are appended to `uris` as written in the scene.
int parse_sdf_object(const json_place& place, const json& js,
    sdf_program& program, const sdf_file_context& files,
    std::vector<std::string>& uris);

}  // namespace implicit
