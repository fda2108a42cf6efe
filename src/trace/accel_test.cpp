// Tests for ray-scene intersection: hits and misses on known geometry,
// grazing rays, rays from inside, both intersection modes, no self-hits; the
// Embree BVH against the minimum over objects, the sorted loop and the
// reference mode on random scenes; shadow queries against closest hits.

#include "accel.h"

#include <doctest/doctest.h>
#include <tbb/parallel_for.h>

#include <utility>

#include "../math/random.h"
#include "../math/sampling.h"
#include "../scene/scene_random.h"
#include "../sdf/sdf_primitives.h"
#include "render.h"
#include "sphere_trace.h"

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
    CHECK(accel.unbounded.empty());
    // Sphere straight on (exact in bvh mode, marched in the reference).
    auto isec = intersect_scene(accel, {}, {{0, 0, -5}, {0, 0, 1}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 0);
    CHECK(isec.distance == doctest::Approx(4.0f).epsilon(1e-3));
    // Torus (marched): ray down the y axis through the tube at x = 5.
    isec = intersect_scene(accel, {}, {{5, 3, 0}, {0, -1, 0}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 1);
    CHECK(isec.distance == doctest::Approx(2.75f).epsilon(1e-3));
    // Through the torus hole onto the floor at y = -2 + 1e-5.
    isec = intersect_scene(accel, {}, {{4, 3, 0}, {0, -1, 0}});
    REQUIRE(isec.hit);
    CHECK(isec.object == 2);
    CHECK(isec.distance == doctest::Approx(5.0f).epsilon(1e-3));
    // Up into the sky.
    isec = intersect_scene(accel, {}, {{0, 3, 0}, {0, 1, 0}});
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
      auto inner =
          intersect_scene(accel, {}, {{-3, 0.25f - offset, 1}, {1, 0, 0}});
      auto outer =
          intersect_scene(accel, {}, {{-3, 0.25f + offset, 1}, {1, 0, 0}});
      CHECK(inner.hit);
      // Closer than the closest-approach tolerance counts as touching.
      auto tolerance = march_params{}.fallback * hit_epsilon(accel, {}, 4.0f);
      if (offset > tolerance) CHECK(!outer.hit);
    }
  }
}

TEST_CASE("accel: rays from inside reach the exit") {
  auto scene = make_test_scene();
  auto accel = make_accel(scene, accel_type::bvh, {});
  auto isec  = intersect_scene(accel, {}, {{0, 0, 0}, {0, 0, 1}});
  REQUIRE(isec.hit);
  CHECK(isec.distance == doctest::Approx(1.0f).epsilon(1e-3));
  // Inside the torus tube (marched, following the negative distance).
  isec = intersect_scene(accel, {}, {{5, 0, 0}, {0, 1, 0}});
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
    auto target = vec3f{4, 0, 0} +
                  (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} - 0.5f) * 2.5f;
    auto origin = target + sample_sphere(rand2f(rng)) * 3;
    auto ray    = ray3f{origin, normalize(target - origin)};
    auto isec   = intersect_scene(accel, {}, ray);
    if (!isec.hit || isec.object != 1) continue;
    auto p = ray_point(ray, isec.distance);
    auto n = eval_object_normal(accel.objects[1], p, isec.epsilon * 0.5f);
    // The normal matches the torus's exact normal.
    auto q     = p - vec3f{4, 0, 0};
    auto ring  = normalize(vec3f{q.x, 0, q.z});
    auto exact = normalize(q - ring);
    CHECK(dot(n, exact) > 0.999f);
    // Leaving on the outside along a direction in the upper hemisphere must
    // not hit the torus at distance ~0.
    auto offset = 2 * isec.epsilon + 2 * min_hit_epsilon(accel, {});
    auto dir    = normalize(n + sample_sphere(rand2f(rng)) * 0.9f);
    if (dot(dir, n) <= 0.05f) continue;
    auto next = intersect_scene(accel, {}, {p + n * offset, dir});
    if (next.hit && next.object == 1) CHECK(next.distance > 10 * offset);
  }
}

