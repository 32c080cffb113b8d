// penumbra-editor: the interactive editor, and its scripted mode for tests and demos.
//
//   penumbra-editor [SCENE] [--script FILE] [--validation] [--size WxH] [--present fifo|mailbox|immediate]
//                   [--shadow-map SIZE] [--render-scale S]
//
// The loop: poll events, collect finished bakes, step the script, update the World, draw the
// panels, render the viewport and the UI, present. At exit it prints the frame times (median and
// 95th percentile, split by whether a bake was running) and, with --validation, fails when the
// validation layer reported anything.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <glm/gtc/quaternion.hpp>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <imgui.h>

#include "penumbra/scene/animation.h"

#include "camera_control.h"
#include "gizmo.h"
#include "overlays.h"
#include "panels.h"
#include "picking.h"
#include "script.h"
#include "viewport.h"

namespace penumbra::editor {
namespace {

struct Options {
  std::string scene = "builtin:courtyard";
  std::string script;
  bool validation = false;
  int width = 1280, height = 720;
  VkPresentModeKHR present = VK_PRESENT_MODE_FIFO_KHR;
  std::uint32_t shadow_map_size = 512;  // 0: no shadows (the View panel changes it too)
  // Of the 3D view (the View panel changes it too); 0: 0.5 on a CPU device (lavapipe), where the
  // lit shader dominates the frame, else 1.
  float render_scale = 0.0f;
};

int usage(const char* message) {
  std::fprintf(stderr,
               "penumbra-editor: %s\nusage: penumbra-editor [SCENE] [--script FILE] [--validation] [--size WxH] "
               "[--present fifo|mailbox|immediate] [--shadow-map SIZE] [--render-scale S]\n",
               message);
  return 2;
}

// Mouse and keyboard to the camera, when ImGui does not want them. Ctrl + left drag is the
// overlays' (moving a light: extension.h), not the camera's.
void camera_input(GLFWwindow* window, CameraControl& camera, double dt) {
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.WantCaptureMouse && !io.KeyCtrl) {
    const glm::vec2 delta(io.MouseDelta.x, io.MouseDelta.y);
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) camera.rotate(delta);
    if (ImGui::IsMouseDown(ImGuiMouseButton_Middle)) camera.pan(delta);
    if (io.MouseWheel != 0.0f) camera.zoom(io.MouseWheel);
  }
  if (!io.WantCaptureKeyboard && camera.mode() == CameraControl::Mode::Fly) {
    glm::vec3 m(0.0f);
    if (glfwGetKey(window, GLFW_KEY_W) == GLFW_PRESS) m.z += 1;
    if (glfwGetKey(window, GLFW_KEY_S) == GLFW_PRESS) m.z -= 1;
    if (glfwGetKey(window, GLFW_KEY_D) == GLFW_PRESS) m.x += 1;
    if (glfwGetKey(window, GLFW_KEY_A) == GLFW_PRESS) m.x -= 1;
    if (glfwGetKey(window, GLFW_KEY_E) == GLFW_PRESS) m.y += 1;
    if (glfwGetKey(window, GLFW_KEY_Q) == GLFW_PRESS) m.y -= 1;
    camera.move(m * static_cast<float>(dt) * 0.3f * camera.radius);
  }
}

// A left click in the 3D view (press and release within a few pixels, not over a panel, without
// Ctrl) selects what is under the pointer (picking.h); a click on nothing clears the selection.
void click_select(Document& doc, const CameraView& camera, glm::vec2 size, std::string& message) {
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantCaptureMouse || io.KeyCtrl || !ImGui::IsMouseReleased(ImGuiMouseButton_Left)) return;
  const glm::vec2 at(io.MousePos.x, io.MousePos.y), from(io.MouseClickedPos[0].x, io.MouseClickedPos[0].y);
  if (glm::distance(at, from) > 4.0f) return;  // a drag turned the camera
  auto picked = pick(doc.world(), camera, at, size);
  if (!picked) {
    message = "select: " + picked.error().message;
    return;
  }
  doc.select(*picked);
  if (!*picked) {
    message = "selection cleared";
  } else if (const Name* name = doc.world().try_get<Name>(*picked)) {
    message = "selected '" + name->value + "'";
  } else {
    message = "selected #" + std::to_string(picked->index);
  }
  std::printf("%s\n", message.c_str());  // for scripted runs and logs
}

