// End-to-end tests of the ypathtrace command: options, errors, outputs.

#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "image/image_io.h"

namespace fs = std::filesystem;

#include "test_commands.h"

using namespace implicit_test;

namespace {

std::string ypathtrace_path() { return program_path("ypathtrace"); }

// Run ypathtrace with arguments (already quoted where needed).
command_result run_ypathtrace(const std::string& arguments) {
  return run_command(ypathtrace_path() + " " + arguments);
}

}  // namespace

TEST_CASE("cli: help prints usage and succeeds") {
  auto result = run_ypathtrace("--help");
  CHECK(result.status == 0);
  CHECK(result.output.find("--scene") != std::string::npos);
  CHECK(result.output.find("--stmaxiter") != std::string::npos);
}

TEST_CASE("cli: bad options and values fail with a one-line reason") {
  auto dir = test_dir("cli_bad");
  auto out = (dir / "out.png").string();
  for (auto args : {std::string{"--bogus"}, std::string{"--samples 0"},
           std::string{"--samples abc"}, std::string{"--resolution -5"},
           std::string{"--shader nope"}, std::string{"--accel fast"},
           std::string{"--clamp -1"}, std::string{"--output out.gif"},
           std::string{"--stmaxiter 0"}, std::string{"--mis three"},
           std::string{"--sampler halton"}, std::string{"--lightsampler all"},
           std::string{"--seed -1"}, std::string{"--samples 4294967297"},
           std::string{"--filmic=3"}, std::string{"--samples 1e3"},
           std::string{"--aov albedo,bogus"}, std::string{"--aov ,"},
           std::string{"--noise-threshold -0.01"},
           std::string{"--noise-threshold nan"},
           std::string{"--min-samples -1"}, std::string{"--time -1"}}) {
    auto result = run_ypathtrace(
        "--scene " + example_scene() + " " + args +
        (args.find("--output") == std::string::npos ? " --output " + out : ""));
    INFO(args, " -> ", result.output);
    CHECK(result.status != 0);
    CHECK(result.output.rfind("ypathtrace: error:", 0) == 0);
    CHECK(!fs::exists(out));
  }
  auto shader = run_ypathtrace("--shader nope");
  CHECK(shader.output.find("implicit_normal") !=
        std::string::npos);  // lists valid names
  auto sampler = run_ypathtrace("--sampler halton");
  CHECK(sampler.output.find("sobol") != std::string::npos);
  auto aov = run_ypathtrace("--aov albedo,bogus");
  CHECK(aov.output.find("\"bogus\"") != std::string::npos);
  CHECK(aov.output.find("position") != std::string::npos);  // lists names
}

TEST_CASE("cli: a bad option prints its reason and where to look, not usage") {
  // Two lines, as git and CMake answer: the usage would scroll the reason
  // out of sight.
  for (auto args : {"--bogus", "--samples 0", "--samples abc", "--shader nope",
           "--clamp nan", "--output out.gif"}) {
    auto result = run_ypathtrace(args);
    INFO(args, " -> ", result.output);
    CHECK(result.status == 2);
    CHECK(std::count(result.output.begin(), result.output.end(), '\n') == 2);
    CHECK(result.output.find("\nRun 'ypathtrace --help' for the options.\n") !=
          std::string::npos);
    CHECK(result.output.find("Usage") == std::string::npos);
  }
  auto samples = run_ypathtrace("--samples 0");
  CHECK(samples.output.rfind(
            "ypathtrace: error: --samples: 0 is out of range [1, 1048576]\n",
            0) == 0);
  auto text = run_ypathtrace("--samples abc");
  CHECK(
      text.output.rfind(
          "ypathtrace: error: --samples: \"abc\" is not an integer\n", 0) == 0);
}

TEST_CASE("cli: --help lists the option table with ranges and defaults") {
  auto help = run_ypathtrace("--help").output;
  CHECK(help.find("--samples N") != std::string::npos);
  CHECK(help.find("[1..1048576] (default 512)") != std::string::npos);
  CHECK(help.find("[implicit|implicit_normal|eyelight|normal|position|color|"
                  "frontfacing|material|steps] (default implicit)") !=
        std::string::npos);
  CHECK(help.find("(default 961748941)") != std::string::npos);
  CHECK(help.find("--noimplicitmis") != std::string::npos);
  CHECK(help.find("--pratio") == std::string::npos);  // the viewer's only
}