TEST_CASE("accel: world bounds of rotated and scaled objects") {
  auto scene = scene_data{};
  scene.materials.push_back({});
  auto function = make_function(torus_node(1, 0.25f), {0, 0, 0});
  // World -> local that rotates 90 degrees about z and scales by 2:
  // the torus axis becomes world x and its size halves.
  function.local_from_world = {{0, 2, 0}, {-2, 0, 0}, {0, 0, 2}, {0, 0, 0}};
  scene.sdfunctions.push_back(function);
  auto  accel = make_accel(scene, accel_type::bvh, {});
  auto& box   = accel.objects[0].world_bounds;
  CHECK(box.min.x == doctest::Approx(-0.125f));
  CHECK(box.max.y == doctest::Approx(0.625f));
  CHECK(accel.objects[0].distance_scale == doctest::Approx(0.5f));
  // A ray along world x hits the ring's tube centre line at |y| = 0.5.
  auto isec = intersect_scene(accel, {}, {{0, 0.5f, -3}, {0, 0, 1}});
  REQUIRE(isec.hit);
  CHECK(isec.distance == doctest::Approx(2.625f).epsilon(2e-3));
}

// -----------------------------------------------------------------------------
// RANDOM SCENES
// -----------------------------------------------------------------------------

// `count` random boxes, spheres, tori and capped cones in [-4,4]^3, rotated
// and scaled unevenly (so distance bounds are not exact), over a floor plane.
static scene_data make_random_scene(
    int count, uint64_t seed, bool floor = true) {
  auto scene = scene_data{};
  scene.materials.push_back({});
  add_random_primitives(scene, count, 4, 1.5f, 1, seed);
  if (floor) {
    auto plane = sdf_node{};
    plane.type = sdf_type::plane;
    scene.sdfunctions.push_back(make_function(plane, {0, -4.5f, 0}));
  }
  return scene;
}

// Rays from outside aimed into the scene, and rays from random points in it
// (some inside objects) in random directions.
static std::vector<ray3f> make_random_rays(int count, uint64_t seed) {
  auto rng  = make_rng(seed);
  auto rays = std::vector<ray3f>{};
  for (auto k = 0; k < count; k++) {
    auto target = (vec3f{rand1f(rng), rand1f(rng), rand1f(rng)} - 0.5f) * 9;
    if (k % 2 == 0) {
      auto origin = sample_sphere(rand2f(rng)) * 15;
      rays.push_back({origin, normalize(target - origin)});
    } else {
      rays.push_back({target, sample_sphere(rand2f(rng))});
    }
  }
  return rays;
}

// Accel options: `linear_max` 0 sends every scene through the Embree BVH.
static accel_params bvh_params(int linear_max) {
  auto params       = accel_params{};
  params.linear_max = linear_max;
  return params;
}

// The closest hit as the minimum of intersect_object() over all objects,
// equal distances going to the lower index.
static scene_intersection intersect_all(
    const accel_data& accel, const ray3f& ray) {
  auto best = scene_intersection{};
  for (auto i = 0; i < (int)accel.objects.size(); i++) {
    auto isec = intersect_object(accel, {}, i, ray);
    if (isec.hit && (!best.hit || isec.distance < best.distance)) best = isec;
  }
  return best;
}

// -----------------------------------------------------------------------------
// BVH, LOOP AND REFERENCE
// -----------------------------------------------------------------------------

TEST_CASE("accel: BVH hits equal the minimum over all objects") {
  auto scene = make_random_scene(60, 1);
  auto accel = make_accel(scene, accel_type::bvh, bvh_params(0));
  REQUIRE(accel.bvh.scene != nullptr);
  CHECK(accel.bounded.size() == 60);
  CHECK(accel.unbounded == std::vector<int>{60});
  auto rays = make_random_rays(4000, 2);
  auto hits = 0;
  for (auto& ray : rays) {
    auto isec     = intersect_scene(accel, {}, ray);
    auto expected = intersect_all(accel, ray);
    REQUIRE(isec.hit == expected.hit);
    if (!isec.hit) continue;
    hits++;
    // Exactly equal: each object's march ignores the visiting order.
    CHECK(isec.object == expected.object);
    CHECK(isec.distance == expected.distance);
    CHECK(isec.epsilon == expected.epsilon);
  }
  CHECK(hits > 2000);
}

