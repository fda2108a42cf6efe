// # implicit: fuzz target for one mesh format (FUZZ_EXT: .obj or .ply)
//
// The loaders map their file, so the input goes through a temporary file.

#include "../src/sdf/sdf_mesh_io.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace implicit;
  auto input = fuzz_input_file{data, size, FUZZ_EXT};
  try {
    load_mesh(input.filename);
  } catch (const io_error&) {
    // The expected outcome for a malformed file.
  }
  return 0;
}
