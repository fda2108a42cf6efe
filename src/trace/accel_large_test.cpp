// Tests of large implicit models (issue 11): union parts and pruned fields
// against the reference mode's whole-tree evaluation, and models of any size
// or depth rendering without a crash.

#include <doctest/doctest.h>

#include <cmath>

#include "../scene/scene_random.h"
#include "../sdf/sdf_models.h"
#include "accel.h"
#include "render.h"

using namespace implicit;

namespace {

scene_data make_model_scene(sdf_program program) {
  return make_model_scene(std::move(program), material_data{});
}

// A small pruning budget keeps the sanitizer build fast; the pruned values
// are exact at any budget.
constexpr size_t test_prune_bytes = size_t{4} << 20;

image_data render_normals(
    const scene_data& scene, accel_type type, int resolution) {
  auto params       = trace_params{};
  params.resolution = resolution;
  params.samples    = 1;
  params.shader     = shader_type::implicit_normal;
  params.accel      = type;
  auto build        = accel_params{};
  build.prune_bytes = test_prune_bytes;
  auto context      = make_render_context(scene_data{scene}, params, build);
  auto image        = image_data{};
  render_image(*context, params, image);
  return image;
}

// Fraction of pixels whose RGBA agree within `tolerance`.
double agreement(const image_data& a, const image_data& b, float tolerance) {
  auto equal = 0;
  for (size_t k = 0; k < a.pixels.size(); k++) {
    auto pa = a.pixels[k], pb = b.pixels[k];
    equal += std::abs(pa.x - pb.x) <= tolerance &&
             std::abs(pa.y - pb.y) <= tolerance &&
             std::abs(pa.z - pb.z) <= tolerance && pa.w == pb.w;
  }
  return (double)equal / (double)a.pixels.size();
}

// Fraction of pixels that hit something.
double coverage(const image_data& image) {
  auto hit = 0;
  for (auto& pixel : image.pixels) hit += pixel.w > 0;
  return (double)hit / (double)image.pixels.size();
}

}  // namespace

// Accelerated and reference normals of a 1,000-operand model.
static void check_agreement(sdf_model_type type) {
  auto scene        = make_model_scene(make_sdf_model(type, 1000, 3));
  auto build        = accel_params{};
  build.prune_bytes = test_prune_bytes;
  auto fast         = make_accel(scene, accel_type::bvh, build);
  if (type == sdf_model_type::hard_union) {
    CHECK(fast.objects.size() == 1000);
  } else {
    REQUIRE(fast.objects.size() == 1);
    CHECK((bool)fast.objects[0].field->octree);
  }
  auto a = render_normals(scene, accel_type::bvh, 24);
  auto b = render_normals(scene, accel_type::none, 24);
  CHECK(coverage(a) > 0.2);
  CHECK(agreement(a, b, 2 / 255.0f) >= 0.98);
}

TEST_CASE("accel large: union parts agree with the reference") {
  check_agreement(sdf_model_type::hard_union);
}

TEST_CASE("accel large: pruned smooth union agrees with the reference") {
  check_agreement(sdf_model_type::smooth_union);
}

TEST_CASE("accel large: pruned subtractions agree with the reference") {
  check_agreement(sdf_model_type::perforated_slab);
}

TEST_CASE("accel large: a union of 200,000 spheres and boxes renders") {
  auto scene =
      make_model_scene(make_sdf_model(sdf_model_type::hard_union, 200000, 5));
  auto image = render_normals(scene, accel_type::bvh, 8);
  CHECK(coverage(image) > 0.2);
}

TEST_CASE("accel large: 10,000 nested smooth unions under transforms render") {
  auto program  = sdf_program{};
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.3f;
  auto root     = add_node(program, sphere);
  for (auto level = 0; level < 10000; level++) {
    root = add_transform(
        program, root, frame3f{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1e-4f, 0, 0}});
    auto op  = sdf_node{};
    op.type  = sdf_type::op_smooth_union;
    op.blend = 0.05f;
    op.left  = add_node(program, sphere);
    op.right = root;
    root     = add_node(program, op);
  }
  auto scene = make_model_scene(program);
  auto a     = render_normals(scene, accel_type::bvh, 8);
  auto b     = render_normals(scene, accel_type::none, 8);
  CHECK(coverage(a) > 0);
  CHECK(agreement(a, b, 2 / 255.0f) >= 0.95);
}
