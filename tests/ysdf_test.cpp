// End-to-end tests of the ysdf command: info, convert, bake, meshes, errors.

#include <doctest/doctest.h>

#include <algorithm>

#include <filesystem>
#include <fstream>
#include <string>

#include "sdf/sdf_grid_io.h"
#include "shared_data.h"
#include "test_commands.h"

using namespace implicit;
using namespace implicit_test;

namespace {

command_result run_ysdf(const std::string& arguments) {
  return run_command(program_path("ysdf") + " " + arguments);
}

std::string shared_sample(const std::string& name) {
  return std::string{IMPLICIT_SHARED_DIR} + "/sdf_samples/" + name;
}

// A sample grid of ../shared, or without it a sphere baked by ysdf into
// `dir` (SDFGen text, as the samples used here).
std::string sample_or_baked(
    const std::string& name, const std::filesystem::path& dir) {
  if (std::filesystem::is_directory(IMPLICIT_SHARED_DIR))
    return shared_sample(name);
  auto grid   = (dir / "baked_sphere.sdf").string();
  auto result = run_ysdf("--quiet bake " + grid +
                         " --voxel 0.05 --pad 2 --shape \"sphere radius=0.5\"");
  INFO(result.output);
  REQUIRE(result.status == 0);
  return grid;
}

}  // namespace

TEST_CASE("ysdf: info reports dims, spacing and the surface") {
  IMPLICIT_SKIP_WITHOUT_SHARED("torus sample; the bake test runs info too");
  auto result = run_ysdf(
      "info " + shared_sample("sdfgen_torus_R0.6_r0.2_dx0.04_pad2.sdf"));
  INFO(result.output);
  CHECK(result.status == 0);
  CHECK(result.output.find("43 x 44 x 14") != std::string::npos);
  CHECK(result.output.find("spacing:  0.04") != std::string::npos);
  CHECK(result.output.find("zero crossing") != std::string::npos);
}

TEST_CASE("ysdf: convert round trips through every format") {
  auto dir    = test_dir("ysdf_convert");
  auto source = sample_or_baked("sdfgen_icosphere_r0.5_dx0.05_pad2.sdf", dir);
  auto input  = load_grid(source, grid_format::sdfgen);
  auto chain  = std::vector<std::string>{"a.vdb", "b.vol", "c.sdf"};
  auto from   = source;
  for (auto& name : chain) {
    auto to     = (dir / name).string();
    auto result = run_ysdf("--quiet convert " + from + " " + to);
    INFO(result.output);
    REQUIRE(result.status == 0);
    from = to;
  }
  auto output = load_grid(from, grid_format::sdfgen);
  CHECK(output.dims == input.dims);
  CHECK(output.spacing == doctest::Approx(input.spacing));
  // The .vdb is a narrow-band level set: values within 3 voxels of the
  // surface are kept, the others become +-3 voxels with their sign.
  auto band  = 3 * input.spacing;
  auto worst = 0.0f;
  for (size_t i = 0; i < input.values.size(); i++) {
    auto expected = std::clamp(input.values[i], -band, band);
    worst         = std::max(worst, std::abs(output.values[i] - expected));
  }
  CHECK(worst < 1e-5f);  // SDFGen text keeps 6+ significant digits
  auto info = run_ysdf("info " + (dir / "a.vdb").string());
  INFO(info.output);
  CHECK(info.output.find("band:     +-0.15 (background, 3 voxels)") !=
        std::string::npos);
  CHECK(info.output.find("active:   ") != std::string::npos);
}

TEST_CASE("ysdf: bake a sphere and mesh it") {
  auto dir    = test_dir("ysdf_bake");
  auto grid   = (dir / "sphere.sdf").string();
  auto result = run_ysdf("--quiet bake " + grid +
                         " --voxel 0.05 --pad 2 --shape \"sphere radius=0.5\"");
  INFO(result.output);
  REQUIRE(result.status == 0);
  auto baked = load_grid(grid, grid_format::sdfgen);
  // The sample nearest the centre is about -radius.
  auto lowest = 0.0f;
  for (auto v : baked.values) lowest = std::min(lowest, v);
  CHECK(lowest == doctest::Approx(-0.5f).epsilon(0.1).scale(0));
  auto info = run_ysdf("info " + grid);
  INFO(info.output);
  CHECK(info.status == 0);
  CHECK(info.output.find("spacing:  0.05") != std::string::npos);
  CHECK(info.output.find("zero crossing") != std::string::npos);
  auto mesh = (dir / "sphere.obj").string();
  result    = run_ysdf("--quiet to-mesh " + grid + " " + mesh);
  INFO(result.output);
  CHECK(result.status == 0);
  CHECK(std::filesystem::file_size(mesh) > 1000);
}

