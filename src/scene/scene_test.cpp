// Tests for cameras, environments and scene evaluation.

#include "scene.h"

#include <doctest/doctest.h>

#include "../util/error.h"

using namespace implicit;

TEST_CASE("scene: camera rays") {
  auto camera   = camera_data{};
  camera.frame  = lookat_frame({0, 0, 5}, {0, 0, 0}, {0, 1, 0});
  camera.aspect = 2;
  camera.lens   = 0.05f;
  camera.film   = 0.036f;
  // Centre of the image looks down -z of the frame.
  auto ray = eval_camera(camera, {0.5f, 0.5f}, {0, 0});
  CHECK(ray.o.z == doctest::Approx(5.0f));
  CHECK(ray.d.z == doctest::Approx(-1.0f));
  // Right edge: horizontal half angle atan(film/2 / lens); v grows downward.
  auto right = eval_camera(camera, {1, 0.5f}, {0, 0});
  CHECK(right.d.x / -right.d.z == doctest::Approx(0.018f / 0.05f));
  auto top = eval_camera(camera, {0.5f, 0}, {0, 0});
  CHECK(top.d.y / -top.d.z == doctest::Approx(0.009f / 0.05f));
  // Thin lens: rays from any lens point meet on the focus plane.
  camera.aperture = 0.1f;
  camera.focus    = 3;
  auto a          = eval_camera(camera, {0.3f, 0.7f}, {0.5f, -0.2f});
  auto b          = eval_camera(camera, {0.3f, 0.7f}, {-0.8f, 0.6f});
  auto pa         = ray_point(a, (a.o.z - 2) / -a.d.z);
  auto pb         = ray_point(b, (b.o.z - 2) / -b.d.z);
  CHECK(distance(pa, pb) < 1e-4f);
  // Orthographic: parallel rays.
  camera.orthographic = true;
  camera.aperture     = 0;
  auto o1             = eval_camera(camera, {0.1f, 0.2f}, {0, 0});
  auto o2             = eval_camera(camera, {0.9f, 0.6f}, {0, 0});
  CHECK(dot(o1.d, o2.d) == doctest::Approx(1.0f));
  CHECK(o1.o.x < o2.o.x);
}

TEST_CASE("scene: image size from resolution and aspect") {
  auto camera   = camera_data{};
  camera.aspect = 2.4f;
  CHECK(camera_resolution(camera, 720).x == 720);
  CHECK(camera_resolution(camera, 720).y == 300);
  camera.aspect = 0.5f;
  CHECK(camera_resolution(camera, 100).x == 50);
  CHECK(camera_resolution(camera, 100).y == 100);
}

TEST_CASE("scene: find_camera order") {
  auto scene = scene_data{};
  CHECK(find_camera(scene, "") == invalidid);
  for (auto name : {"side", "camera1", "default", "top"}) {
    auto camera = camera_data{};
    camera.name = name;
    scene.cameras.push_back(camera);
  }
  CHECK(find_camera(scene, "") == 2);
  CHECK(find_camera(scene, "top") == 3);
  CHECK_THROWS_AS(find_camera(scene, "missing"), io_error);
  scene.cameras[2].name = "other";
  CHECK(find_camera(scene, "") == 1);
  scene.cameras[1].name = "other1";
  CHECK(find_camera(scene, "") == 0);
}

TEST_CASE("scene: missing camera frames the bounds") {
  auto scene = scene_data{};
  add_missing_camera(scene, {{-1, -1, -1}, {1, 1, 1}});
  REQUIRE(scene.cameras.size() == 1);
  auto ray = eval_camera(scene.cameras[0], {0.5f, 0.5f}, {0, 0});
  // Looks at the centre.
  CHECK(length(cross(ray.d, normalize(-ray.o))) < 1e-4f);
}

TEST_CASE("scene: constant environment") {
  auto scene           = scene_data{};
  auto environment     = environment_data{};
  environment.emission = {0.5f, 1, 2};
  scene.environments.push_back(environment);
  scene.environments.push_back(environment);
  auto e = eval_environment(scene, {0, 1, 0});
  CHECK(e.x == doctest::Approx(1.0f));
  CHECK(e.z == doctest::Approx(4.0f));
}
