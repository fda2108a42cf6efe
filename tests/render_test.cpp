// Render tests on whole scenes: the example scenes and the seed's scenes in
// ../shared, compared by statistics with tolerances.

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include "scene/scene_io.h"
#include "trace/trace.h"

using namespace implicit;

namespace {

std::string example_scene(const std::string& name) {
  return std::string{IMPLICIT_SOURCE_DIR} + "/examples/" + name;
}

image_data render(const scene_data& scene, trace_params params) {
  auto accel  = make_accel(scene, params.accel, params.march);
  auto lights = make_lights(scene, accel);
  auto state  = make_state(scene, params);
  for (auto s = 0; s < params.samples; s++)
    trace_samples(state, scene, accel, lights, params);
  return get_render(state);
}

// Fraction of pixels equal within `tolerance` on every channel.
double equal_fraction(const image_data& a, const image_data& b, float tolerance) {
  auto equal = 0;
  for (size_t i = 0; i < a.pixels.size(); i++) {
    auto pa = a.pixels[i], pb = b.pixels[i];
    equal += std::abs(pa.x - pb.x) <= tolerance && std::abs(pa.y - pb.y) <= tolerance &&
             std::abs(pa.z - pb.z) <= tolerance && std::abs(pa.w - pb.w) <= tolerance;
  }
  return (double)equal / a.pixels.size();
}

double coverage(const image_data& image) {
  auto sum = 0.0;
  for (auto& p : image.pixels) sum += p.w;
  return sum / image.pixels.size();
}

}  // namespace

TEST_CASE("render: default tracer and reference mode agree on normals") {
  auto scene        = load_scene(example_scene("sdfunction/sdfunction.json"));
  auto params       = trace_params{};
  params.camera     = find_camera(scene, "");
  params.resolution = 120;
  params.samples    = 1;
  params.shader     = shader_type::implicit_normal;
  auto fast         = render(scene, params);
  params.accel      = accel_type::none;
  auto reference    = render(scene, params);
  CHECK(coverage(fast) > 0.5);
  CHECK(coverage(fast) == doctest::Approx(coverage(reference)).epsilon(0.002));
  CHECK(equal_fraction(fast, reference, 1 / 255.0f) >= 0.995);
  CHECK(equal_fraction(fast, reference, 0.02f) >= 0.999);
}

TEST_CASE("render: the example renders lit, with no NaN") {
  auto scene        = load_scene(example_scene("sdfunction/sdfunction.json"));
  auto params       = trace_params{};
  params.camera     = find_camera(scene, "");
  params.resolution = 96;
  params.samples    = 8;
  auto image        = render(scene, params);
  auto mean         = 0.0;
  for (auto& p : image.pixels) {
    CHECK(isfinite(xyz(p)));
    mean += p.x + p.y + p.z;
  }
  mean /= 3 * image.pixels.size();
  CHECK(mean > 0.05);
  CHECK(mean < 2.0);
}