TEST_CASE("accel: sorted loop and BVH give the same hits") {
  // 12 objects: under linear_max_objects, so both paths apply.
  auto scene = make_random_scene(12, 3);
  auto loop  = make_accel(scene, accel_type::bvh, bvh_params(16));
  auto bvh   = make_accel(scene, accel_type::bvh, bvh_params(0));
  CHECK(loop.bvh.scene == nullptr);
  CHECK(bvh.bvh.scene != nullptr);
  for (auto& ray : make_random_rays(3000, 4)) {
    auto a = intersect_scene(loop, {}, ray), b = intersect_scene(bvh, {}, ray);
    REQUIRE(a.hit == b.hit);
    CHECK(a.object == b.object);
    CHECK(a.distance == b.distance);
  }
}

TEST_CASE("accel: BVH is thread-safe and deterministic") {
  auto scene  = make_random_scene(200, 5);
  auto accel  = make_accel(scene, accel_type::bvh, bvh_params(0));
  auto again  = make_accel(scene, accel_type::bvh, bvh_params(0));
  auto rays   = make_random_rays(4000, 6);
  auto serial = std::vector<scene_intersection>{};
  for (auto& ray : rays) serial.push_back(intersect_scene(accel, {}, ray));
  auto parallel = std::vector<scene_intersection>(rays.size());
  tbb::parallel_for(size_t{0}, rays.size(),
      [&](size_t k) { parallel[k] = intersect_scene(accel, {}, rays[k]); });
  for (size_t k = 0; k < rays.size(); k++) {
    CHECK(parallel[k].object == serial[k].object);
    CHECK(parallel[k].distance == serial[k].distance);
    CHECK(parallel[k].evaluations == serial[k].evaluations);
    // A second build visits the objects in the same order.
    auto other = intersect_scene(again, {}, rays[k]);
    CHECK(other.distance == serial[k].distance);
    CHECK(other.evaluations == serial[k].evaluations);
  }
  // Moving the accel keeps its BVH.
  auto moved = std::move(accel);
  CHECK(intersect_scene(moved, {}, rays[0]).distance == serial[0].distance);
}

// Whether the ray only grazes an object: inside its box, the object's
// distance along the ray never goes below -tolerance thresholds (a ray that
// touches a surface this little may be a hit or a miss).
static bool grazes(
    const accel_data& accel, int object, const ray3f& ray, float tolerance) {
  auto t0 = 0.0f, t1 = 0.0f;
  if (!intersect_bbox(ray, accel.objects[object].world_bounds, t0, t1))
    return true;
  auto samples = 4000;
  for (auto k = 0; k <= samples; k++) {
    auto t = t0 + (t1 - t0) * k / samples;
    auto d = eval_object_distance(accel.objects[object], ray_point(ray, t));
    if (d < -tolerance * hit_epsilon(accel, {}, t)) return false;
  }
  return true;
}

TEST_CASE("accel: BVH and reference mode agree on random scenes") {
  // Camera rays over random scenes: the same hits except on silhouettes that
  // the ray grazes within the closest-approach tolerance.
  for (auto seed : {7, 8}) {
    auto scene    = make_random_scene(24, (uint64_t)seed);
    auto fast     = make_accel(scene, accel_type::bvh, bvh_params(0));
    auto slow     = make_accel(scene, accel_type::none, {});
    auto camera   = camera_data{};
    camera.frame  = lookat_frame({3, 6, 14}, {0, -1, 0}, {0, 1, 0});
    camera.aspect = 1;
    auto size = 48, same = 0, grazing = 0;
    for (auto j = 0; j < size; j++) {
      for (auto i = 0; i < size; i++) {
        auto ray =
            eval_camera(camera, {(i + 0.5f) / size, (j + 0.5f) / size}, {0, 0});
        auto a = intersect_scene(fast, {}, ray);
        auto b = intersect_scene(slow, {}, ray);
        // Marched hits stop within the threshold of the surface, so along
        // grazing rays their distance may differ by more than it.
        if (a.hit == b.hit &&
            (!a.hit || (a.object == b.object &&
                           std::abs(a.distance - b.distance) <=
                               1e-3f * a.distance + 4 * a.epsilon))) {
          same++;
          continue;
        }
        // The nearer of the two hits must be on a surface that the ray
        // only grazes.
        auto& nearer = (a.hit && (!b.hit || a.distance < b.distance)) ? a : b;
        if (grazes(fast, nearer.object, ray, 3)) grazing++;
      }
    }
    CHECK(same + grazing == size * size);
    CHECK(same >= size * size * 99 / 100);
  }
}