// A scripted pointer: a click (from == to) or a drag over `frames` frames: hover at `from`, press,
// move to `to` over the frames between, release. Applied after the GLFW backend, which reads the
// real pointer.
struct ScriptedPointer {
  glm::vec2 from{0.0f}, to{0.0f};
  int frames = 0, frame = 0;  // frames in all; the next one
  bool active() const { return frame < frames; }
  void apply(ImGuiIO& io) {
    const float t = std::clamp(float(frame - 1) / float(std::max(frames - 3, 1)), 0.0f, 1.0f);
    const glm::vec2 p = from + t * (to - from);
    io.MousePos = ImVec2(p.x, p.y);
    io.MouseDown[0] = frame >= 1 && frame <= frames - 2;
    ++frame;
  }
};

// The gizmo's drag in progress (gizmo.h): the axis grabbed (-1: none), the mode, the entity, its
// world position, local rotation and scale, the handles' directions (gizmo_axes), the pointer and
// the handles' length when it was grabbed.
struct GizmoDrag {
  int axis = -1;
  GizmoMode mode = GizmoMode::Move;
  Entity entity;
  glm::vec3 start{0.0f};
  glm::mat3 axes{1.0f};
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};
  glm::vec3 scale{1.0f};
  glm::vec2 grab{0.0f};
  float length = 1.0f;
};

// The selection's world position, when it has a Transform the gizmo can move.
std::optional<glm::vec3> gizmo_origin(World& world, Entity e) {
  if (!e || !world.alive(e) || !world.has<Transform>(e)) return std::nullopt;
  const WorldTransform* wt = world.try_get<WorldTransform>(e);
  return wt ? std::optional<glm::vec3>(glm::vec3(wt->matrix[3])) : std::nullopt;
}

// A left press on one of the gizmo's handles (not over a panel, without Ctrl) starts a drag
// about or along its axis; while the button is down the selection follows the pointer, as one
// undoable edit of Transform.translation, .rotation or .scale (through the parent's world matrix;
// a refused value goes to `message`). Returns whether the gizmo holds the pointer this frame (a
// drag in progress, or one that just ended): the camera does not turn and a release does not
// select.
bool gizmo_input(Document& doc, GizmoDrag& drag, GizmoMode mode, const CameraView& camera, glm::vec2 size,
                 std::string& message) {
  const ImGuiIO& io = ImGui::GetIO();
  World& world = doc.world();
  const glm::vec2 mouse(io.MousePos.x, io.MousePos.y);
  if (drag.axis < 0) {
    if (io.WantCaptureMouse || io.KeyCtrl || !ImGui::IsMouseClicked(ImGuiMouseButton_Left)) return false;
    const auto origin = gizmo_origin(world, doc.selection());
    const glm::mat3 axes = gizmo_axes(world, doc.selection(), mode);
    const auto handles = origin ? gizmo_handles(camera, *origin, size, mode, axes) : std::nullopt;
    const int axis = handles ? pick_gizmo_axis(*handles, mouse) : -1;
    if (axis < 0) return false;
    const Transform& t = world.get<Transform>(doc.selection());
    drag = GizmoDrag{axis, mode, doc.selection(), *origin, axes, t.rotation, t.scale, mouse, handles->length};
    return true;
  }
  if (!world.alive(drag.entity) || !ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
    drag.axis = -1;
    doc.undo().end_merge();
    return true;
  }
  const glm::vec3 axis = drag.axes[drag.axis];
  const glm::mat4 parent_world = parent_world_matrix(world, drag.entity);
  const char* field = "translation";
  FieldValue value;
  if (drag.mode == GizmoMode::Move) {
    const glm::vec3 target = drag.start + drag_along_axis(camera, drag.start, axis, drag.grab, mouse, size);
    value = glm::vec3(glm::inverse(parent_world) * glm::vec4(target, 1.0f));
  } else if (drag.mode == GizmoMode::Rotate) {
    // A turn about the world axis, in the parent's frame: q_parent^-1 R q_parent q_local.
    const glm::mat3 m(parent_world);
    const glm::quat parent_rotation =
        glm::quat_cast(glm::mat3(glm::normalize(m[0]), glm::normalize(m[1]), glm::normalize(m[2])));
    const glm::quat turn = glm::angleAxis(rotate_about_axis(camera, drag.start, axis, drag.grab, mouse, size), axis);
    field = "rotation";
    value = glm::normalize(glm::inverse(parent_rotation) * turn * parent_rotation * drag.rotation);
  } else {
    glm::vec3 scale = drag.scale;
    scale[drag.axis] *= scale_along_axis(camera, drag.start, axis, drag.length, drag.grab, mouse, size);
    field = "scale";
    value = scale;
  }
  const FieldDesc* desc = find_field("Transform", field);
  if (desc == nullptr) return true;
  if (Status s = doc.undo().set(world, drag.entity, *desc, value, /*merge=*/true); !s)
    message = std::string(to_string(drag.mode)) + ": " + s.error().message;
  return true;
}

