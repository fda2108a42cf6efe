// End-to-end tests of `ypathtrace --interactive`: without a display it fails
// with one line; under Xvfb with Mesa's software OpenGL a scripted run opens
// the window, renders, and its screenshot shows exactly the pixels the
// command line renders, changing with the samples and with a camera drag.

#include <doctest/doctest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "gui/navigation.h"
#include "gui/viewer.h"
#include "image/image_io.h"

using namespace implicit;
namespace fs = std::filesystem;

#include "test_commands.h"

using namespace implicit_test;

namespace {

std::string ypathtrace_path() { return program_path("ypathtrace"); }

// An executable of that name on PATH, or "".
std::string find_program(const std::string& name) {
  auto path = std::getenv("PATH");
  if (path == nullptr) return "";
  auto rest = std::string{path};
  while (!rest.empty()) {
    auto colon = rest.find(':');
    auto dir   = rest.substr(0, colon);
    rest       = colon == std::string::npos ? "" : rest.substr(colon + 1);
    auto file  = fs::path{dir.empty() ? "." : dir} / name;
    if (access(file.c_str(), X_OK) == 0) return file.string();
  }
  return "";
}

// An Xvfb server on a display number it picks itself (-displayfd), so tests
// running in parallel never collide; killed when the test ends.
struct xvfb_server {
  xvfb_server(const xvfb_server&)            = delete;
  xvfb_server& operator=(const xvfb_server&) = delete;
  explicit xvfb_server(const std::string& program) {
    int fds[2];
    REQUIRE(pipe(fds) == 0);
    pid = fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      close(fds[0]);
      auto null = fopen("/dev/null", "w");
      if (null != nullptr) {
        dup2(fileno(null), 1);
        dup2(fileno(null), 2);
      }
      auto fd = std::to_string(fds[1]);
      execl(program.c_str(), "Xvfb", "-displayfd", fd.c_str(), "-screen", "0",
          "1920x1080x24", "-nolisten", "tcp", (char*)nullptr);
      _exit(127);
    }
    close(fds[1]);
    // Xvfb writes the display number once it accepts connections.
    auto ready  = pollfd{fds[0], POLLIN, 0};
    auto number = std::string{};
    char c      = 0;
    while (poll(&ready, 1, 20000) > 0 && read(fds[0], &c, 1) == 1 && c != '\n')
      number += c;
    close(fds[0]);
    display = number.empty() ? "" : ":" + number;
  }
  ~xvfb_server() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  }
  pid_t       pid     = -1;
  std::string display = "";
};

// The rectangle where the viewer draws an image of this size in a window
// the size of the screenshot.
image_rect viewer_rect(const image_data& screenshot, vec2i image_size) {
  return fit_image(image_size, {(float)viewer_panel_width, 0},
      {(float)(screenshot.width - viewer_panel_width),
          (float)screenshot.height});
}

// The image as the viewer shows it: the window pixel at the middle of each
// image pixel's square.
image_data shown_image(const image_data& screenshot, vec2i size) {
  auto rect  = viewer_rect(screenshot, size);
  auto image = make_image(size.x, size.y);
  for (auto j = 0; j < size.y; j++) {
    for (auto i = 0; i < size.x; i++) {
      auto x = (int)(rect.min.x + std::floor((i + 0.5f) * rect.scale));
      auto y = (int)(rect.min.y + std::floor((j + 0.5f) * rect.scale));
      pixel(image, i, j) = pixel(screenshot, x, y);
    }
  }
  return image;
}

// Pixels whose RGB differs.
int count_different(const image_data& a, const image_data& b) {
  auto count = 0;
  for (size_t idx = 0; idx < a.pixels.size(); idx++) {
    auto p = a.pixels[idx], q = b.pixels[idx];
    count += p.x != q.x || p.y != q.y || p.z != q.z;
  }
  return count;
}

// Standard deviation of the pixels' mean RGB.
double deviation(const image_data& image) {
  auto sum = 0.0, sum2 = 0.0;
  for (auto& p : image.pixels) {
    auto v = (p.x + p.y + p.z) / 3.0;
    sum += v;
    sum2 += v * v;
  }
  auto n = (double)image.pixels.size();
  return std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
}

}  // namespace

TEST_CASE("viewer: without a display --interactive fails with one line") {
  // The scene does not exist: the display is checked before loading.
  auto result =
      run_command("env -u DISPLAY -u WAYLAND_DISPLAY " + ypathtrace_path() +
                  " --scene does-not-exist.json --interactive");
  CHECK(result.status == 1);
  CHECK(result.output.find("run without --interactive") != std::string::npos);
  CHECK(result.output.find("does-not-exist") == std::string::npos);
  CHECK(result.output.find('\n') == result.output.size() - 1);
}

