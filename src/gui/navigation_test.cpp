// Tests for the viewer's camera navigation and image placement: the turntable
// keeps its focus point, each gesture moves the camera by Yocto/GL's amounts,
// and window points map to the pixels drawn there.

#include "navigation.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace implicit;

static camera_data look_at(vec3f from, vec3f to) {
  auto camera  = camera_data{};
  camera.frame = lookat_frame(from, to, {0, 1, 0});
  camera.focus = length(from - to);
  return camera;
}

static vec3f focus_point(const camera_data& camera) {
  return camera.frame.o - camera.frame.z * camera.focus;
}

static void check_close(vec3f a, vec3f b, float tolerance = 1e-5f) {
  CHECK(std::abs(a.x - b.x) <= tolerance);
  CHECK(std::abs(a.y - b.y) <= tolerance);
  CHECK(std::abs(a.z - b.z) <= tolerance);
}

TEST_CASE("navigation: orbit turns about the focus point by delta / 100") {
  auto camera = look_at({3, 1, 2}, {0.5f, 0.25f, -1});
  auto center = focus_point(camera);
  auto focus  = camera.focus;
  auto z0     = camera.frame.z;
  CHECK(navigate_camera(camera, navigation_mode::orbit, {30, -20}, 0));
  // Same focus point and distance, orthonormal frame with a level x axis.
  check_close(focus_point(camera), center);
  CHECK(camera.focus == doctest::Approx(focus).epsilon(1e-6));
  CHECK(
      distance(camera.frame.o, center) == doctest::Approx(focus).epsilon(1e-5));
  CHECK(length(camera.frame.x) == doctest::Approx(1).epsilon(1e-6));
  CHECK(dot(camera.frame.x, camera.frame.z) == doctest::Approx(0).scale(1e-6));
  CHECK(std::abs(camera.frame.x.y) <= 1e-6f);
  // Azimuth about +y grows by 0.3 rad, the polar angle shrinks by 0.2 rad.
  auto z1 = camera.frame.z;
  CHECK(std::atan2(z1.z, z1.x) - std::atan2(z0.z, z0.x) ==
        doctest::Approx(0.3).epsilon(1e-5));
  CHECK(
      std::acos(z1.y) - std::acos(z0.y) == doctest::Approx(-0.2).epsilon(1e-5));
}

TEST_CASE("navigation: orbit stops short of the poles") {
  auto camera = look_at({0, 0, 5}, {0, 0, 0});
  navigate_camera(camera, navigation_mode::orbit, {0, 1000}, 0);
  // theta clamped to pi - 0.001: looking up from just below the focus point.
  CHECK(camera.frame.z.y ==
        doctest::Approx(std::cos(3.14159265f - 0.001f)).epsilon(1e-6));
  CHECK(std::isfinite(camera.frame.x.x));
  check_close(focus_point(camera), {0, 0, 0});
}

TEST_CASE(
    "navigation: pan moves camera and focus point by delta * focus / 200") {
  auto camera = look_at({0, 0, 4}, {0, 0, 0});  // x = +x, y = +y
  CHECK(navigate_camera(camera, navigation_mode::pan, {50, 20}, 0));
  // The scene follows the cursor: right drag moves the camera left; a drag
  // down (window y grows) moves it up.
  check_close(camera.frame.o, {-1, 0.4f, 4});
  check_close(focus_point(camera), {-1, 0.4f, 0});
  CHECK(camera.focus == 4);
  check_close(camera.frame.z, {0, 0, 1});
}

TEST_CASE("navigation: dolly and scroll scale the focus distance") {
  auto camera = look_at({0, 0, 4}, {0, 0, 0});
  CHECK(navigate_camera(camera, navigation_mode::dolly, {7, 50}, 0));
  CHECK(camera.focus == doctest::Approx(6));  // 1 + 50 / 100
  check_close(camera.frame.o, {0, 0, 6});
  CHECK(navigate_camera(camera, navigation_mode::orbit, {0, 0}, 2));
  CHECK(camera.focus == doctest::Approx(4.8));  // 1 - 2 * 0.1
  check_close(focus_point(camera), {0, 0, 0});
  // Dolly never crosses the focus point.
  navigate_camera(camera, navigation_mode::dolly, {0, -1000}, 0);
  CHECK(camera.focus > 0);
  CHECK(camera.frame.o.z > 0);
}

TEST_CASE("navigation: no motion leaves the camera alone") {
  auto camera = look_at({1, 2, 3}, {0, 0, 0});
  auto before = camera.frame;
  CHECK_FALSE(navigate_camera(camera, navigation_mode::orbit, {0, 0}, 0));
  CHECK_FALSE(navigate_camera(camera, navigation_mode::dolly, {5, 0}, 0));
  CHECK(camera.frame.o == before.o);
  CHECK(camera.frame.z == before.z);
}

TEST_CASE("navigation: fit_image centres and scales, pixels map back") {
  // 240x100 in the 1280x720 area right of the panel: limited by the width.
  auto rect = fit_image({240, 100}, {320, 0}, {1280, 720});
  CHECK(rect.scale == doctest::Approx(1280.0 / 240));
  CHECK(rect.min.x == 320);
  CHECK(rect.min.y == std::floor((720 - 100 * 1280.0f / 240) / 2));
  CHECK(rect.size.x == doctest::Approx(1280));
  // The window pixel whose centre lies at the middle of image pixel (i, j)
  // shows that pixel, for every pixel.
  auto mismatches = 0;
  for (auto j = 0; j < 100; j++) {
    for (auto i = 0; i < 240; i++) {
      auto x  = rect.min.x + std::floor((i + 0.5f) * rect.scale) + 0.5f;
      auto y  = rect.min.y + std::floor((j + 0.5f) * rect.scale) + 0.5f;
      auto ij = image_pixel_at(rect, {240, 100}, {x, y});
      if (ij.x != i || ij.y != j) mismatches++;
    }
  }
  CHECK(mismatches == 0);
  // A preview 8 times smaller shown in the same rectangle.
  auto ij = image_pixel_at(
      rect, {30, 13}, {rect.min.x + rect.size.x - 1, rect.min.y + 1});
  CHECK(ij.x == 29);
  CHECK(ij.y == 0);
  // Outside: the panel, above the image, past the right edge.
  CHECK(image_pixel_at(rect, {240, 100}, {100, 300}).x == -1);
  CHECK(image_pixel_at(rect, {240, 100}, {800, rect.min.y - 1}).x == -1);
  CHECK(image_pixel_at(rect, {240, 100}, {1600, 300}).x == -1);
  // A tall image is limited by the height.
  auto tall = fit_image({100, 400}, {320, 0}, {1280, 720});
  CHECK(tall.scale == doctest::Approx(1.8));
  CHECK(tall.min.x == std::floor(320 + (1280 - 180) / 2.0f));
  CHECK(tall.min.y == 0);
  // Nothing to fit.
  CHECK(fit_image({0, 10}, {0, 0}, {100, 100}).scale == 0);
}
