// Tests for ray-scene intersection: hits and misses on known geometry,
// grazing rays, rays from inside, both intersection modes, no self-hits.

#include "accel.h"

#include <doctest/doctest.h>

#include "../math/random.h"
#include "../math/sampling.h"

using namespace implicit;

// An sdfunction placed with its centre (or corner, for boxes) at `origin`.
static sdf_function_data make_function(sdf_node node, vec3f origin) {
  auto function             = sdf_function_data{};
  function.program          = make_primitive_program(node);
  function.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, -origin};
  function.material         = 0;
  return function;
}

static sdf_node sphere_node(float radius) {
  auto node   = sdf_node{};
  node.type   = sdf_type::sphere;
  node.radius = radius;
  return node;
}

static sdf_node torus_node(float r1, float r2) {
  auto node    = sdf_node{};
  node.type    = sdf_type::torus;
  node.radius  = r1;
  node.radius2 = r2;
  return node;
}

static scene_data make_test_scene() {
  auto scene = scene_data{};
  scene.materials.push_back({});
  scene.sdfunctions.push_back(make_function(sphere_node(1), {0, 0, 0}));
  scene.sdfunctions.push_back(make_function(torus_node(1, 0.25f), {4, 0, 0}));
  auto floor = sdf_node{};
  floor.type = sdf_type::box;
  floor.size = {20, 1e-5f, 20};
  scene.sdfunctions.push_back(make_function(floor, {-10, -2, -10}));
  return scene;
}

TEST_CASE("accel: hits and misses on known geometry") {
  auto scene = make_test_scene();
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel = make_accel(scene, type, {});
    // Sphere straight on (exact in bvh mode, marched in the reference).
    auto isec = intersect_scene(accel, {{0, 0, -5}, {0, 0, 1}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 0);
    CHECK(isec.distance == doctest::Approx(4.0f).epsilon(1e-3));
    // Torus (marched): ray down the y axis through the tube at x = 5.
    isec = intersect_scene(accel, {{5, 3, 0}, {0, -1, 0}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 1);
    CHECK(isec.distance == doctest::Approx(2.75f).epsilon(1e-3));
    // Through the torus hole onto the floor at y = -2 + 1e-5.
    isec = intersect_scene(accel, {{4, 3, 0}, {0, -1, 0}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 2);
    CHECK(isec.distance == doctest::Approx(5.0f).epsilon(1e-3));
    // Up into the sky.
    isec = intersect_scene(accel, {{0, 3, 0}, {0, 1, 0}});
    CHECK(!isec.hit);
  }
}

TEST_CASE("accel: grazing rays near silhouettes do not leak") {
  // Rays parallel to a line through the torus tube just inside and outside
  // its silhouette: inside ones must hit, outside ones must miss.
  auto scene = scene_data{};
  scene.materials.push_back({});
  scene.sdfunctions.push_back(make_function(torus_node(1, 0.25f), {0, 0, 0}));
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel = make_accel(scene, type, {});
    for (auto k = 1; k <= 50; k++) {
      auto offset = 0.25f * k / 1000.0f;  // up to 5% of the tube radius
      auto inner  = intersect_scene(accel, {{-3, 0.25f - offset, 1}, {1, 0, 0}});
      auto outer  = intersect_scene(accel, {{-3, 0.25f + offset, 1}, {1, 0, 0}});
      CHECK(inner.hit);
      // Closer than the closest-approach tolerance counts as touching.
      auto tolerance = accel.march.fallback * hit_epsilon(accel, 4.0f);
      if (offset > tolerance) CHECK(!outer.hit);
    }
  }
}

TEST_CASE("accel: rays from inside reach the exit") {
  auto scene = make_test_scene();
  auto accel = make_accel(scene, accel_type::bvh, {});
  auto isec  = intersect_scene(accel, {{0, 0, 0}, {0, 0, 1}});
  REQUIRE(isec.hit);
  CHECK(isec.distance == doctest::Approx(1.0f).epsilon(1e-3));
  // Inside the torus tube (marched, following the negative distance).
  isec = intersect_scene(accel, {{5, 0, 0}, {0, 1, 0}});
  REQUIRE(isec.hit);
  CHECK(isec.object == 1);
  CHECK(isec.distance == doctest::Approx(0.25f).epsilon(1e-3));
}

TEST_CASE("accel: normals and no self-hit after spawning") {
  auto scene = make_test_scene();
  auto accel = make_accel(scene, accel_type::bvh, {});
  auto rng   = make_rng(3);
  for (auto k = 0; k < 500; k++) {
    // Random rays at the torus from outside.
    auto target = vec3f{4, 0, 0} + (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} - 0.5f) * 2.5f;
    auto origin = target + sample_sphere(rand2f(rng)) * 3;
    auto ray    = ray3f{origin, normalize(target - origin)};
    auto isec   = intersect_scene(accel, ray);
    if (!isec.hit || isec.object != 1) continue;
    auto p = ray_point(ray, isec.distance);
    auto n = eval_object_normal(accel.objects[1], p, isec.epsilon * 0.5f);
    // The normal matches the torus's exact normal.
    auto q      = p - vec3f{4, 0, 0};
    auto ring   = normalize(vec3f{q.x, 0, q.z});
    auto exact  = normalize(q - ring);
    CHECK(dot(n, exact) > 0.999f);
    // Leaving on the outside along a direction in the upper hemisphere must
    // not hit the torus at distance ~0.
    auto offset = 2 * isec.epsilon + 2 * accel.hit_min;
    auto dir    = normalize(n + sample_sphere(rand2f(rng)) * 0.9f);
    if (dot(dir, n) <= 0.05f) continue;
    auto next = intersect_scene(accel, {p + n * offset, dir});
    if (next.hit && next.object == 1) CHECK(next.distance > 10 * offset);
  }
}

TEST_CASE("accel: world bounds of rotated and scaled objects") {
  auto scene    = scene_data{};
  scene.materials.push_back({});
  auto function = make_function(torus_node(1, 0.25f), {0, 0, 0});
  // World -> local that rotates 90 degrees about z and scales by 2:
  // the torus axis becomes world x and its size halves.
  function.local_from_world = {{0, 2, 0}, {-2, 0, 0}, {0, 0, 2}, {0, 0, 0}};
  scene.sdfunctions.push_back(function);
  auto accel = make_accel(scene, accel_type::bvh, {});
  auto& box  = accel.objects[0].world_bounds;
  CHECK(box.min.x == doctest::Approx(-0.125f));
  CHECK(box.max.y == doctest::Approx(0.625f));
  CHECK(accel.objects[0].distance_scale == doctest::Approx(0.5f));
  // A ray along world x hits the ring's tube centre line at |y| = 0.5.
  auto isec = intersect_scene(accel, {{0, 0.5f, -3}, {0, 0, 1}});
  REQUIRE(isec.hit);
  CHECK(isec.distance == doctest::Approx(2.625f).epsilon(2e-3));
}
