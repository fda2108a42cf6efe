// Tests for tools/crosscheck/crosscheck_compare: per-region statistics on
// synthetic renders with known means, the stack command, and its errors.

#include <fstream>

#include "image/image.h"
#include "image/image_io.h"
#include "test_commands.h"

using namespace implicit;
using namespace implicit_test;

// A 4x2 mask: region 1 on the left half, region 2 on the right half but for
// one uncounted pixel (0).
static void write_mask(const std::filesystem::path& dir) {
  auto pgm = std::ofstream(dir / "regions.pgm", std::ios::binary);
  pgm << "P5\n4 2\n255\n";
  auto ids = std::string{"\x01\x01\x02\x02\x01\x01\x02\x00", 8};
  pgm << ids;
  auto names = std::ofstream(dir / "regions.txt");
  names << "left\nright\n";
}

// A render with `left` on the left half and `right` on the right half; the
// uncounted pixel gets a value that would spoil the right mean.
static std::string write_render(const std::filesystem::path& dir,
    const std::string& name, float left, float right) {
  auto image = make_image(4, 2);
  for (auto j = 0; j < 2; j++)
    for (auto i = 0; i < 4; i++) {
      auto v             = i < 2 ? left : right;
      pixel(image, i, j) = {v, v, v, 1};
    }
  pixel(image, 3, 1) = {100, 100, 100, 1};
  auto filename      = (dir / (name + ".exr")).string();
  save_image(filename, image);
  return filename;
}

static command_result run_compare(const std::string& arguments) {
  return run_command(program_path("crosscheck_compare") + " " + arguments);
}

TEST_CASE("crosscheck: region means, relative difference and its error") {
  auto dir = test_dir("crosscheck_stats");
  write_mask(dir);
  // Ours: left 0.5 and 0.75 (mean 0.625, standard error 0.125), right 0.25.
  // Reference: left 0.625, right 0.125. Binary fractions: exact sums.
  auto ours = write_render(dir, "ours_0", 0.5f, 0.25f) + " " +
              write_render(dir, "ours_1", 0.75f, 0.25f);
  auto ref = write_render(dir, "ref_0", 0.625f, 0.125f) + " " +
             write_render(dir, "ref_1", 0.625f, 0.125f);
  auto result = run_compare("--mask " + (dir / "regions.pgm").string() +
                            " --names " + (dir / "regions.txt").string() +
                            " --case synthetic --ours " + ours + " --ref " +
                            ref + " --png " + (dir / "side.png").string());
  INFO(result.output);
  REQUIRE(result.status == 0);
  // rel 0, se = 0.125 / 0.625 = 20%.
  CHECK(result.output.find(
            "| left       |     4 | 0.6250 0.6250 0.6250 | "
            "0.6250 0.6250 0.6250 |  +0.00% | 20.00% |") != std::string::npos);
  // The uncounted pixel is left out: right is 0.25 vs 0.125, +100%.
  CHECK(result.output.find(
            "| right      |     3 | 0.2500 0.2500 0.2500 | "
            "0.1250 0.1250 0.1250 | +100.00% |  0.00% |") != std::string::npos);
  auto side = load_image((dir / "side.png").string());
  CHECK(side.width == 12);
  CHECK(side.height == 2);
}

TEST_CASE("crosscheck: stack puts images of one width top to bottom") {
  auto dir    = test_dir("crosscheck_stack");
  auto a      = write_render(dir, "a", 0.25f, 0.5f);
  auto b      = write_render(dir, "b", 1.0f, 0.0f);
  auto output = (dir / "stack.exr").string();
  auto result = run_compare("stack --output " + output + " " + a + " " + b);
  INFO(result.output);
  REQUIRE(result.status == 0);
  auto stack = load_image(output);
  REQUIRE(stack.width == 4);
  REQUIRE(stack.height == 4);
  CHECK(pixel(stack, 0, 0).x == 0.25f);
  CHECK(pixel(stack, 3, 0).x == 0.5f);
  CHECK(pixel(stack, 0, 2).x == 1.0f);
  CHECK(pixel(stack, 3, 3).x == 100.0f);
}

TEST_CASE("crosscheck: bad inputs name the file and the problem") {
  auto dir = test_dir("crosscheck_errors");
  write_mask(dir);
  auto mask   = (dir / "regions.pgm").string();
  auto names  = (dir / "regions.txt").string();
  auto render = write_render(dir, "r", 0.5f, 0.5f);
  {
    auto truncated = (dir / "truncated.pgm").string();
    std::ofstream(truncated, std::ios::binary) << "P5\n4 2\n255\nabc";
    auto result =
        run_compare("--mask " + truncated + " --names " + names + " --ours " +
                    render + " " + render + " --ref " + render + " " + render);
    CHECK(result.status != 0);
    CHECK(result.output.find(truncated) != std::string::npos);
    CHECK(result.output.find("truncated") != std::string::npos);
  }
  {
    auto ascii = (dir / "ascii.pgm").string();
    std::ofstream(ascii) << "P2\n4 2\n255\n1 1 2 2 1 1 2 0\n";
    auto result =
        run_compare("--mask " + ascii + " --names " + names + " --ours " +
                    render + " " + render + " --ref " + render + " " + render);
    CHECK(result.status != 0);
    CHECK(result.output.find("expected 'P5 width height 255'") !=
          std::string::npos);
  }
  {
    auto small = make_image(2, 2);
    auto other = (dir / "small.exr").string();
    save_image(other, small);
    auto result =
        run_compare("--mask " + mask + " --names " + names + " --ours " +
                    render + " " + render + " --ref " + other + " " + render);
    CHECK(result.status != 0);
    CHECK(result.output.find(other) != std::string::npos);
    CHECK(result.output.find("size 2x2 differs from the mask's 4x2") !=
          std::string::npos);
  }
  {
    auto result = run_compare("--mask " + mask + " --names " + names +
                              " --ours " + render + " --ref " + render);
    CHECK(result.status != 0);
    CHECK(result.output.find("at least 2 renders") != std::string::npos);
  }
  {
    auto result =
        run_compare("stack --output " + (dir / "s.png").string() + " " +
                    render + " " + (dir / "small.exr").string());
    CHECK(result.status != 0);
    CHECK(result.output.find("width 2 differs from the first image's 4") !=
          std::string::npos);
  }
}