TEST_CASE("accel: BVH and reference images are equal") {
  auto scene    = make_random_scene(16, 9);
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({-4, 5, 13}, {0, -1, 0}, {0, 1, 0});
  camera.aspect = 1;
  scene.cameras.push_back(camera);
  auto params       = trace_params{};
  params.resolution = 64;
  params.samples    = 1;
  params.shader     = shader_type::implicit_normal;
  auto render       = [&](accel_type type) {
    auto typed   = params;
    typed.accel  = type;
    auto context = make_render_context(scene_data{scene}, typed, bvh_params(0));
    auto image   = image_data{};
    render_image(*context, typed, image);
    return image;
  };
  auto fast = render(accel_type::bvh), slow = render(accel_type::none);
  auto equal = 0;
  for (size_t k = 0; k < fast.pixels.size(); k++) {
    auto a = fast.pixels[k], b = slow.pixels[k];
    equal += std::abs(a.x - b.x) <= 1 / 255.0f &&
             std::abs(a.y - b.y) <= 1 / 255.0f &&
             std::abs(a.z - b.z) <= 1 / 255.0f && a.w == b.w;
  }
  CHECK(equal >= (int)fast.pixels.size() * 995 / 1000);
}

// -----------------------------------------------------------------------------
// SHADOW QUERIES
// -----------------------------------------------------------------------------

TEST_CASE("accel: shadow queries agree with closest hits") {
  auto scene = make_random_scene(40, 10);
  auto rng   = make_rng(11);
  for (auto linear_max : {0, 16}) {
    for (auto type : {accel_type::bvh, accel_type::none}) {
      auto small = make_random_scene(6, 12);
      for (auto* which : {&scene, &small}) {
        auto accel = make_accel(*which, type, bvh_params(linear_max));
        auto count = type == accel_type::none ? 300 : 2000;
        auto hits  = 0;
        for (auto ray : make_random_rays(count, 13)) {
          // Finite segments, as for shadow rays toward a light.
          ray.tmax = 0.5f + 12 * rand1f(rng);
          auto any = intersect_scene_any(accel, {}, ray);
          CHECK(any == intersect_scene(accel, {}, ray).hit);
          hits += any;
        }
        CHECK(hits > count / 10);
        CHECK(hits < count);
      }
    }
  }
}

// -----------------------------------------------------------------------------
// HARD RAYS
// -----------------------------------------------------------------------------

