// # implicit: fuzz target for scene JSON, through a tiny render
//
// parse_scene() validates the JSON; then the scene is rendered at 8 pixels,
// 1 sample, 2 bounces, so that what the loader lets through (NaN, huge or
// degenerate sizes, deep CSG) reaches make_accel(), make_lights() and the
// tracer. Referenced files are not loaded (the file loaders have their own
// targets, and a fuzzed path could name any file on the machine): each
// texture and grid gets small stand-in data, as if its file had loaded.

#include <tbb/global_control.h>

#include <memory>
#include <utility>

#include "../src/scene/scene_io.h"
#include "../src/sdf/sdf_grid.h"
#include "../src/trace/render.h"
#include "fuzz_common.h"

// What a loaded texture or grid file would have given.
static void add_stand_in_files(implicit::scene_data& scene) {
  using namespace implicit;
  for (auto& texture : scene.textures) {
    texture.image = make_image(4, 2);
    for (size_t i = 0; i < texture.image.pixels.size(); i++)
      texture.image.pixels[i] = {0.1f * i, 0.5f, 1.0f / (1 + i), 1};
  }
  for (auto& volume : scene.volumes) {
    auto grid = make_grid({4, 4, 4}, 0.25f, {-0.5f, -0.5f, -0.5f}, 0);
    for (auto k = 0; k < 4; k++)
      for (auto j = 0; j < 4; j++)
        for (auto i = 0; i < 4; i++)
          grid.values[(k * 4 + j) * 4 + i] =
              length(vec3f{i - 1.5f, j - 1.5f, k - 1.5f}) * 0.25f - 0.3f;
    update_grid_accel(grid);
    volume.grid = std::make_shared<const grid_data>(std::move(grid));
  }
}

// Scene files this large only parse and render slower; the loader has no
// size limit of its own to reach.
static constexpr size_t max_scene_bytes = 64 * 1024;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace implicit;
  if (size > max_scene_bytes) return 0;
  // One thread: deterministic coverage and no thread pool per input.
  static auto threads =
      tbb::global_control(tbb::global_control::max_allowed_parallelism, 1);
  auto text = std::string((const char*)data, size);
  try {
    auto warnings = std::vector<std::string>{};
    auto scene    = parse_scene(text, "fuzz.json", warnings, false);
    add_stand_in_files(scene);
    auto params       = trace_params{};
    params.resolution = 8;
    params.samples    = 1;
    params.bounces    = 2;
    auto context      = make_render_context(std::move(scene), params);
    auto image        = image_data{};
    render_image(*context, params, image);
  } catch (const io_error&) {
    // The expected outcome for a malformed scene.
  }
  return 0;
}
