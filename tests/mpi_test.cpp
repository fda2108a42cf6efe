// End-to-end tests of distributed rendering (ypathtrace under mpirun) and of
// --turntable sequences. The scene is written by the tests: an SDFGen grid,
// a PNG texture one folder up from the scene (a "../" uri), a light.

#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "image/image_io.h"
#include "math/math.h"
#include "test_commands.h"
#include "trace/render_queue.h"

namespace fs = std::filesystem;
using namespace implicit_test;

namespace {

// Whole file as bytes ("" when missing).
std::string read_file_bytes(const fs::path& path) {
  auto stream = std::ifstream(path, std::ios::binary);
  return std::string{std::istreambuf_iterator<char>(stream), {}};
}

// A camera frame as JSON, exactly (9 significant digits round-trip floats).
std::string frame_json(const implicit::frame3f& frame) {
  auto text = std::string{"["};
  for (auto v : {frame.x, frame.y, frame.z, frame.o}) {
    for (auto c : {v.x, v.y, v.z}) {
      char buffer[32];
      std::snprintf(buffer, sizeof(buffer), "%.9g", c);
      text += (text.size() > 1 ? ", " : "") + std::string{buffer};
    }
  }
  return text + "]";
}

const auto test_camera =
    implicit::frame3f{{1, 0, 0}, {0, 0.9721864f, -0.2342085f},
        {0, 0.2342085f, 0.9721864f}, {0.1f, 0.6f, 2.2f}};
constexpr auto test_focus = 2.2f;

// Write the test scene under `dir`: scene/scene.json, scene/grids/ball.sdf
// and textures/checker.png. Returns the scene's path.
std::string write_test_scene(
    const fs::path& dir, const implicit::frame3f& camera = test_camera) {
  fs::create_directories(dir / "scene" / "grids");
  fs::create_directories(dir / "textures");
  // A ball of radius 0.3 sampled on 12^3 points spaced 0.06 (SDFGen text).
  auto grid = std::ofstream(dir / "scene" / "grids" / "ball.sdf");
  auto n    = 12;
  auto dx   = 0.06f;
  grid << n << " " << n << " " << n << "\n0 0 0\n" << dx << "\n";
  for (auto k = 0; k < n; k++)
    for (auto j = 0; j < n; j++)
      for (auto i = 0; i < n; i++) {
        auto c = (n - 1) * dx / 2;
        grid << std::hypot(i * dx - c, j * dx - c, k * dx - c) - 0.3f << "\n";
      }
  grid.close();
  // A 4x4 checker texture.
  auto checker = implicit::make_image(4, 4);
  for (auto j = 0; j < 4; j++)
    for (auto i = 0; i < 4; i++)
      checker.pixels[j * 4 + i] = (i + j) % 2
                                      ? implicit::vec4f{0.9f, 0.2f, 0.1f, 1}
                                      : implicit::vec4f{0.1f, 0.3f, 0.9f, 1};
  implicit::save_image((dir / "textures" / "checker.png").string(), checker);
  auto scene = std::ofstream(dir / "scene" / "scene.json");
  scene << R"({
  "asset": {"version": "4.2"},
  "cameras": [{"name": "default", "frame": )"
        << frame_json(camera) << R"(, "aspect": 1.5, "lens": 0.04, "focus": )"
        << test_focus << R"(}],
  "textures": [{"name": "checker", "uri": "../textures/checker.png"}],
  "environments": [{"name": "sky", "emission": [0.3, 0.3, 0.35]}],
  "materials": [
    {"name": "floor", "color": [0.8, 0.8, 0.8], "color_tex": 0},
    {"name": "ball", "type": "glossy", "color": [0.8, 0.5, 0.2], "roughness": 0.3},
    {"name": "light", "emission": [10, 10, 10]}
  ],
  "volumes": [{"name": "ball", "uri": "grids/ball.sdf", "binary": false}],
  "vol_instances": [{"name": "ball", "volume": 0, "material": 1, "scale": 1,
    "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1, -0.33, 0, -0.33]}],
  "sdfunctions": [
    {"name": "floor", "type": "box", "whd": [4, 0.00001, 4], "material": 0,
     "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]},
    {"name": "light", "type": "box", "whd": [0.6, 0.00001, 0.6], "material": 2,
     "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 1.5, 0]}
  ]
})";
  scene.close();
  return (dir / "scene" / "scene.json").string();
}

// ypathtrace on one process.
command_result run_single(const std::string& arguments) {
  return run_command(program_path("ypathtrace") + " " + arguments);
}

#ifdef IMPLICIT_MPIEXEC
// ypathtrace on `ranks` processes of this machine. Leak checking is off: the
// MPI runtime does not free everything before exit.
// `wrapper` runs before ypathtrace on every rank (it must exec it).
command_result run_mpi(int ranks, const std::string& arguments,
    const std::string& environment = "", const std::string& wrapper = "") {
  return run_command(
      "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
      "OMPI_MCA_rmaps_base_oversubscribe=1 ASAN_OPTIONS=detect_leaks=0 " +
      environment + " timeout 120 " + IMPLICIT_MPIEXEC + " -np " +
      std::to_string(ranks) + " " + wrapper + " " + program_path("ypathtrace") +
      " " + arguments);
}
#endif

// Print the ctest skip marker; true when the MPI tests cannot run.
bool skip_without_mpi() {
#ifdef IMPLICIT_MPIEXEC
  return false;
#else
  std::printf(
      "IMPLICIT_TEST_SKIPPED: built without MPI or mpirun "
      "(scripts/install_deps.sh installs OpenMPI)\n");
  std::fflush(stdout);
  return true;
#endif
}

// The camera of frame `frame` of the test scene's orbit, as the library
// computes it (its orbit is tested in src/trace/render_queue_test.cpp).
implicit::frame3f orbit_frame(int frame, int frames) {
  auto camera  = implicit::camera_data{};
  camera.frame = test_camera;
  camera.focus = test_focus;
  return implicit::turntable_camera(camera, frame, frames).frame;
}

}  // namespace

TEST_CASE("mpi: images are byte-identical to one process at any rank count") {
  if (skip_without_mpi()) return;
  auto dir   = test_dir("mpi_identical");
  auto scene = write_test_scene(dir);
  // 45x30 pixels: not a multiple of 16-pixel tiles (6 tiles), and with
  // 32-pixel tiles only 2 tiles for 3 and 5 ranks. With --savebatch a tile's
  // sums and random streams move between ranks; the random sampler uses the
  // streams, Sobol points do not.
  auto common = " --scene " + scene +
                " --resolution 45 --samples 5 --savebatch 2 --quiet";
  // Sobol also with every AOV layer and adaptive sampling: the per-pixel
  // counts and statistics move with the sums.
  auto clean = std::string{
      " --aov albedo,normal,depth,position,variance --noise-threshold 0.3 "
      "--min-samples 2"};
  for (auto [sampler, tile] : {std::pair{"random", 16}, {"sobol", 32}}) {
    auto options = common + " --sampler " + sampler +
                   (std::string{sampler} == "sobol" ? clean : "");
    auto prefix   = std::string{sampler} + "-single";
    auto expected = (dir / (prefix + ".exr")).string();
    auto single   = run_single(options + " --output " + expected);
    REQUIRE_MESSAGE(single.status == 0, single.output);
    for (auto ranks : {1, 2, 3, 5}) {
      auto name   = std::string{sampler} + "-mpi" + std::to_string(ranks);
      auto output = (dir / (name + ".exr")).string();
      auto result =
          run_mpi(ranks, options + " --tilesize " + std::to_string(tile) +
                             " --output " + output);
      INFO(name, ": ", result.output);
      REQUIRE(result.status == 0);
      CHECK(read_file_bytes(output) == read_file_bytes(expected));
      for (auto batch : {"-s0002.exr", "-s0004.exr"}) {
        auto image   = read_file_bytes(dir / (name + batch));
        auto missing = name + batch + " was not written";
        CHECK_MESSAGE(!image.empty(), missing);
        CHECK(image == read_file_bytes(dir / (prefix + batch)));
      }
    }
  }
}

TEST_CASE("mpi: a bad scene gives one error line and a non-zero exit") {
  if (skip_without_mpi()) return;
  auto dir    = test_dir("mpi_bad");
  auto output = (dir / "out.exr").string();
  auto bad    = dir / "bad.json";
  std::ofstream(bad) << R"({"materials": [{"name": "m", "type": "plastic"}]})";
  for (auto scene : {bad.string(), (dir / "missing.json").string()}) {
    auto result = run_mpi(3, "--scene " + scene + " --output " + output);
    INFO(result.output);
    CHECK(result.status != 0);
    auto count = 0, start = 0;
    auto lines = std::istringstream{result.output};
    for (auto line = std::string{}; std::getline(lines, line);) {
      if (line.find("ypathtrace: error:") != std::string::npos) count++;
      if (line.rfind("ypathtrace: error:", 0) == 0) start++;
    }
    CHECK(count == 1);
    CHECK(start == 1);
    CHECK(!fs::exists(output));
  }
  // A bad option is reported once too.
  auto option = run_mpi(2, "--samples 0 --output " + output);
  auto first  = option.output.find("ypathtrace: error:");
  CHECK(option.status != 0);
  CHECK(first != std::string::npos);
  CHECK(
      option.output.find("ypathtrace: error:", first + 1) == std::string::npos);
}

TEST_CASE("mpi: a rank that dies mid-render fails the run, with no output") {
  if (skip_without_mpi()) return;
  auto dir    = test_dir("mpi_crash");
  auto scene  = write_test_scene(dir);
  auto output = dir / "out.exr";
  // Rank 1 is killed (SIGKILL, as a crashed machine) a second after it
  // starts, in the middle of a render far too long to finish by then (280
  // tiles of 100,000 samples, one thread): mpirun sees it die and ends the
  // job. The wrapper execs ypathtrace, so the kill reaches the rank itself;
  // the binary has no test hook.
  fs::create_directories(dir / "bin");
  auto wrapper = dir / "bin" / "kill_rank1.sh";
  std::ofstream(wrapper) << "#!/bin/sh\n"
                            "if [ \"$OMPI_COMM_WORLD_RANK\" = 1 ]; then\n"
                            "  (sleep 1; kill -9 $$) &\n"
                            "fi\n"
                            "exec \"$@\"\n";
  fs::permissions(wrapper, fs::perms::owner_all);
  auto result = run_mpi(2,
      "--scene " + scene + " --resolution 160 --samples 100000 --tilesize 8 " +
          "--threads 1 --quiet --output " + output.string(),
      "", wrapper.string());
  INFO(result.output);
  CHECK(result.status != 0);
  CHECK(result.status != 124);  // ended by the failure, not by the timeout
  CHECK(!fs::exists(output));
  for (auto& entry : fs::directory_iterator(dir))
    CHECK_MESSAGE(!entry.is_regular_file(), entry.path());  // no partial file
}

TEST_CASE("turntable: frames equal single renders with the orbit's cameras") {
  auto dir    = test_dir("turntable");
  auto common = std::string{" --resolution 30 --samples 3 --quiet"};
  auto scene  = write_test_scene(dir / "orbit");
  auto result =
      run_single("--scene " + scene + common + " --turntable 4 --output " +
                 (dir / "seq.exr").string());
  REQUIRE_MESSAGE(result.status == 0, result.output);
  for (auto frame = 0; frame < 4; frame++) {
    auto name     = "frame" + std::to_string(frame);
    auto single   = write_test_scene(dir / name, orbit_frame(frame, 4));
    auto expected = (dir / (name + ".exr")).string();
    auto render =
        run_single("--scene " + single + common + " --output " + expected);
    REQUIRE_MESSAGE(render.status == 0, render.output);
    auto number = "-000" + std::to_string(frame) + ".exr";
    INFO(name);
    CHECK(read_file_bytes(dir / ("seq" + number)) == read_file_bytes(expected));
  }
  // Restarting skips the frames already written: a stand-in frame 1 stays,
  // a deleted frame 2 is rendered again.
  std::ofstream(dir / "seq-0001.exr") << "stand-in";
  auto frame2 = read_file_bytes(dir / "seq-0002.exr");
  fs::remove(dir / "seq-0002.exr");
  result = run_single("--scene " + scene + common + " --turntable 4 --output " +
                      (dir / "seq.exr").string());
  REQUIRE_MESSAGE(result.status == 0, result.output);
  CHECK(read_file_bytes(dir / "seq-0001.exr") == "stand-in");
  CHECK(read_file_bytes(dir / "seq-0002.exr") == frame2);
#ifdef IMPLICIT_MPIEXEC
  // Distributed: whole frames over 2 ranks, and tiles over 5 ranks.
  for (auto ranks : {2, 5}) {
    auto output = (dir / ("mpi" + std::to_string(ranks) + ".exr")).string();
    auto mpi =
        run_mpi(ranks, "--scene " + scene + common +
                           " --tilesize 16 --turntable 4 --output " + output);
    REQUIRE_MESSAGE(mpi.status == 0, mpi.output);
    for (auto frame = 0; frame < 4; frame++) {
      auto number = "-000" + std::to_string(frame) + ".exr";
      CHECK(read_file_bytes(dir / ("mpi" + std::to_string(ranks) + number)) ==
            read_file_bytes(dir / ("frame" + std::to_string(frame) + ".exr")));
    }
  }
#endif
}