TEST_CASE("accel: rays starting inside objects reach their exit") {
  // From the centre of every object of a random scene, in random
  // directions: the hit is that object's surface, where its distance is ~0.
  auto scene = make_random_scene(40, 14, false);
  auto rng   = make_rng(15);
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel = make_accel(scene, type, bvh_params(0));
    for (auto i = 0; i < (int)accel.objects.size(); i++) {
      auto& object = accel.objects[i];
      auto  center = transform_point(object.world_from_local,
          i % 4 == 0 ? scene.sdfunctions[i].program.nodes[0].size * 0.5f
                      : vec3f{0, 0, 0});
      if (i % 4 == 2) continue;  // the centre of a torus is outside it
      REQUIRE(eval_object_distance(object, center) < 0);
      for (auto k = 0; k < 8; k++) {
        auto ray  = ray3f{center, sample_sphere(rand2f(rng))};
        auto isec = intersect_scene(accel, {}, ray);
        REQUIRE(isec.hit);
        auto p = ray_point(ray, isec.distance);
        auto d = eval_object_distance(accel.objects[isec.object], p);
        CHECK(std::abs(d) <= march_params{}.fallback * isec.epsilon);
        if (type == accel_type::bvh) {
          // The exit of this object, or a surface of an overlapping one
          // inside it (objects are separate surfaces).
          if (isec.object != i) CHECK(eval_object_distance(object, p) < 0);
        } else {
          // The exit of the union of the objects (the seed's semantics).
          auto inside = false;
          for (auto& other : accel.objects)
            inside |= eval_object_distance(other, p) < -3 * isec.epsilon;
          CHECK(!inside);
        }
      }
    }
  }
  // Exact forms from inside: a sphere of radius 2 scaled by 1.5 exits at 3.
  auto single   = scene_data{};
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 2;
  single.materials.push_back({});
  single.sdfunctions.push_back(make_function(sphere, {0, 0, 0}));
  single.sdfunctions[0].local_from_world = {
      {1 / 1.5f, 0, 0}, {0, 1 / 1.5f, 0}, {0, 0, 1 / 1.5f}, {0, 0, 0}};
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel = make_accel(single, type, bvh_params(0));
    auto isec  = intersect_scene(accel, {}, {{0.5f, 0, 0}, {0, 1, 0}});
    REQUIRE(isec.hit);
    CHECK(isec.distance == doctest::Approx(std::sqrt(9 - 0.25f)).epsilon(1e-4));
  }
}

TEST_CASE("accel: rays parallel to box faces") {
  // A unit box at the origin (corner convention), rays along x at heights
  // inside, on and just off its faces, through the loop and the BVH.
  auto scene = scene_data{};
  scene.materials.push_back({});
  auto box = sdf_node{};
  box.type = sdf_type::box;
  box.size = {1, 1, 1};
  scene.sdfunctions.push_back(make_function(box, {0, 0, 0}));
  // Enough far-away spheres to make the BVH worth it.
  for (auto k = 0; k < 10; k++)
    scene.sdfunctions.push_back(
        make_function(sphere_node(0.1f), {k * 1.0f, 20, 0}));
  for (auto linear_max : {0, 16}) {
    for (auto type : {accel_type::bvh, accel_type::none}) {
      auto accel = make_accel(scene, type, bvh_params(linear_max));
      auto tol   = march_params{}.fallback * hit_epsilon(accel, {}, 3);
      for (auto y : {0.5f, 0.999f, 1.0f, 0.0f, 1.001f, -0.001f, 1.01f}) {
        for (auto z : {0.5f, 0.0f, 1.0f}) {
          auto ray  = ray3f{{-2, y, z}, {1, 0, 0}};
          auto isec = intersect_scene(accel, {}, ray);
          auto any  = intersect_scene_any(accel, {}, ray);
          CHECK(any == isec.hit);
          auto outside = y > 1 + tol || y < -tol;
          if (outside) {
            CHECK(!isec.hit);
          } else if (y > tol && y < 1 - tol && z > tol && z < 1 - tol) {
            REQUIRE(isec.hit);
            CHECK(isec.object == 0);
            CHECK(isec.distance == doctest::Approx(2.0f).epsilon(1e-4));
          }
        }
      }
      // A ray inside the box, parallel to its faces, exits at x = 1.
      auto isec = intersect_scene(accel, {}, {{0.25f, 0.5f, 0.5f}, {1, 0, 0}});
      REQUIRE(isec.hit);
      CHECK(isec.distance == doctest::Approx(0.75f).epsilon(1e-4));
    }
  }
}

