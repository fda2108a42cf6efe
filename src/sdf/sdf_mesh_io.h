// # implicit: triangle mesh files
//
// Just enough OBJ and PLY for `ysdf from-mesh` and `ysdf to-mesh`: positions
// and polygons (fan-triangulated); normals, UVs, colours and other elements
// are skipped. PLY may be ascii or binary little endian. Errors throw
// io_error naming the file and the line or byte offset.
#pragma once

#include <string>

#include "sdf_mesh.h"

namespace implicit {

// Load an .obj or .ply mesh (by extension).
mesh_data load_mesh(const std::string& filename);

// Save an .obj (text) or .ply (binary little endian) mesh (by extension).
void save_mesh(const std::string& filename, const mesh_data& mesh);

}  // namespace implicit
