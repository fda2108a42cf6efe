// # implicit: interactive viewer
//
// `ypathtrace --interactive`: a GLFW window (OpenGL 3.3 core) with a Dear
// ImGui panel on the left and the progressive render on the right, as
// Yocto/GL's viewer. The render runs on a render_worker (render_worker.h):
// render_step() and get_image() of the render core, the one render loop of
// the command line too; this module only shows images and turns input into
// new render jobs.
#pragma once

#include <string>

#include "../trace/render.h"

namespace implicit {

// -----------------------------------------------------------------------------
// PARAMETERS
// -----------------------------------------------------------------------------

// Width of the panel on the left, in window pixels (Yocto/GL's 320).
inline constexpr int viewer_panel_width = 320;

// What the viewer needs besides the render parameters.
struct viewer_params {
  std::string name     = "";  // shown in the panel (the scene file)
  std::string output   = "";  // where the save button writes
  float       exposure = 0;
  bool        filmic   = false;
  vec2i       window   = {1280 + viewer_panel_width, 720};
  // Automation, for tests and screenshots. The scripted drag happens at
  // frame orbit_frame. With frames > 0 the viewer closes once it has shown
  // that many frames, the drag is done and the render has all its samples;
  // the last frame is then saved to screenshot.
  int         frames      = 0;
  std::string screenshot  = "";
  vec2f       orbit       = {0, 0};  // a left-button drag, in pixels
  int         orbit_frame = 1;       // the frame at which it happens
};

// -----------------------------------------------------------------------------
// VIEWER
// -----------------------------------------------------------------------------

// Throw io_error at once, before anything is loaded, when there is no
// display to open a window on.
void check_display();

// Open the window and run until it is closed (or the automation ends). The
// context is only read (the cameras the user moves are the viewer's own
// copies). Throws io_error when no window or OpenGL 3.3 context can be had.
void run_viewer(const render_context& context, const trace_params& params,
    const viewer_params& viewer);

}  // namespace implicit