TEST_CASE("ysdf: errors are one line and exit 1") {
  auto dir = test_dir("ysdf_errors");
  auto bad = dir / "junk.sdf";
  std::ofstream(bad) << "2 2 2\n0 0 0\n0.1\n1 2 3 x 5 6 7 8\n";
  auto result = run_ysdf("info " + bad.string());
  CHECK(result.status == 1);
  CHECK(result.output.rfind("ysdf: ", 0) == 0);
  CHECK(result.output.find("junk.sdf") != std::string::npos);
  result = run_ysdf("info " + (dir / "missing.vdb").string());
  CHECK(result.status != 0);
  CHECK(result.output.find("missing.vdb") != std::string::npos);
  result = run_ysdf("convert " +
                    sample_or_baked("mitsuba_sdfgrid_sphere_48.vol", dir) +
                    " " + (dir / "out.xyz").string());
  CHECK(result.status != 0);
  CHECK(!std::filesystem::exists(dir / "out.xyz"));
}

TEST_CASE("ysdf: expressions, .vm files and the types table") {
  auto dir   = test_dir("ysdf_expressions");
  auto types = run_ysdf("types");
  CHECK(types.status == 0);
  for (auto word : {"sphere", "radius (number, > 0)", "twist", "repeat",
           "limit", "optional", "expression", "displace", "opElongate"})
    CHECK(types.output.find(word) != std::string::npos);
  auto result = run_ysdf("bake " + (dir / "a.vdb").string() +
                         " --voxel 0.1 --expression \"max(x, (y\"");
  CHECK(result.status == 1);
  CHECK(result.output == "ysdf: --expression: column 10: expected ')'\n");
  result = run_ysdf("bake " + (dir / "a.vdb").string() +
                    " --voxel 0.1 --expression x --shape \"sphere "
                    "radius=1\"");
  CHECK(result.output ==
        "ysdf: bake: give one of --scene, --expression, --vm or one or more "
        "--shape\n");
  std::ofstream(dir / "bad.vm") << "_x var-x\n_y foo _x\n";
  result = run_ysdf("bake " + (dir / "a.vdb").string() + " --voxel 0.1 --vm " +
                    (dir / "bad.vm").string());
  CHECK(result.output ==
        "ysdf: " + (dir / "bad.vm").string() + ":2: unknown opcode \"foo\"\n");
  result = run_ysdf(
      "to-mesh " + (dir / "bad.vm").string() + " " + (dir / "a.obj").string());
  CHECK(result.output ==
        "ysdf: to-mesh: a scene or .vm file needs --voxel > 0\n");
  result = run_ysdf("to-mesh " + (dir / "bad.vm").string() + " " +
                    (dir / "a.obj").string() + " --voxel 0.1");
  CHECK(result.output ==
        "ysdf: " + (dir / "bad.vm").string() + ":2: unknown opcode \"foo\"\n");
  CHECK(!std::filesystem::exists(dir / "a.obj"));
  CHECK(!std::filesystem::exists(dir / "a.vdb"));
}

TEST_CASE("ysdf: --shape reads primitives as scene files do") {
  auto dir  = test_dir("ysdf_shape");
  auto out  = (dir / "a.vdb").string();
  auto bake = [&](const std::string& shape) {
    return run_ysdf("bake " + out + " --voxel 0.1 --shape \"" + shape + "\"");
  };
  // The JSON keys and the table's ranges and cross checks, with the scene
  // loader's messages.
  auto result = bake("capsule radius=0.2 height=-1");
  CHECK(result.status == 1);
  CHECK(result.output ==
        "ysdf: --shape \"capsule radius=0.2 height=-1\": height: must be > 0, "
        "found -1\n");
  result = bake("box size=1,1,1");
  CHECK(result.output ==
        "ysdf: --shape \"box size=1,1,1\": size: unknown key for type "
        "\"box\" (valid keys: whd)\n");
  result = bake("box whd=1,1");
  CHECK(result.output.find("whd") != std::string::npos);
  CHECK(result.status == 1);
  result = bake("sphere radius=one");
  CHECK(result.output.find("--shape \"sphere radius=one\": radius:") !=
        std::string::npos);
  result = bake("sphere");
  CHECK(result.output ==
        "ysdf: --shape \"sphere\": radius: missing required parameter\n");
  result = bake("union radius=1");
  CHECK(result.output.find("unknown type \"union\"") != std::string::npos);
  result = bake("sphere radius=1 frame=1");
  CHECK(result.output ==
        "ysdf: --shape \"sphere radius=1 frame=1\": frame: unknown key for "
        "type \"sphere\" (valid keys: radius)\n");
  result = bake("sphere radius=1 at=1,2");
  CHECK(result.output ==
        "ysdf: --shape \"sphere radius=1 at=1,2\": at: needs 3 numbers x,y,z, "
        "found '1,2'\n");
  CHECK(!std::filesystem::exists(out));
  result = bake("box whd=0.4,0.6,0.8 at=0.1,0,0");
  INFO(result.output);
  CHECK(result.status == 0);
  CHECK(std::filesystem::exists(out));
}
