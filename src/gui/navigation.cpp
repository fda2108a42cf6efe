// # implicit: viewer navigation (implementation)

#include "navigation.h"

#include <algorithm>
#include <cmath>

namespace implicit {

// -----------------------------------------------------------------------------
// CAMERA NAVIGATION
// -----------------------------------------------------------------------------

// Polar angles closer than this to the poles would make lookat_frame's
// cross(up, z) vanish.
static constexpr float pole_margin = 0.001f;
// The focus distance never shrinks below this, so dolly can always recover.
static constexpr float min_focus = 0.001f;

// Yocto/GL's update_turntable (frame version).
void update_turntable(
    frame3f& frame, float& focus, vec2f rotate, float dolly, vec2f pan) {
  if (rotate.x != 0 || rotate.y != 0) {
    auto z      = normalize(frame.z);
    auto phi    = std::atan2(z.z, z.x) + rotate.x;
    auto theta  = std::acos(clamp(z.y, -1.0f, 1.0f)) + rotate.y;
    theta       = clamp(theta, pole_margin, pif - pole_margin);
    auto new_z  = vec3f{std::sin(theta) * std::cos(phi), std::cos(theta),
        std::sin(theta) * std::sin(phi)};
    auto center = frame.o - z * focus;
    frame       = lookat_frame(center + new_z * focus, center, {0, 1, 0});
  }
  if (dolly != 0) {
    auto z      = normalize(frame.z);
    auto center = frame.o - z * focus;
    focus       = std::max(focus * (1 + dolly), min_focus);
    frame.o     = center + z * focus;
  }
  if (pan.x != 0 || pan.y != 0) {
    frame.o += normalize(frame.x) * pan.x + normalize(frame.y) * pan.y;
  }
}

// Mouse pixels per radian of orbit, per focus distance of pan, per unit of
// dolly: Yocto/GL's uiupdate_camera_params.
static constexpr float orbit_pixels = 100;
static constexpr float pan_pixels   = 200;
static constexpr float dolly_pixels = 100;
// One scroll click changes the focus distance by this fraction.
static constexpr float scroll_dolly = 0.1f;

// Mouse gesture -> turntable motion.
bool navigate_camera(
    camera_data& camera, navigation_mode mode, vec2f delta, float scroll) {
  auto rotate = vec2f{0, 0};
  auto pan    = vec2f{0, 0};
  auto dolly  = -scroll * scroll_dolly;
  switch (mode) {
    case navigation_mode::orbit: rotate = delta / orbit_pixels; break;
    case navigation_mode::pan:
      // The scene follows the cursor: the camera moves the other way in x
      // and, with y down on screen and up in the camera, the same way in y.
      pan = vec2f{-delta.x, delta.y} * (camera.focus / pan_pixels);
      break;
    case navigation_mode::dolly: dolly += delta.y / dolly_pixels; break;
  }
  if (rotate.x == 0 && rotate.y == 0 && pan.x == 0 && pan.y == 0 && dolly == 0)
    return false;
  update_turntable(camera.frame, camera.focus, rotate, dolly, pan);
  return true;
}

// -----------------------------------------------------------------------------
// IMAGE PLACEMENT
// -----------------------------------------------------------------------------

// Centre and scale to fit.
image_rect fit_image(vec2i image_size, vec2f area_min, vec2f area_size) {
  auto rect = image_rect{};
  if (image_size.x <= 0 || image_size.y <= 0 || area_size.x <= 0 ||
      area_size.y <= 0)
    return rect;
  rect.scale = std::min(area_size.x / image_size.x, area_size.y / image_size.y);
  rect.size  = vec2f{(float)image_size.x, (float)image_size.y} * rect.scale;
  auto min   = area_min + (area_size - rect.size) * 0.5f;
  rect.min   = {std::floor(min.x), std::floor(min.y)};
  return rect;
}

// Window point -> pixel of the image shown in rect.
vec2i image_pixel_at(const image_rect& rect, vec2i image_size, vec2f point) {
  if (rect.size.x <= 0 || rect.size.y <= 0) return {-1, -1};
  auto uv = vec2f{(point.x - rect.min.x) / rect.size.x,
      (point.y - rect.min.y) / rect.size.y};
  if (!(uv.x >= 0 && uv.x < 1 && uv.y >= 0 && uv.y < 1)) return {-1, -1};
  return {std::min((int)(uv.x * image_size.x), image_size.x - 1),
      std::min((int)(uv.y * image_size.y), image_size.y - 1)};
}

}  // namespace implicit
