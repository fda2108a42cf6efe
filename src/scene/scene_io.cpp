// # implicit: scene files (placeholder until the loader lands)

#include "scene_io.h"

#include "../util/error.h"

namespace implicit {

scene_data load_scene(const std::string& filename) {
  throw_io_error(filename, "scene loading is not implemented yet");
}

scene_data parse_scene(const std::string&, const std::string& filename) {
  throw_io_error(filename, "scene loading is not implemented yet");
}

}  // namespace implicit
