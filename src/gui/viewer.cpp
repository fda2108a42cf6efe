// # implicit: interactive viewer (implementation)
//
// One interface thread (GLFW events, ImGui, OpenGL) and one render_worker.
// Each frame the interface takes the latest finished image, if any, tonemaps
// it to bytes and uploads it; it never waits for a render pass. Edits of the
// camera or of a render setting post a new job, which the worker starts at
// once with a preview; edits of the view and of denoising re-show the
// worker's render; tonemap edits only re-tonemap the image it has.

#include "viewer.h"

#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "../image/image_io.h"
#include "../trace/render_options.h"
#include "../util/error.h"
#include "../util/progress.h"
#include "navigation.h"
#include "render_worker.h"

namespace implicit {

// -----------------------------------------------------------------------------
// WINDOW
// -----------------------------------------------------------------------------

// What every window failure tells the user to do instead.
static const std::string no_window_hint =
    "; run without --interactive to render to a file";

// Fail early when no display is named.
void check_display() {
  auto display = std::getenv("DISPLAY");
  auto wayland = std::getenv("WAYLAND_DISPLAY");
  if ((display == nullptr || *display == 0) &&
      (wayland == nullptr || *wayland == 0))
    throw io_error(
        "cannot open the interactive viewer: no display (DISPLAY is not set)" +
        no_window_hint);
}

// GLFW's description of its last error.
static std::string glfw_error() {
  const char* description = nullptr;
  glfwGetError(&description);
  return description != nullptr ? description : "unknown GLFW error";
}

// Owner of the window, the OpenGL context and ImGui; tears them down in
// reverse order of creation, also when an exception leaves run_viewer().
struct gl_session {
  gl_session()                             = default;
  gl_session(const gl_session&)            = delete;
  gl_session& operator=(const gl_session&) = delete;
  ~gl_session() {
    if (opengl3) ImGui_ImplOpenGL3_Shutdown();
    if (glfw) ImGui_ImplGlfw_Shutdown();
    if (imgui) ImGui::DestroyContext();
    if (window != nullptr) glfwDestroyWindow(window);
    if (initialized) glfwTerminate();
  }
  bool        initialized = false;
  GLFWwindow* window      = nullptr;
  bool        imgui       = false;
  bool        glfw        = false;  // ImGui's GLFW backend
  bool        opengl3     = false;  // ImGui's OpenGL 3 backend
};

// Window, OpenGL 3.3 core context and ImGui, or an io_error.
static void open_window(
    gl_session& session, const std::string& title, vec2i size) {
  if (glfwInit() != GLFW_TRUE)
    throw io_error(
        "cannot open the interactive viewer: " + glfw_error() + no_window_hint);
  session.initialized = true;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  session.window =
      glfwCreateWindow(size.x, size.y, title.c_str(), nullptr, nullptr);
  if (session.window == nullptr)
    throw io_error(
        "cannot open the interactive viewer: no OpenGL 3.3 core window (" +
        glfw_error() + ")" + no_window_hint);
  glfwMakeContextCurrent(session.window);
  glfwSwapInterval(1);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  session.imgui              = true;
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's folder
  ImGui::StyleColorsDark();
  session.glfw = ImGui_ImplGlfw_InitForOpenGL(session.window, true);
  if (!session.glfw)
    throw io_error(
        "cannot open the interactive viewer: ImGui's GLFW backend "
        "failed" +
        no_window_hint);
  session.opengl3 = ImGui_ImplOpenGL3_Init("#version 330");
  if (!session.opengl3)
    throw io_error(
        "cannot open the interactive viewer: ImGui's OpenGL 3 "
        "backend failed" +
        no_window_hint);
}

// -----------------------------------------------------------------------------
// IMAGES
// -----------------------------------------------------------------------------

// The render as an OpenGL texture of tonemapped sRGB bytes.
struct display_texture {
  GLuint               id     = 0;
  int                  width  = 0;
  int                  height = 0;
  std::vector<uint8_t> bytes  = {};
};

// Tonemap as save_image() does for 8-bit files and upload. Magnified pixels
// stay square (nearest), so the preview looks like Yocto/GL's and the pixels
// on screen are those the command line would save.
static void upload_image(display_texture& texture, const image_data& image,
    float exposure, bool filmic) {
  texture.bytes.resize(image.pixels.size() * 4);
  for (size_t idx = 0; idx < image.pixels.size(); idx++) {
    auto ldr                   = tonemap(image.pixels[idx], exposure, filmic);
    texture.bytes[idx * 4 + 0] = float_to_byte(ldr.x);
    texture.bytes[idx * 4 + 1] = float_to_byte(ldr.y);
    texture.bytes[idx * 4 + 2] = float_to_byte(ldr.z);
    texture.bytes[idx * 4 + 3] = float_to_byte(ldr.w);
  }
  if (texture.id == 0) {
    glGenTextures(1, &texture.id);
    glBindTexture(GL_TEXTURE_2D, texture.id);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_2D, texture.id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (texture.width != image.width || texture.height != image.height) {
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, image.width, image.height, 0,
        GL_RGBA, GL_UNSIGNED_BYTE, texture.bytes.data());
    texture.width  = image.width;
    texture.height = image.height;
  } else {
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGBA,
        GL_UNSIGNED_BYTE, texture.bytes.data());
  }
}