TEST_CASE("cli: missing or broken scene fails without output") {
  auto dir    = test_dir("cli_scene");
  auto out    = (dir / "out.png").string();
  auto result = run_ypathtrace(
      "--scene " + (dir / "missing.json").string() + " --output " + out);
  CHECK(result.status == 1);
  CHECK(result.output.find("missing.json") != std::string::npos);
  CHECK(!fs::exists(out));
  auto broken = dir / "broken.json";
  std::ofstream(broken) << "{ \"asset\": { \"version\": \"4.2\" }, "
                           "\"sdfunctions\": [ { \"type\": \"sphere\", ";
  result = run_ypathtrace("--scene " + broken.string() + " --output " + out);
  CHECK(result.status == 1);
  CHECK(result.output.find("broken.json") != std::string::npos);
  CHECK(!fs::exists(out));
  // Only the error line: no partial image, no temporary files left.
  CHECK(result.output.rfind("ypathtrace: error:", 0) == 0);
  CHECK(std::count(result.output.begin(), result.output.end(), '\n') == 1);
  auto files = 0;
  for (auto& entry : fs::directory_iterator(dir))
    files += entry.path() != broken;
  CHECK(files == 0);
}

TEST_CASE("cli: renders the example in every output format") {
  auto dir = test_dir("cli_render");
  for (auto ext : {".png", ".jpg", ".hdr", ".exr"}) {
    auto out    = (dir / (std::string{"example"} + ext)).string();
    auto result = run_ypathtrace("--scene " + example_scene() + " --output " +
                                 out + " --resolution 48 --samples 2 --quiet");
    INFO(result.output);
    REQUIRE(result.status == 0);
    auto image = implicit::load_image(out);
    CHECK(image.width == 48);
    CHECK(image.height == 20);
  }
}

TEST_CASE("cli: passes and --savebatch images do not change the render") {
  // 70 samples: without --savebatch two passes (64 + 6), with --savebatch 1
  // seventy; each pixel sums the same samples in the same order either way.
  auto dir    = test_dir("cli_passes");
  auto render = [&](const std::string& name, const std::string& options) {
    auto out    = (dir / name).string();
    auto result = run_ypathtrace("--scene " + example_scene() + " --output " +
                                 out + " --resolution 16 --quiet " + options);
    INFO(result.output);
    REQUIRE(result.status == 0);
    return implicit::load_image(out).pixels;
  };
  auto same = [](const std::vector<implicit::vec4f>&  a,
                  const std::vector<implicit::vec4f>& b) {
    return a.size() == b.size() &&
           std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
  };
  auto passes  = render("passes.exr", "--samples 70");
  auto batches = render("batches.exr", "--samples 70 --savebatch 1");
  CHECK(same(passes, batches));
  auto three = render("three.exr", "--samples 3");
  CHECK(same(implicit::load_image((dir / "batches-s0003.exr").string()).pixels,
      three));
  CHECK(fs::exists(dir / "batches-s0069.exr"));
  CHECK(!fs::exists(dir / "batches-s0070.exr"));  // the final image instead
  CHECK(!fs::exists(dir / "passes-s0064.exr"));
  // Adaptive sampling decides at fixed samples: batches change nothing, a
  // time budget that is not reached neither.
  auto adaptive = std::string{"--samples 40 --noise-threshold 0.1"};
  auto whole    = render("adaptive.exr", adaptive);
  CHECK(
      same(whole, render("adaptive-batches.exr", adaptive + " --savebatch 3")));
  CHECK(same(whole, render("adaptive-time.exr", adaptive + " --time 1e6")));
  CHECK(!same(whole, passes));
}

TEST_CASE("cli: a scene without lights falls back to eyelight") {
  auto dir   = test_dir("cli_nolights");
  auto scene = dir / "dark.json";
  std::ofstream(scene) << R"({
    "asset": {"version": "4.2"},
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [{"name": "ball", "type": "sphere", "radius": 1, "material": 0,
                     "frame": [1,0,0, 0,1,0, 0,0,1, 0,0,0]}]
  })";
  auto out    = (dir / "dark.png").string();
  auto result = run_ypathtrace("--scene " + scene.string() + " --output " +
                               out + " --resolution 32 --samples 2");
  INFO(result.output);
  CHECK(result.status == 0);
  CHECK(result.output.find("no lights") != std::string::npos);
  auto image = implicit::load_image(out);
  // The ball is lit by the eye light: the centre is bright.
  CHECK(implicit::pixel(image, 16, 9).x > 0.3f);
}

