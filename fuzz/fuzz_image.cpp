// # implicit: fuzz target for one image format (FUZZ_EXT picks the decoder)
//
// The bytes go to load_image_from_memory(), the same path load_image() takes
// after reading the file.

#include "../src/image/image_io.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace implicit;
  try {
    load_image_from_memory("fuzz" FUZZ_EXT, data, size);
  } catch (const io_error&) {
    // The expected outcome for a malformed file.
  }
  return 0;
}
