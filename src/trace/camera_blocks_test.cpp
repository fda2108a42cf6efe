// Tests of the camera's first pass: no camera ray of a block meets a
// surface before the block's start (rays through the corners of each pixel,
// with the box and the tent filter), on a scene of a function that is no
// distance bound under a rotation and a non-uniform scale, a CSG blend with
// an octree, and a small box; the pass skips something there (blocks that
// miss, blocks that start late); rays started there find the same hits;
// cameras inside an object, with a lens or orthographic start at the camera;
// and a render gives the same image with and without the pass, whatever the
// rectangles its pixels are rendered in.

#include "camera_blocks.h"

#include <doctest/doctest.h>

#include <cstring>
#include <string>

#include "../math/random.h"
#include "../scene/scene_io.h"
#include "render.h"

using namespace implicit;

namespace {

// Three objects seen from (0.2, 0.3, 7) down -z: a quartic (no distance
// bound) rotated and stretched, a smooth union of 20 spheres (a distance
// program long enough for an octree), and a box.
std::string blocks_scene(const std::string& camera, float radius) {
  auto spheres = std::string{};
  for (auto k = 0; k < 20; k++) {
    auto x = -1.2 + 0.3 * (k % 5), y = -1.6 + 0.3 * (k / 5);
    spheres += std::string{k ? ", " : ""} + R"({"type": "sphere", "radius": )" +
               std::to_string(radius) +
               R"(, "world_from_local": [1, 0, 0, 0, 1, 0, 0, 0, 1, )" +
               std::to_string(x) + ", " + std::to_string(y) + ", 0.5]}";
  }
  return R"js({"asset": {"version": "4.2"}, "cameras": [)js" + camera +
         R"js(], "environments": [{"name": "sky", "emission": [1, 1, 1]}],
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [
      {"name": "quartic", "type": "expression", "material": 0,
       "expression": "x^4 + y^4 + z^4 - 1.5*(x*x + y*y + z*z) + 0.6",
       "world_from_local": [0.8, 0.3, 0, -0.45, 1.2, 0, 0, 0, 0.9,
         0.9, 0.6, 0]},
      {"name": "blend", "type": "smooth_union", "blend": 0.1, "material": 0,
       "operands": [)js" +
         spheres + R"js(]},
      {"name": "box", "type": "box", "material": 0, "whd": [0.3, 0.3, 0.3],
       "world_from_local": [1, 0, 0, 0, 1, 0, 0, 0, 1, -2.2, 1.2, 0]}]})js";
}

std::string pinhole(vec3f from, float aperture = 0, bool ortho = false) {
  return R"({"name": "default", "frame": [1, 0, 0, 0, 1, 0, 0, 0, 1, )" +
         std::to_string(from.x) + ", " + std::to_string(from.y) + ", " +
         std::to_string(from.z) + R"(], "lens": 0.05, "film": 0.036,
    "aspect": 1.333, "focus": 7, "aperture": )" +
         std::to_string(aperture) +
         (ortho ? R"(, "orthographic": true})" : "}");
}

// The scene of blocks_scene(), the blend's spheres of `radius` (0.6: one
// solid blob, whose octree has cells wholly inside).
std::unique_ptr<const render_context> blocks_context(
    const std::string& camera, float radius = 0.2f) {
  auto warnings = std::vector<std::string>{};
  auto scene =
      parse_scene(blocks_scene(camera, radius), "blocks.json", warnings, true);
  return make_render_context(std::move(scene), trace_params{});
}

// What the blocks of an image found, checked against each pixel's rays.
struct block_counts {
  int blocks = 0, misses = 0, late = 0;  // late: started past the camera
  int rays = 0, early_hits = 0, changed = 0;
};

block_counts check_blocks(
    const render_context& context, vec2i size, bool tent) {
  auto& camera = context.scene.cameras[0];
  auto  march  = march_params{};
  auto  counts = block_counts{};
  auto  b      = camera_block_size;
  auto  reach  = tent ? 0.5f : 0.0f;
  for (auto y = 0; y < size.y; y += b) {
    for (auto x = 0; x < size.x; x += b) {
      auto hi    = vec2i{std::min(x + b, size.x), std::min(y + b, size.y)};
      auto start = camera_block_start(
          context.accel, march, camera, size, {x, y}, hi, tent);
      counts.blocks++;
      counts.misses += start == flt_max;
      counts.late += start > 0 && start < flt_max;
      for (auto j = y; j < hi.y; j++) {
        for (auto i = x; i < hi.x; i++) {
          for (auto corner = 0; corner < 4; corner++) {
            auto du  = (corner & 1) ? 1 + reach - 1e-4f : -reach;
            auto dv  = (corner & 2) ? 1 + reach - 1e-4f : -reach;
            auto uv  = vec2f{(i + du) / size.x, (j + dv) / size.y};
            auto ray = eval_camera(camera, uv, {0, 0});
            auto hit = intersect_scene(context.accel, march, ray);
            counts.rays++;
            counts.early_hits += hit.hit && hit.distance < start;
            ray.tmin   = start;
            auto later = intersect_scene(context.accel, march, ray);
            counts.changed +=
                later.hit != hit.hit ||
                (hit.hit && std::abs(later.distance - hit.distance) >
                                1e-4f * hit.distance);
          }
        }
      }
    }
  }
  return counts;
}

// Whether two arrays hold the same bytes.
template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

}  // namespace