TEST_CASE("accel: grazing spheres") {
  // Rays tangent to a rotated, scaled sphere (exact in the BVH, marched in
  // the reference) at offsets around its silhouette: inside ones hit, ones
  // beyond the closest-approach tolerance miss, in both modes.
  auto scene = scene_data{};
  scene.materials.push_back({});
  scene.sdfunctions.push_back(make_function(sphere_node(0.5f), {0, 0, 0}));
  auto axes  = basis_fromz(normalize(vec3f{1, 2, 3}));
  auto world = frame3f{axes.x * 2, axes.y * 2, axes.z * 2, {1, 1, 1}};
  scene.sdfunctions[0].local_from_world =
      inverse(world);  // radius 1 at (1,1,1)
  for (auto k = 0; k < 12; k++)
    scene.sdfunctions.push_back(
        make_function(sphere_node(0.1f), {k * 1.0f, -20, 0}));
  for (auto type : {accel_type::bvh, accel_type::none}) {
    auto accel = make_accel(scene, type, bvh_params(0));
    auto tol   = march_params{}.fallback * hit_epsilon(accel, {}, 10);
    for (auto k = -40; k <= 40; k++) {
      auto offset = k * 2e-5f;  // around the silhouette, in world units
      auto ray    = ray3f{{1 - 10, 1 + 1 + offset, 1}, {1, 0, 0}};
      auto isec   = intersect_scene(accel, {}, ray);
      CHECK(intersect_scene_any(accel, {}, ray) == isec.hit);
      if (offset < -tol) {
        REQUIRE(isec.hit);
        CHECK(isec.object == 0);
        // The chord's entry: x = 1 - sqrt(1 - (1 + offset)^2) (exact in the
        // BVH; the reference stops within its threshold of the surface).
        auto h = 1 + offset;
        if (type == accel_type::bvh)
          CHECK(isec.distance ==
                doctest::Approx(10 - std::sqrt(1 - h * h)).epsilon(1e-5));
        auto p = ray_point(ray, isec.distance);
        CHECK(std::abs(eval_object_distance(accel.objects[0], p)) <=
              isec.epsilon);
      }
      if (offset > tol) CHECK(!isec.hit);
    }
  }
}

// -----------------------------------------------------------------------------
// MARCHING
// -----------------------------------------------------------------------------

TEST_CASE("accel: march cutoff keeps every hit before it") {
  // Rays at a torus, many grazing it, with few iterations so that the
  // closest-approach fallback decides some of them: a march with a cutoff
  // gives the full march's result whenever that lies at or before the
  // cutoff, and otherwise no hit or that same result.
  auto rng = make_rng(16);
  for (auto planar : {0.0f, 0.9f}) {
    auto params           = march_params{};
    params.planar         = planar;
    params.max_iterations = 24;
    auto fallbacks = 0, stopped = 0;
    for (auto k = 0; k < 3000; k++) {
      auto target = vec3f{rand1f(rng) - 0.5f, (rand1f(rng) - 0.5f) * 0.6f,
                        rand1f(rng) - 0.5f} *
                    2.6f;
      auto origin   = sample_sphere(rand2f(rng)) * 4;
      auto ray      = ray3f{origin, normalize(target - origin)};
      auto distance = [&](float t) {
        return sd_torus(ray_point(ray, t), 1, 0.25f);
      };
      auto full = sphere_trace(distance, 0, 8, flt_max, params, 1e-6f);
      if (full.hit && full.epsilon > 1e-5f * full.distance * 1.5f) fallbacks++;
      for (auto cutoff : {1.0f, 2.5f, 3.0f, 3.5f, 4.0f, 5.0f, 6.0f}) {
        auto cut = sphere_trace(distance, 0, 8, cutoff, params, 1e-6f);
        CHECK(cut.evaluations <= full.evaluations);
        if (full.hit && full.distance <= cutoff) {
          REQUIRE(cut.hit);
          CHECK(cut.distance == full.distance);
          CHECK(cut.epsilon == full.epsilon);
        } else if (cut.hit) {
          CHECK(cut.distance == full.distance);
        } else {
          stopped += cut.evaluations < full.evaluations;
        }
      }
    }
    CHECK(fallbacks > 0);   // the fallback was exercised
    CHECK(stopped > 1000);  // and the cutoff saved work
  }
  // Rays along x over the top of the tube (y = 0.25 at x = -1 and x = 1),
  // within the closest-approach tolerance at x = -1 and rising clear of the
  // tube by x = 1: the full march reports the closest approach near x = -1
  // (t = 3), and a cutoff beyond it must keep it.
  auto params = march_params{};
  auto eps    = params.hit_relative * 3;
  auto kept   = 0;
  for (auto k = 0; k <= 12; k++) {
    auto ray      = ray3f{{-4, 0.25f + k * 0.15f * eps - 3 * 2e-4f, 0},
        normalize(vec3f{1, 2e-4f, 0})};
    auto distance = [&](float t) {
      return sd_torus(ray_point(ray, t), 1, 0.25f);
    };
    auto full = sphere_trace(distance, 0, 8, flt_max, params, 1e-6f);
    if (!full.hit) continue;
    CHECK(full.distance == doctest::Approx(3).epsilon(0.01));
    for (auto cutoff : {3.05f, 3.5f, 4.5f}) {
      auto cut = sphere_trace(distance, 0, 8, cutoff, params, 1e-6f);
      REQUIRE(cut.hit);
      CHECK(cut.distance == full.distance);
      kept++;
    }
  }
  CHECK(kept >= 9);
}