// The reference map the View panel or a script asked for (UiState::reference_requested): the
// real-time lit view at the map's size (its cells follow the viewport's aspect), then the offline
// reference in the background.
void start_reference_map(UiState& ui, Document& doc, Renderer& renderer, const CameraView& camera, glm::vec2 size) {
  ui.reference_requested = false;
  ReferenceMapRequest request;
  request.camera = camera;
  request.columns =
      std::max(1u, static_cast<std::uint32_t>(std::lround(float(request.rows) * size.x / std::max(size.y, 1.0f))));
  request.spp = static_cast<std::uint32_t>(ui.reference_spp);
  RenderSettings lit = ui.render;
  lit.view = "lit";
  auto image = renderer.render_image(doc.world(), camera, request.width(), request.height(), lit, true);
  if (!image) {
    ui.message = "reference map: " + image.error().message;
    return;
  }
  std::vector<glm::vec3> tested(std::size_t{request.width()} * request.height());
  for (std::size_t i = 0; i < tested.size(); ++i)
    tested[i] = pixel_rgb(*image, i);
  const Status started = ui.reference_job.start(doc.world(), std::move(tested), request);
  ui.message = started ? "rendering the offline reference of this frame (" + std::to_string(request.spp) +
                             " paths per pixel) in the background"
                       : started.error().message;
}

// Takes the finished reference map, if any, into the UI (or its error, which names the map, into
// the status bar).
void collect_reference_map(UiState& ui) {
  auto done = ui.reference_job.take();
  if (!done) return;
  if (done->ok()) {
    ui.reference_map = std::move(done->value());
    ui.message = describe_reference_map(*ui.reference_map);
  } else {
    ui.message = done->error().message;
  }
}

