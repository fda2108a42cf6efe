// # implicit: viewer navigation
//
// The window-system-free half of the viewer's interaction: Yocto/GL's
// turntable camera (orbit about the focus point, pan, dolly), the mapping
// from mouse motion to it, and where the image sits in the window. Kept apart
// from GLFW and OpenGL so that tests can check it without a display.
#pragma once

#include "../math/math.h"
#include "../scene/scene.h"

namespace implicit {

// -----------------------------------------------------------------------------
// CAMERA NAVIGATION
// -----------------------------------------------------------------------------

// Yocto/GL's update_turntable: `rotate` adds to the azimuth (x) and polar
// angle (y, clamped away from the poles) of the camera about the focus point
// o - z * focus, keeping +y up; `dolly` scales the focus distance by
// (1 + dolly), moving the camera along z; `pan` moves it along its x and y.
void update_turntable(
    frame3f& frame, float& focus, vec2f rotate, float dolly, vec2f pan);

// How a mouse gesture moves the camera (Yocto/GL's viewer).
enum class navigation_mode { orbit, pan, dolly };

// Move the camera for a mouse drag of `delta` pixels (y down) and a scroll of
// `scroll` clicks (positive away from the user, which moves closer). Yocto's
// scales: orbit delta / 100 radians, pan delta * focus / 200 world units,
// dolly delta.y / 100. Returns whether the camera changed.
bool navigate_camera(
    camera_data& camera, navigation_mode mode, vec2f delta, float scroll);

// -----------------------------------------------------------------------------
// IMAGE PLACEMENT
// -----------------------------------------------------------------------------

// Where the image is drawn, in window pixels.
struct image_rect {
  vec2f min   = {0, 0};  // top-left corner, on whole pixels
  vec2f size  = {0, 0};
  float scale = 0;  // window pixels per image pixel
};

// Fit an image of `image_size` pixels into an area, centred and as large as
// the area allows (Yocto's camera_imview with `fit`). The corner is rounded
// to whole pixels so that magnified pixels have crisp edges.
image_rect fit_image(vec2i image_size, vec2f area_min, vec2f area_size);

// The pixel of an image of `image_size` pixels drawn in `rect` under a
// window point, or {-1, -1} outside. The image shown may be a preview
// smaller than the one `rect` was fitted for.
vec2i image_pixel_at(const image_rect& rect, vec2i image_size, vec2f point);

}  // namespace implicit
