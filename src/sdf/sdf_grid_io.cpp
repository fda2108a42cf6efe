// # implicit: SDF grid files (placeholder until the grid loaders land)

#include "sdf_grid_io.h"

#include "../util/error.h"

namespace implicit {

grid_format grid_format_from_uri(const std::string& uri, bool binary) {
  (void)uri;
  return binary ? grid_format::skanti : grid_format::sdfgen;
}

grid_data load_grid(const std::string& filename, grid_format) {
  throw_io_error(filename, "grid files are not supported yet");
}

void save_grid(const std::string& filename, const grid_data&, grid_format) {
  throw_io_error(filename, "grid files are not supported yet");
}

}  // namespace implicit