TEST_CASE("camera blocks: no ray of a block meets a surface before its start") {
  auto context = blocks_context(pinhole({0.2f, 0.3f, 7}));
  for (auto tent : {false, true}) {
    CAPTURE(tent);
    auto counts = check_blocks(*context, {96, 72}, tent);
    CHECK(counts.rays == 96 * 72 * 4);
    CHECK(counts.early_hits == 0);
    CHECK(counts.changed == 0);
    // The pass has work to skip here: empty blocks, and blocks whose rays
    // start well past the camera.
    CHECK(counts.misses > counts.blocks / 10);
    CHECK(counts.late > counts.blocks / 4);
  }
}

// 240 specks far smaller than a pixel, seen from (0, 0, 7) at 96 x 72 and
// scattered over the view, so that some lie just across the border of a
// block, within the tent filter's reach: spheres of their own (each its own
// box, which the pass takes as it is), or one blend of them (an octree).
std::string specks_scene(bool blend) {
  auto rng     = make_rng(7);
  auto objects = std::string{};
  // A smooth union: a top-level union would be split into its operands.
  if (blend)
    objects += R"({"name": "blend", "type": "smooth_union", "blend": 0.0001, )"
               R"("material": 0, "operands": [)";
  for (auto k = 0; k < 240; k++) {
    auto p = vec3f{rand1f(rng) * 5 - 2.5f, rand1f(rng) * 3.8f - 1.9f, 0};
    objects += std::string{k ? ", " : ""} +
               R"({"type": "sphere", "radius": 0.006, )" +
               (blend ? "" : R"("material": 0, )") +
               R"("world_from_local": [1, 0, 0, 0, 1, 0, 0, 0, 1, )" +
               std::to_string(p.x) + ", " + std::to_string(p.y) + ", 0]}";
  }
  if (blend) objects += "]}";
  return R"js({"asset": {"version": "4.2"}, "cameras": [)js" +
         pinhole({0, 0, 7}) +
         R"js(], "environments": [{"name": "sky", "emission": [1, 1, 1]}],
    "materials": [{"name": "white", "color": [0.8, 0.8, 0.8]}],
    "sdfunctions": [)js" +
         objects + "]}";
}

TEST_CASE("camera blocks: specks across the borders of blocks") {
  for (auto blend : {false, true}) {
    auto warnings = std::vector<std::string>{};
    auto scene =
        parse_scene(specks_scene(blend), "specks.json", warnings, true);
    auto context = make_render_context(std::move(scene), trace_params{});
    for (auto tent : {false, true}) {
      CAPTURE(blend);
      CAPTURE(tent);
      auto counts = check_blocks(*context, {96, 72}, tent);
      CHECK(counts.early_hits == 0);
      CHECK(counts.changed == 0);
      if (!blend) CHECK(counts.misses > 0);
    }
  }
}

TEST_CASE("camera blocks: cameras it cannot bound start at the camera") {
  // Inside the box or a sphere of the blend (any camera), and outside with
  // a lens or an orthographic camera: every block starts at the camera.
  for (auto from : {vec3f{-2.05f, 1.35f, 0.15f}, vec3f{-0.9f, -1.3f, 0.5f},
           vec3f{0.2f, 0.3f, 7}}) {
    for (auto kind : {0, 1, 2}) {
      auto inside = from.z < 1;
      if (!inside && kind == 0) continue;
      auto camera  = pinhole(from, kind == 1 ? 0.1f : 0, kind == 2);
      auto context = blocks_context(camera, from.z < 1 ? 0.6f : 0.2f);
      auto size    = vec2i{32, 24};
      auto counts  = check_blocks(*context, size, false);
      CAPTURE(kind);
      CHECK(counts.early_hits == 0);
      CHECK(counts.late == 0);
      CHECK(counts.misses == 0);
    }
  }
}

TEST_CASE("camera blocks: renders match without the pass, in any rectangles") {
  auto context      = blocks_context(pinhole({0.2f, 0.3f, 7}));
  auto params       = trace_params{};
  params.resolution = 80;
  params.samples    = 2;
  params.shader     = shader_type::implicit;
  params.aovs       = aov_bit(aov_type::depth);
  auto& camera      = context->scene.cameras[0];
  auto  size        = camera_resolution(camera, params.resolution);
  auto  render      = [&](bool first_pass, int tile) {
    params.first_pass = first_pass;
    auto buffer       = make_render_buffer(
                    {0, size.x, 0, size.y}, size.x, params.seed, render_layout(params));
    for (auto y = 0; y < size.y; y += tile)
      for (auto x = 0; x < size.x; x += tile)
        render_pixels(*context, params, camera,
                  {x, std::min(x + tile, size.x), y, std::min(y + tile, size.y)}, 0,
                  params.samples, buffer);
    return buffer;
  };
  auto with    = render(true, 80);
  auto without = render(false, 80);
  auto tiles   = render(true, 5);  // blocks cut by the tiles
  CHECK(same_bytes(tiles.sums, with.sums));
  CHECK(same_bytes(tiles.depths, with.depths));
  auto hits_differ = 0, far = 0;
  for (size_t k = 0; k < with.depths.size(); k++) {
    hits_differ += with.depths[k].y != without.depths[k].y;
    far += std::abs(with.depths[k].x - without.depths[k].x) >
           1e-4f * without.depths[k].x;
  }
  CHECK(hits_differ == 0);
  CHECK(far == 0);
}