// Save the frame just drawn (the back buffer) as an image file. The bytes
// are sRGB already: they go through save_image() as their linear values,
// which it encodes back to the same bytes.
static void save_screenshot(const std::string& filename, vec2i size) {
  auto bytes = std::vector<uint8_t>((size_t)size.x * size.y * 4);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, size.x, size.y, GL_RGBA, GL_UNSIGNED_BYTE, bytes.data());
  auto image = make_image(size.x, size.y);
  for (auto j = 0; j < size.y; j++) {
    for (auto i = 0; i < size.x; i++) {
      // OpenGL's rows go bottom-up; the window has no meaningful alpha.
      auto byte          = &bytes[((size_t)(size.y - 1 - j) * size.x + i) * 4];
      pixel(image, i, j) = {srgb_to_linear(byte_to_float(byte[0])),
          srgb_to_linear(byte_to_float(byte[1])),
          srgb_to_linear(byte_to_float(byte[2])), 1};
    }
  }
  save_image(filename, image);
}

// -----------------------------------------------------------------------------
// VIEWER STATE
// -----------------------------------------------------------------------------

// What the interface thread owns.
struct viewer_state {
  trace_params             params    = {};
  std::vector<camera_data> cameras   = {};  // navigated here, copied to jobs
  float                    exposure  = 0;
  bool                     filmic    = false;
  int64_t                  job       = 0;   // newest job posted
  render_update            shown     = {};  // the image on screen
  bool                     has_image = false;
  display_texture          texture   = {};
  std::string              message   = "";  // result of the save button
  int view = 0;  // 0: the image; k: the layer of aov_type k - 1
};

// The view and denoising settings of the panel.
static render_view current_view(const viewer_state& state) {
  return {state.view, state.params.denoise, state.params.denoiser};
}

// Post the current parameters and camera as a new job, keeping what every
// view reads.
static void restart(viewer_state& state, render_worker& worker) {
  state.job = restart_render(
      worker, {viewer_params_for_views(state.params),
                  state.cameras[state.params.camera], current_view(state)});
}

// Whether the image on screen has all the samples of the newest job.
static bool render_finished(const viewer_state& state) {
  return state.has_image && state.shown.job == state.job &&
         !state.shown.preview && state.shown.samples >= state.params.samples;
}

// Name of a camera in the combo box.
static std::string camera_label(const viewer_state& state, int index) {
  auto& name = state.cameras[index].name;
  return name.empty() ? "camera" + std::to_string(index) : name;
}

