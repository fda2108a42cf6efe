// # implicit: SDF grid files
//
// SDFGen text (.sdf, `binary: false`), skanti binary (.sdf, `binary: true`),
// OpenVDB level sets (.vdb) and Mitsuba 3 grids (.vol). Errors throw io_error
// naming the file and the line or byte offset.
#pragma once

#include <string>
#include <vector>

#include "sdf_grid.h"

namespace implicit {

enum class grid_format { sdfgen, skanti, vdb, mitsuba };
inline const std::vector<std::string> grid_format_names = {
    "sdfgen", "skanti", "vdb", "mitsuba"};

// Format of a scene volume: by extension for .vdb and .vol, else by the
// seed's `binary` flag.
grid_format grid_format_from_uri(const std::string& uri, bool binary);

// Load a grid.
grid_data load_grid(const std::string& filename, grid_format format);

// Save a grid.
void save_grid(
    const std::string& filename, const grid_data& grid, grid_format format);

}  // namespace implicit
