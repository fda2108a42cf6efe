// # implicit: image files (placeholder until the image module lands)

#include "image_io.h"

#include "../util/error.h"

namespace implicit {

bool is_hdr_filename(const std::string& filename) {
  auto ext = filename.substr(filename.find_last_of('.') + 1);
  return ext == "hdr" || ext == "exr";
}

image_data load_image(const std::string& filename) {
  throw_io_error(filename, "image loading is not implemented yet");
}

void save_image(const std::string& filename, const image_data&, float, bool) {
  throw_io_error(filename, "image saving is not implemented yet");
}

}  // namespace implicit
