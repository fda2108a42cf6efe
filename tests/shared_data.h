// Tests that read the seed's data in ../shared (scenes, sample grids,
// meshes) skip themselves when it is absent (a fresh clone): they print the
// marker that CMakeLists.txt maps to a ctest skip, with the reason. Every
// code path they cover is also covered by data the tests make themselves.
#pragma once

#include <cstdio>
#include <filesystem>

namespace implicit_test {

// True, after printing the skip marker, when ../shared is absent.
inline bool shared_absent(const char* reason) {
  if (std::filesystem::is_directory(IMPLICIT_SHARED_DIR)) return false;
  std::printf("IMPLICIT_TEST_SKIPPED: ../shared absent (%s)\n", reason);
  return true;
}

}  // namespace implicit_test

// Return from the test case (reported skipped) when ../shared is absent.
#define IMPLICIT_SKIP_WITHOUT_SHARED(reason) \
  if (implicit_test::shared_absent(reason)) return