TEST_CASE("viewer: scripted run under Xvfb renders, accumulates and orbits") {
  auto xvfb = find_program("Xvfb");
  if (xvfb.empty()) {
    // CTest reports this test as skipped (SKIP_REGULAR_EXPRESSION).
    std::printf(
        "IMPLICIT_TEST_SKIPPED: Xvfb is not installed "
        "(scripts/install_deps.sh installs it)\n");
    std::fflush(stdout);
    return;
  }
  auto server = xvfb_server{xvfb};
  REQUIRE_MESSAGE(!server.display.empty(), "Xvfb did not start");
  auto dir    = test_dir("viewer");
  auto common = " --scene " + example_scene() + " --resolution 120";
  // Mesa's software rasterizer (llvmpipe), whatever the machine has. In
  // sanitizer builds, leak checking is off for the viewer process: Mesa's
  // driver is unloaded before LeakSanitizer reports, leaving a few hundred
  // bytes in an "unknown module" that no suppression can name. The worker's
  // and navigation's own allocations are leak-checked in-process by the
  // render_worker and navigation tests.
  auto asan   = std::getenv("ASAN_OPTIONS");
  auto viewer = "env DISPLAY=" + server.display + " LIBGL_ALWAYS_SOFTWARE=1 " +
                "ASAN_OPTIONS=" + (asan ? std::string{asan} + ":" : "") +
                "detect_leaks=0 timeout 120 " + ypathtrace_path() + common +
                " --interactive --frames 2 --output " +
                (dir / "saved.png").string();
  auto run_viewer = [&](const std::string& options, const std::string& name) {
    auto result = run_command(
        viewer + options + " --screenshot " + (dir / name).string());
    INFO(result.output);
    REQUIRE(result.status == 0);
    return load_image((dir / name).string());
  };
  auto run_cli = [&](const std::string& options, const std::string& name) {
    auto result = run_command(ypathtrace_path() + common + options +
                              " --quiet --output " + (dir / name).string());
    INFO(result.output);
    REQUIRE(result.status == 0);
    return load_image((dir / name).string());
  };

  auto cli1 = run_cli(" --samples 1", "cli1.png");
  auto cli4 = run_cli(" --samples 4", "cli4.png");
  REQUIRE(cli4.width == 120);
  REQUIRE(cli4.height == 50);
  auto size = vec2i{cli4.width, cli4.height};
  CHECK(deviation(cli4) > 0.05);  // a picture, not a flat colour

  auto shot1 = run_viewer(" --samples 1", "viewer1.tga");
  auto shot4 = run_viewer(" --samples 4", "viewer4.tga");
  CHECK(shot4.width == 1280 + viewer_panel_width);
  CHECK(shot4.height == 720);
  // The image area shows exactly what the command line renders.
  auto shown1 = shown_image(shot1, size);
  auto shown4 = shown_image(shot4, size);
  CHECK(count_different(shown1, cli1) == 0);
  CHECK(count_different(shown4, cli4) == 0);
  // Accumulating samples changes most pixels.
  CHECK(count_different(shown1, shown4) > size.x * size.y / 2);
  // Denoised: the last pass shows the command line's denoised image.
  auto cliD   = run_cli(" --samples 4 --denoise", "cliD.png");
  auto shotD  = run_viewer(" --samples 4 --denoise", "viewerD.tga");
  auto shownD = shown_image(shotD, size);
  CHECK(count_different(shownD, cliD) == 0);
  CHECK(count_different(shownD, shown4) > size.x * size.y / 4);

  // A drag to the right turns the camera: most pixels change, and the image
  // is still a picture.
  auto orbit =
      run_viewer(" --samples 4 --orbit 60,0 --orbit-frame 2", "orbit4.tga");
  auto shownO = shown_image(orbit, size);
  CHECK(count_different(shownO, shown4) > size.x * size.y / 2);
  CHECK(deviation(shownO) > 0.05);
  // The panel is drawn: its strip is not a flat colour.
  auto panel = make_image(viewer_panel_width, shot4.height);
  for (auto j = 0; j < panel.height; j++)
    for (auto i = 0; i < panel.width; i++)
      pixel(panel, i, j) = pixel(shot4, i, j);
  CHECK(deviation(panel) > 0.01);
}