TEST_CASE("cli: NaN and infinite values are refused") {
  auto dir = test_dir("cli_nan");
  auto out = (dir / "out.png").string();
  for (auto args : {"--clamp nan", "--clamp inf", "--exposure inf",
           "--exposure nan", "--exposure -inf", "--clamp 0"}) {
    auto result = run_ypathtrace(
        "--scene " + example_scene() + " " + args + " --output " + out);
    INFO(args, " -> ", result.output);
    CHECK(result.status == 2);
    CHECK(result.output.rfind("ypathtrace: error:", 0) == 0);
    auto name = std::string{args}.substr(2, std::string{args}.find(' ') - 2);
    CHECK(result.output.find(name) != std::string::npos);
    CHECK(!fs::exists(out));
  }
}

TEST_CASE("cli: the output is checked before rendering") {
  auto dir = test_dir("cli_output");
  // A missing folder and a folder that cannot be written fail at once, with
  // a render too long to finish in the test's time if it started.
  auto slow    = " --resolution 2000 --samples 100000 --quiet";
  auto missing = run_ypathtrace("--scene " + example_scene() + " --output " +
                                (dir / "nowhere" / "out.png").string() + slow);
  INFO(missing.output);
  CHECK(missing.status == 2);
  CHECK(missing.output.find("does not exist") != std::string::npos);
  // A file where the folder should be.
  std::ofstream(dir / "file") << "x";
  auto notdir = run_ypathtrace("--scene " + example_scene() + " --output " +
                               (dir / "file" / "out.png").string() + slow);
  CHECK(notdir.status == 2);
  CHECK(notdir.output.find("does not exist") != std::string::npos);
  // A folder without write permission (root writes anywhere: not tested).
  if (geteuid() != 0) {
    auto locked = dir / "locked";
    fs::create_directories(locked);
    fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    auto readonly = run_ypathtrace("--scene " + example_scene() + " --output " +
                                   (locked / "out.png").string() + slow);
    fs::permissions(locked, fs::perms::owner_all);
    INFO(readonly.output);
    CHECK(readonly.status == 2);
    CHECK(readonly.output.find("not writable") != std::string::npos);
    CHECK(fs::is_empty(locked));
  }
  auto format = run_ypathtrace("--scene " + example_scene() + " --output " +
                               (dir / "out.bmpx").string() + slow);
  CHECK(format.status == 2);
  CHECK(format.output.find("unsupported image format") != std::string::npos);
}

TEST_CASE("cli: an interrupted render writes nothing half-done") {
  // A single image and a sequence stop the same way, between blocks of
  // pixels: the batch images already saved stay, nothing else is written.
  for (auto sequence : {false, true}) {
    for (auto signal : {"INT", "TERM"}) {
      INFO("SIG", signal, sequence ? " sequence" : " image");
      auto dir = test_dir(std::string{"cli_interrupt_"} + signal +
                          (sequence ? "_sequence" : ""));
      auto out = (dir / "out.png").string();
      // Wait for the first complete batch, then interrupt (`timeout`
      // passes the signal on, and ends a render that ignores it).
      auto script = "timeout 120 " + ypathtrace_path() + " --scene " +
                    example_scene() + " --output " + out +
                    " --resolution 32 --samples 1000000 --savebatch 1 " +
                    (sequence ? "--turntable 3 " : "") +
                    "--quiet & pid=$!; for i in $(seq 1 600); do ls " +
                    dir.string() +
                    "/out-*s*.png >/dev/null 2>&1 && break; "
                    "sleep 0.05; done; sleep 0.2; kill -" +
                    signal + " $pid; wait $pid; echo exit=$?";
      auto result = run_command("bash -c '" + script + "'");
      INFO(result.output);
      CHECK(result.output.find("exit=130") != std::string::npos);
      CHECK(result.output.find("interrupted") != std::string::npos);
      CHECK(!fs::exists(out));
      CHECK(!fs::exists(dir / "out-0000.png"));
      auto batches = 0, temporaries = 0;
      for (auto& entry : fs::directory_iterator(dir)) {
        auto name   = entry.path().filename().string();
        auto prefix = sequence ? "out-0000-s" : "out-s";
        if (name.rfind(prefix, 0) == 0) {
          batches++;
          auto image = implicit::load_image(entry.path().string());
          CHECK(image.width == 32);
        } else {
          temporaries++;
        }
      }
      CHECK(batches >= 1);
      CHECK(temporaries == 0);
    }
  }
}