int run(const Options& options) {
  // The script first: a bad script is reported before any window opens.
  std::optional<ScriptRunner> runner;
  UiState ui;
  ui.render.shadows = options.shadow_map_size > 0;
  ui.render.shadow_map_size = std::max(options.shadow_map_size, 64u);
  std::string pending_screenshot;
  bool reference_started = false;  // by the running script's `reference-map`
  ScriptedPointer pointer;
  std::optional<std::pair<int, float>> gizmo_request;  // drag-gizmo AXIS PIXELS, resolved in the next frame
  GizmoDrag gizmo;
  if (!options.script.empty()) {
    auto script = load_script(options.script);
    if (!script) {
      std::fprintf(stderr, "penumbra-editor: %s\n", script.error().message.c_str());
      return 1;
    }
    runner.emplace(std::move(*script), [&](const ScriptAction& a, bool& again) -> Status {
      if (a.verb == "reference-map") {
        // Asks for the map at the next frame, then waits for it and prints its line.
        if (!reference_started) {
          ui.reference_spp = std::stoi(a.args[0]);
          ui.reference_map.reset();
          ui.reference_requested = reference_started = again = true;
          return {};
        }
        collect_reference_map(ui);
        if (ui.reference_requested || ui.reference_job.running()) {
          again = true;
          return {};
        }
        reference_started = false;
        if (!ui.reference_map) return make_error(ErrorCode::InvalidInput, ui.message);
        std::printf("%s\n", describe_reference_map(*ui.reference_map).c_str());
        return {};
      }
      if (a.verb == "screenshot") {
        pending_screenshot = a.args[0];
      } else if (a.verb == "orbit") {
        const float dist = a.args.size() == 3 ? std::stof(a.args[2]) : 0.0f;
        ui.camera.set_orbit(glm::radians(std::stof(a.args[0])), glm::radians(std::stof(a.args[1])), dist);
      } else if (a.verb == "reset-stats") {
        ui.frames = FrameTimes{};
        ui.frames.frames = FrameTimes::kWarmUp;  // already warm
      } else if (a.verb == "click") {
        const glm::vec2 at(std::stof(a.args[0]), std::stof(a.args[1]));
        pointer = ScriptedPointer{at, at, 3, 0};
      } else if (a.verb == "gizmo") {
        ui.gizmo_mode = a.args[0] == "rotate" ? GizmoMode::Rotate : a.args[0] == "scale" ? GizmoMode::Scale : GizmoMode::Move;
      } else if (a.verb == "drag-gizmo") {
        gizmo_request = std::pair{int(a.args[0][0] - 'x'), std::stof(a.args[1])};
      } else if (a.verb == "ui") {
        ui.show_ui = a.args[0] == "on";
      } else if (a.verb == "view") {
        std::string all;
        for (const ViewInfo& v : ui.views) {
          if (v.name == a.args[0]) {
            ui.render.view = a.args[0];
            return {};
          }
          all += (all.empty() ? "" : ", ") + std::string(v.name);
        }
        return make_error(ErrorCode::InvalidArgument, "unknown view '" + a.args[0] + "'; use one of " + all);
      }
      return {};
    });
  }

  if (!glfwInit()) {
    std::fprintf(stderr, "penumbra-editor: cannot open a window (no X display?); run under xvfb-run -a\n");
    return 1;
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  GLFWwindow* window = glfwCreateWindow(options.width, options.height, "Penumbra editor", nullptr, nullptr);
  if (!window) {
    std::fprintf(stderr, "penumbra-editor: glfwCreateWindow failed\n");
    glfwTerminate();
    return 1;
  }
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // the layout is the code's, not a file's
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForVulkan(window, true);
  int exit_code = 0;
  {
    ViewportOptions vo;
    vo.validation = options.validation;
    vo.present_mode = options.present;
    auto viewport = Viewport::create(window, vo);
    if (!viewport) {
      std::fprintf(stderr, "penumbra-editor: %s\n", viewport.error().message.c_str());
      exit_code = 1;
    } else {
      ui.render_scale = options.render_scale > 0.0f ? options.render_scale
                                                    : ((*viewport)->device().is_software() ? 0.5f : 1.0f);
      ui.views = (*viewport)->renderer().views();
      (*viewport)->set_render_scale(ui.render_scale);
      EditorModel model;
      if (!runner) {
        if (Status s = model.open(options.scene); !s) {
          std::fprintf(stderr, "penumbra-editor: %s\n", s.error().message.c_str());
          exit_code = 1;
        }
      }
      std::string opened_source;
      auto last = std::chrono::steady_clock::now();
      bool quit = exit_code != 0;
      while (!quit && !glfwWindowShouldClose(window)) {
        const auto start = std::chrono::steady_clock::now();
        const double dt = std::chrono::duration<double>(start - last).count();
        last = start;
        glfwPollEvents();
        const bool baking = model.bakes().running();
        if (model.poll()) {  // a bake ended: its outcome replaces "bake started"
          const BakeStatus& st = model.bakes().status();
          char done[128];
          if (st.estimate)
            std::snprintf(done, sizeof done, "estimate done in %.2f s: the bake would take ~%.2f s", st.seconds,
                          st.estimate->seconds());
          else
            std::snprintf(done, sizeof done, "bake done in %.2f s, %.1f KiB", st.seconds, double(st.bytes) / 1024.0);
          const char* what = st.estimating ? "estimate " : "bake ";
          ui.message = st.state == BakeStatus::State::Done      ? std::string(done)
                       : st.state == BakeStatus::State::Running ? "estimated a preset; estimating the next"
                                                                : what + std::string(to_string(st.state)) + ": " + st.error;
          std::printf("%s\n", ui.message.c_str());  // for scripted runs and logs
        }
        if (Status s = model.auto_bake_tick(glfwGetTime()); !s) ui.message = "auto-bake: " + s.error().message;
        if (runner && !pointer.active() && !gizmo_request) {  // a click or drag in progress holds the script
          if (Status s = runner->step(model); !s) {
            std::fprintf(stderr, "penumbra-editor: %s\n", s.error().message.c_str());
            exit_code = 1;
            break;
          }
          if (runner->quit_requested() || runner->finished()) {
            quit = true;
            exit_code = runner->exit_code();
          }
        }
        if (!ui.open_request.empty()) {
          // Between frames: nothing holds a reference into the document being replaced.
          const std::string source = std::exchange(ui.open_request, {});
          const Status s = model.open(source);
          ui.message = s ? "opened " + source : s.error().message;
        }
        if (!model.document()) {
          pointer = {};  // no panels to click
          gizmo_request.reset();
          if (runner) continue;  // the script has not opened a scene yet
          break;
        }
        Document& doc = *model.document();
        doc.world().update(dt);
        if (doc.source() != opened_source) {  // after the update, which poses skinned meshes
          // The scene's camera when it has one, else a view framing everything.
          const Aabb bounds = posed_bounds(doc.world());
          ui.camera = CameraControl{};  // from the front and above, as the default light shines
          if (!look_through_scene_camera(doc.world(), bounds, ui.camera)) ui.camera.frame(bounds);
          opened_source = doc.source();
          // The reference map is of the scene before: dropped, and a running one stopped.
          ui.reference_map.reset();
          ui.reference_job.cancel();
          (void)ui.reference_job.take();
          if (!doc.notice().empty()) ui.message = doc.notice();
          std::snprintf(ui.gltf_path, sizeof ui.gltf_path, "%s", doc.source().starts_with("builtin:") ? "scene.glb"
                                                                                                  : doc.source().c_str());
        }

        const VkExtent2D extent = (*viewport)->extent();
        const glm::vec2 size(static_cast<float>(extent.width), static_cast<float>(extent.height));
        if (gizmo_request) {  // the script's drag-gizmo: from 60 % along the arrow, along it
          const auto [axis, pixels] = *std::exchange(gizmo_request, std::nullopt);
          const auto origin = gizmo_origin(doc.world(), doc.selection());
          const CameraView view = ui.camera.view(size.x / std::max(size.y, 1.0f));
          // Move and scale: from 60 % along the arrow, along it. Rotate: from the ring's point
          // farthest from the centre, across the screen (a turn about the centre).
          const auto handles =
              origin ? gizmo_handles(view, *origin, size, ui.gizmo_mode, gizmo_axes(doc.world(), doc.selection(), ui.gizmo_mode))
                     : std::nullopt;
          const auto k = static_cast<std::size_t>(axis);
          std::optional<std::pair<glm::vec2, glm::vec2>> path;
          if (handles && ui.gizmo_mode != GizmoMode::Rotate && handles->tips[k]) {
            const glm::vec2 from = glm::mix(handles->origin, *handles->tips[k], 0.6f);
            path = std::pair{from, from + pixels * glm::normalize(*handles->tips[k] - handles->origin)};
          } else if (handles && ui.gizmo_mode == GizmoMode::Rotate && !handles->rings[k].empty()) {
            const std::vector<glm::vec2>& ring = handles->rings[k];
            const auto far = std::max_element(ring.begin(), ring.end(), [&](glm::vec2 p, glm::vec2 q) {
              return glm::distance(p, handles->origin) < glm::distance(q, handles->origin);
            });
            const glm::vec2 out = glm::normalize(*far - handles->origin);
            path = std::pair{*far, *far + pixels * glm::vec2(out.y, -out.x)};
          }
          if (!path) {
            std::fprintf(stderr, "penumbra-editor: drag-gizmo: %s\n",
                         origin ? "that handle is not on screen; orbit the camera" : "select an entity with a Transform first");
            exit_code = 1;
            break;
          }
          pointer = ScriptedPointer{path->first, path->second, 8, 0};
        }
        ImGui_ImplVulkan_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        if (pointer.active()) pointer.apply(ImGui::GetIO());  // after the backend, which reads the real pointer
        ImGui::NewFrame();
        const bool gizmo_busy =
            ui.show_ui &&
            gizmo_input(doc, gizmo, ui.gizmo_mode, ui.camera.view(size.x / std::max(size.y, 1.0f)), size, ui.message);
        if (!gizmo_busy) camera_input(window, ui.camera, dt);
        draw_panels(model, ui);
        const CameraView camera = ui.camera.view(size.x / std::max(size.y, 1.0f));
        ui.camera_now = camera;
        if (ui.reference_requested) start_reference_map(ui, doc, (*viewport)->renderer(), camera, size);
        collect_reference_map(ui);
        if (!gizmo_busy) click_select(doc, camera, size, ui.message);
        if (ui.show_ui) {
          draw_selection(ImGui::GetBackgroundDrawList(), doc.world(), doc.selection(), camera, size);
          draw_lights(ImGui::GetBackgroundDrawList(), doc.world(), doc.selection(), camera, size);
          if (const auto origin = gizmo_origin(doc.world(), doc.selection()))
            draw_gizmo(ImGui::GetBackgroundDrawList(), camera, *origin, size, ui.gizmo_mode,
                       gizmo_axes(doc.world(), doc.selection(), ui.gizmo_mode), gizmo.axis);
          if (ui.reference_map) draw_error_map(*ui.reference_map, size, ImGui::GetBackgroundDrawList());
          ViewContext view{doc.world(), doc.selection(), camera, size, ui.message};
          for (const EditorExtension& x : editor_extensions())
            if (x.draw_overlay) x.draw_overlay(view, ImGui::GetBackgroundDrawList());
        }
        ImGui::Render();
        (*viewport)->set_render_scale(baking ? std::min(ui.render_scale, ui.bake_render_scale) : ui.render_scale);

        Image shot;
        const bool capture = !pending_screenshot.empty();
        if (Status s = (*viewport)->draw(doc.world(), camera, ui.render, ImGui::GetDrawData(), capture ? &shot : nullptr);
            !s) {
          std::fprintf(stderr, "penumbra-editor: frame: %s\n", s.error().message.c_str());
          exit_code = 1;
          break;
        }
        ui.renderer_stats = (*viewport)->renderer().stats();
        if (capture) {
          if (Status s = write_image(shot, pending_screenshot); !s) {
            std::fprintf(stderr, "penumbra-editor: screenshot: %s\n", s.error().message.c_str());
            exit_code = 1;
            break;
          }
          pending_screenshot.clear();
        } else {
          // Frame time: everything from polling to present, screenshots (PNG encoding) excluded.
          ui.frames.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
                        baking, (*viewport)->times());
        }
        // A running bake keeps the cores: the frame waits out the rest of its 1 / bake_fps.
        if (baking && ui.bake_fps > 0)
          std::this_thread::sleep_until(start + std::chrono::microseconds(1000000 / ui.bake_fps));
      }
      model.bakes().cancel();
      model.bakes().wait();
      const FrameSummary idle = summarise(ui.frames.idle_ms), bake = summarise(ui.frames.baking_ms);
      const VkExtent2D extent = (*viewport)->extent();
      std::printf("frame ms at %ux%u (3D view x%.2f) on %s, after %zu warm-up frames: idle median %.1f p95 %.1f max %.1f (%zu frames); during bakes median "
                  "%.1f p95 %.1f max %.1f (%zu frames)\n",
                  extent.width, extent.height, static_cast<double>(ui.render_scale), (*viewport)->device().name().c_str(), FrameTimes::kWarmUp, idle.median, idle.p95, idle.max,
                  idle.frames, bake.median, bake.p95, bake.max, bake.frames);
      const FrameSummary wait = summarise(ui.frames.wait_ms), record = summarise(ui.frames.record_ms),
                         present = summarise(ui.frames.present_ms);
      std::printf("  medians of the parts: waiting for the previous frame %.1f ms, sync + record %.1f ms, submit + "
                  "present %.1f ms\n",
                  wait.median, record.median, present.median);
      if (options.validation) {
        const std::uint32_t messages = (*viewport)->device().validation_messages();
        std::printf("validation messages: %u\n", messages);
        if (messages > 0) {
          std::fprintf(stderr, "penumbra-editor: the validation layer reported %u messages; the last: %s\n", messages,
                       (*viewport)->device().last_validation_message().c_str());
          exit_code = 1;
        }
      }
    }
  }
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return exit_code;
}

}  // namespace
}  // namespace penumbra::editor

