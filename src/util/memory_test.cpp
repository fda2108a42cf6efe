// Tests of memory hints.

#include "memory.h"

#include <doctest/doctest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../image/image.h"
#include "../sdf/sdf_grid.h"

using namespace implicit;

namespace {

// Whether the kernel has transparent huge pages at all (not "[never]").
bool has_transparent_huge_pages() {
  auto file = std::ifstream{"/sys/kernel/mm/transparent_hugepage/enabled"};
  auto line = std::string{};
  return std::getline(file, line) && line.find("[never]") == std::string::npos;
}

// The VmFlags of the mapping of this process that holds `address`.
std::string mapping_flags(const void* address) {
  auto file    = std::ifstream{"/proc/self/smaps"};
  auto line    = std::string{};
  auto holding = false;
  while (std::getline(file, line)) {
    auto dash  = line.find('-');
    auto space = line.find(' ');
    if (dash != std::string::npos && space != std::string::npos &&
        dash < space && line.find(':') > space) {
      auto begin = std::stoull(line.substr(0, dash), nullptr, 16);
      auto end =
          std::stoull(line.substr(dash + 1, space - dash - 1), nullptr, 16);
      holding = begin <= (uintptr_t)address && (uintptr_t)address < end;
    } else if (holding && line.rfind("VmFlags:", 0) == 0) {
      return line;
    }
  }
  return "";
}

}  // namespace

TEST_CASE("huge page advice covers whole huge pages, images and grids") {
  CHECK_FALSE(advise_huge_pages(nullptr, huge_page_bytes * 4));
  auto small = std::vector<char>(4096);
  CHECK_FALSE(advise_huge_pages(small.data(), small.size()));
  if (!has_transparent_huge_pages()) {
    MESSAGE("no transparent huge pages on this kernel: advice not checked");
    return;
  }
  // A buffer of 4 huge pages holds at least 3 whole ones: advised, and the
  // kernel marks their mapping "hg".
  auto buffer = std::vector<char>{};
  buffer.reserve(huge_page_bytes * 4);
  REQUIRE(advise_huge_pages(buffer.data(), huge_page_bytes * 4));
  auto inside = buffer.data() + huge_page_bytes * 2;
  CHECK(mapping_flags(inside).find(" hg") != std::string::npos);
  // A lat-long sky's pixels are advised too, and still zero.
  auto sky = make_image(2048, 1024);
  CHECK(mapping_flags(sky.pixels.data() + sky.pixels.size() / 2).find(" hg") !=
        std::string::npos);
  CHECK(sky.pixels[12345].x == 0);
  CHECK(sky.pixels.back().w == 0);
  // So are a grid's samples, with their value.
  auto grid = make_grid({128, 128, 128}, 0.1f, {0, 0, 0}, 0.5f);
  CHECK(
      mapping_flags(grid.values.data() + grid.values.size() / 2).find(" hg") !=
      std::string::npos);
  CHECK(grid.values[4321] == 0.5f);
}