TEST_CASE("accel: outlives its scene (grids and user SDFs are its own)") {
  // A baked sphere grid of radius 0.4 about (0.5, 0.5, 0.5), over [0, 1]^3,
  // and a user sphere of radius 0.5 at x = 3.
  auto sphere   = sdf_node{};
  sphere.type   = sdf_type::sphere;
  sphere.radius = 0.4f;
  auto accel    = accel_data{};
  {
    auto scene  = scene_data{};
    auto volume = volume_data{};
    volume.grid = std::make_shared<const grid_data>(
        bake_grid(make_primitive_program(sphere),
            {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.5f, -0.5f, -0.5f}},
            {{0, 0, 0}, {1, 1, 1}}, 0.05f));
    scene.volumes.push_back(volume);
    auto instance     = vol_instance_data{};
    instance.volume   = 0;
    instance.material = 0;
    scene.vol_instances.push_back(instance);
    auto user             = user_sdf_data{};
    user.eval             = [](vec3f p) { return length(p) - 0.5f; };
    user.bounds           = {{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};
    user.local_from_world = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-3, 0, 0}};
    user.material         = 0;
    scene.user_sdfs.push_back(user);
    accel = make_accel(scene, accel_type::bvh, {});
  }
  // The scene is gone; both objects still trace (ASan would flag a use of
  // its memory).
  auto grid_hit = intersect_scene(accel, {}, {{0.5f, 0.5f, -2}, {0, 0, 1}});
  REQUIRE(grid_hit.hit);
  CHECK(accel.objects[grid_hit.object].kind == object_kind::grid);
  CHECK(grid_hit.distance == doctest::Approx(2.1f).epsilon(0.01));
  auto user_hit = intersect_scene(accel, {}, {{3, 0, -2}, {0, 0, 1}});
  REQUIRE(user_hit.hit);
  CHECK(accel.objects[user_hit.object].kind == object_kind::user);
  CHECK(user_hit.distance == doctest::Approx(1.5f).epsilon(1e-3));
}

TEST_CASE("accel: march parameters are read when tracing") {
  // One accel traced with two iteration caps: the cap binds at trace time
  // (nothing is rebuilt), and the default cap finds the torus a cap of 2
  // gives up on.
  auto scene = scene_data{};
  scene.materials.push_back({});
  scene.sdfunctions.push_back(make_function(torus_node(1, 0.25f), {0, 0, 0}));
  auto accel            = make_accel(scene, accel_type::bvh);
  auto ray              = ray3f{{-4, 0.1f, 0}, {1, 0, 0}};
  auto capped           = march_params{};
  capped.max_iterations = 2;
  auto full             = intersect_scene(accel, {}, ray);
  auto cut              = intersect_scene(accel, capped, ray);
  CHECK(full.hit);
  CHECK_FALSE(cut.hit);
  CHECK(cut.evaluations <= 2);
  CHECK(cut.evaluations < full.evaluations);
}