// -----------------------------------------------------------------------------
// PANEL
// -----------------------------------------------------------------------------

// A combo box over a names table; returns the choice, or "" when unchanged.
static std::string combo_names(const char* label,
    const std::vector<std::string>& names, const std::string& current) {
  auto choice = std::string{};
  if (ImGui::BeginCombo(label, current.c_str())) {
    for (auto& name : names)
      if (ImGui::Selectable(name.c_str(), name == current) && name != current)
        choice = name;
    ImGui::EndCombo();
  }
  return choice;
}

// The widget of one option of the table (render_options.h): its slider
// range, its help as the tooltip. Returns whether the value changed; a value
// typed out of the table's range (ctrl+click) is refused, not clamped.
static bool draw_option(
    render_settings& settings, const render_option& option) {
  auto label = option.name.c_str();
  auto text  = get_render_option(settings, option);
  auto value = std::string{};
  auto flags = option.log ? ImGuiSliderFlags_Logarithmic : 0;
  switch (option.type) {
    case render_option_type::integer: {
      auto number = std::stoi(text);
      if (ImGui::SliderInt(label, &number, (int)option.ui_min,
              (int)option.ui_max, "%d", flags))
        value = std::to_string(number);
      break;
    }
    case render_option_type::number: {
      auto number = std::stof(text);
      if (ImGui::SliderFloat(label, &number, (float)option.ui_min,
              (float)option.ui_max, "%.2f", flags)) {
        char buffer[32];
        std::snprintf(buffer, sizeof(buffer), "%.9g", number);  // exact
        value = buffer;
      }
      break;
    }
    case render_option_type::flag: {
      auto flag = text == "true";
      if (ImGui::Checkbox(label, &flag)) value = flag ? "true" : "false";
      break;
    }
    case render_option_type::choice:
      value = combo_names(label, *option.choices, text);
      break;
    case render_option_type::seed:
    case render_option_type::text:
    case render_option_type::list: break;  // not in the viewer
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", option.help.c_str());
  if (value.empty() || value == text) return false;
  try {
    set_render_option(settings, option, value);
  } catch (const io_error&) { return false; }
  return true;
}

// The viewer's options of one stage, in the table's order, those that
// refilter or the others; returns whether any changed.
static bool draw_options(render_settings& settings, render_option_stage stage,
    bool refilter = false) {
  auto edited = false;
  for (auto& option : render_option_table())
    if (option.viewer && option.stage == stage && option.refilter == refilter)
      edited |= draw_option(settings, option);
  return edited;
}

// The view combo: the image or one AOV layer; returns whether it changed.
static bool draw_view(viewer_state& state) {
  auto names = std::vector<std::string>{"image"};
  names.insert(names.end(), aov_type_names.begin(), aov_type_names.end());
  auto choice = combo_names("view", names, names[state.view]);
  if (choice.empty()) return false;
  state.view =
      (int)(std::find(names.begin(), names.end(), choice) - names.begin());
  return true;
}

// What the panel changed: the render (start over) or only how it is shown.
struct panel_edits {
  bool render = false;
  bool view   = false;
};

// Render settings: the camera, then the table's (those that refilter in
// `view`).
static panel_edits draw_render_settings(viewer_state& state) {
  auto& params = state.params;
  auto  edited = false;
  auto  label  = camera_label(state, params.camera);
  if (ImGui::BeginCombo("camera", label.c_str())) {
    for (auto i = 0; i < (int)state.cameras.size(); i++) {
      if (ImGui::Selectable(
              camera_label(state, i).c_str(), i == params.camera) &&
          i != params.camera) {
        params.camera = i;
        edited        = true;
      }
    }
    ImGui::EndCombo();
  }
  auto settings   = render_settings{};
  settings.params = params;
  edited |= draw_options(settings, render_option_stage::render);
  auto refiltered = draw_options(settings, render_option_stage::render, true);
  params          = settings.params;
  return {edited, refiltered};
}

// The linear value of the pixel under the mouse.
static void draw_inspector(
    const viewer_state& state, vec2f mouse, const image_rect& rect) {
  auto& image = state.shown.image;
  auto  ij    = image_pixel_at(rect, {image.width, image.height}, mouse);
  if (!state.has_image || ij.x < 0) {
    ImGui::TextUnformatted("pixel: -");
    return;
  }
  auto value = pixel(image, ij.x, ij.y);
  ImGui::Text(
      "pixel: %d %d%s", ij.x, ij.y, state.shown.preview ? " (preview)" : "");
  ImGui::Text("linear: %.4f %.4f %.4f", value.x, value.y, value.z);
  ImGui::Text("alpha: %.4f", value.w);
}

// The panel; returns what changed.
static panel_edits draw_panel(viewer_state& state, const viewer_params& viewer,
    vec2f window, vec2f mouse, const image_rect& rect) {
  ImGui::SetNextWindowPos({0, 0});
  ImGui::SetNextWindowSize({(float)viewer_panel_width, window.y});
  ImGui::Begin("ypathtrace", nullptr,
      ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize |
          ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoTitleBar);
  ImGui::PushItemWidth(-110);
  ImGui::TextUnformatted(viewer.name.c_str());
  auto& shown   = state.shown;
  auto  samples = shown.preview ? 0 : shown.samples;
  auto  overlay = shown.preview ? std::string{"preview"}
                                : "sample " + std::to_string(samples) + "/" +
                                     std::to_string(state.params.samples);
  if (!shown.preview && shown.remaining > 0)
    overlay += ", eta " + format_duration(shown.remaining);
  if (!shown.preview && shown.converged >= 0)
    overlay += ", conv " + std::to_string((int)(100 * shown.converged)) + "%";
  ImGui::ProgressBar(
      (float)samples / state.params.samples, {-1, 0}, overlay.c_str());
  if (state.has_image)
    ImGui::Text("%d x %d, %.3f s/pass", shown.image.width, shown.image.height,
        shown.seconds);
  auto edited = panel_edits{};
  edited.view = draw_view(state);
  if (ImGui::CollapsingHeader("render", ImGuiTreeNodeFlags_DefaultOpen)) {
    auto settings = draw_render_settings(state);
    edited.render |= settings.render;
    edited.view |= settings.view;
  }
  if (ImGui::CollapsingHeader("tonemap", ImGuiTreeNodeFlags_DefaultOpen)) {
    auto settings            = render_settings{};
    settings.params.exposure = state.exposure;
    settings.params.filmic   = state.filmic;
    auto retonemap = draw_options(settings, render_option_stage::output);
    state.exposure = settings.params.exposure;
    state.filmic   = settings.params.filmic;
    if (retonemap && state.has_image)
      upload_image(state.texture, shown.image, state.exposure, state.filmic);
  }
  if (ImGui::CollapsingHeader("inspect", ImGuiTreeNodeFlags_DefaultOpen))
    draw_inspector(state, mouse, rect);
  auto can_save = state.has_image && !shown.preview && !viewer.output.empty();
  if (!can_save) ImGui::BeginDisabled();
  if (ImGui::Button(("save " + viewer.output).c_str())) {
    try {
      save_image(viewer.output, shown.image, state.exposure, state.filmic);
      state.message = "saved " + std::to_string(shown.samples) + " samples";
    } catch (const std::exception& error) { state.message = error.what(); }
  }
  if (!can_save) ImGui::EndDisabled();
  if (!state.message.empty()) ImGui::TextWrapped("%s", state.message.c_str());
  ImGui::PopItemWidth();
  ImGui::End();
  return edited;
}

// -----------------------------------------------------------------------------
// VIEWER
// -----------------------------------------------------------------------------

// Longest wait for input between frames (60 Hz): a finished pass shows
// within a frame even when the user does nothing.
static constexpr double frame_seconds = 1.0 / 60;

// Drags, shift-drags, ctrl-drags and scrolls over the image move the camera;
// returns whether it moved.
static bool navigate(viewer_state& state) {
  auto& io = ImGui::GetIO();
  if (io.WantCaptureMouse) return false;  // the panel has the mouse
  auto& camera = state.cameras[state.params.camera];
  auto  moved  = false;
  if (io.MouseDown[0] && (io.MouseDelta.x != 0 || io.MouseDelta.y != 0)) {
    auto mode = io.KeyShift  ? navigation_mode::pan
                : io.KeyCtrl ? navigation_mode::dolly
                             : navigation_mode::orbit;
    moved |=
        navigate_camera(camera, mode, {io.MouseDelta.x, io.MouseDelta.y}, 0);
  }
  if (io.MouseWheel != 0)
    moved |=
        navigate_camera(camera, navigation_mode::dolly, {0, 0}, io.MouseWheel);
  return moved;
}

// The window and the loop.
void run_viewer(const render_context& context, const trace_params& params,
    const viewer_params& viewer) {
  check_display();
  auto session = gl_session{};
  open_window(session, "ypathtrace - " + viewer.name, viewer.window);

  auto state     = viewer_state{};
  state.params   = params;
  state.cameras  = context.scene.cameras;
  state.exposure = viewer.exposure;
  state.filmic   = viewer.filmic;
  // Declared after the session, so it is joined before the window goes.
  auto worker = render_worker{};
  start_worker(worker, context);
  restart(state, worker);

  auto frame      = 0;
  auto orbit      = viewer.orbit.x != 0 || viewer.orbit.y != 0;
  auto last_frame = std::max(viewer.frames, orbit ? viewer.orbit_frame + 1 : 0);
  while (!glfwWindowShouldClose(session.window)) {
    glfwWaitEventsTimeout(frame_seconds);
    frame += 1;
    if (take_update(worker, state.shown)) {
      state.has_image = true;
      upload_image(
          state.texture, state.shown.image, state.exposure, state.filmic);
    }

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    auto& io     = ImGui::GetIO();
    auto  window = vec2f{io.DisplaySize.x, io.DisplaySize.y};
    auto  mouse  = vec2f{io.MousePos.x, io.MousePos.y};
    auto  rect   = fit_image({state.texture.width, state.texture.height},
           {(float)viewer_panel_width, 0},
           {window.x - viewer_panel_width, window.y});
    auto  edits  = draw_panel(state, viewer, window, mouse, rect);
    auto  restart_needed = edits.render || navigate(state);
    if (orbit && frame == viewer.orbit_frame)
      restart_needed |= navigate_camera(state.cameras[state.params.camera],
          navigation_mode::orbit, viewer.orbit, 0);
    if (restart_needed)
      restart(state, worker);
    else if (edits.view)
      show_render(worker, current_view(state));
    if (state.has_image)
      ImGui::GetBackgroundDrawList()->AddImage(
          (ImTextureID)(intptr_t)state.texture.id, {rect.min.x, rect.min.y},
          {rect.min.x + rect.size.x, rect.min.y + rect.size.y});
    ImGui::Render();

    auto framebuffer = vec2i{};
    glfwGetFramebufferSize(session.window, &framebuffer.x, &framebuffer.y);
    glViewport(0, 0, framebuffer.x, framebuffer.y);
    glClearColor(0.15f, 0.15f, 0.15f, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (viewer.frames > 0 && frame >= last_frame && render_finished(state)) {
      if (!viewer.screenshot.empty())
        save_screenshot(viewer.screenshot, framebuffer);
      glfwSetWindowShouldClose(session.window, GLFW_TRUE);
    }
    glfwSwapBuffers(session.window);
  }
  stop_worker(worker);
  if (state.texture.id != 0) glDeleteTextures(1, &state.texture.id);
}

}  // namespace implicit