int main(int argc, char** argv) {
  penumbra::editor::Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--script" && has_value) {
      options.script = argv[++i];
    } else if (a == "--validation") {
      options.validation = true;
    } else if (a == "--size" && has_value) {
      if (std::sscanf(argv[++i], "%dx%d", &options.width, &options.height) != 2 || options.width < 64 ||
          options.height < 64 || options.width > 16384 || options.height > 16384)
        return penumbra::editor::usage("--size takes WxH, e.g. 1280x720");
    } else if (a == "--render-scale" && has_value) {
      char* end = nullptr;
      options.render_scale = std::strtof(argv[++i], &end);
      if (*end != '\0' || !(options.render_scale >= 0.25f && options.render_scale <= 1.0f))
        return penumbra::editor::usage("--render-scale takes a number from 0.25 to 1");
    } else if (a == "--shadow-map" && has_value) {
      char* end = nullptr;
      const unsigned long n = std::strtoul(argv[++i], &end, 10);
      if (*end != '\0' || n > 8192) return penumbra::editor::usage("--shadow-map takes a size up to 8192 (0: no shadows)");
      options.shadow_map_size = static_cast<std::uint32_t>(n);
    } else if (a == "--present" && has_value) {
      const std::string m = argv[++i];
      if (m == "fifo") options.present = VK_PRESENT_MODE_FIFO_KHR;
      else if (m == "mailbox") options.present = VK_PRESENT_MODE_MAILBOX_KHR;
      else if (m == "immediate") options.present = VK_PRESENT_MODE_IMMEDIATE_KHR;
      else return penumbra::editor::usage("--present takes fifo, mailbox or immediate");
    } else if (a.starts_with("-")) {
      return penumbra::editor::usage(("unknown option or missing value: " + a).c_str());
    } else {
      options.scene = a;
    }
  }
  return penumbra::editor::run(options);
}
