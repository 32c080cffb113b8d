// The editor's window output: the shared Device with the window's surface, the Swapchain, the
// Renderer drawing the World into each swapchain image, then Dear ImGui in its own VkRenderPass on
// top (ImGui 1.86's Vulkan backend needs one), and an optional read-back of the finished frame
// (screenshots, taken from the swapchain image before it is presented).
// Main thread only; one frame in flight (the Swapchain waits for the previous one).
#pragma once

#include <cstdint>
#include <memory>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/render/device.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/swapchain.h"

struct GLFWwindow;
struct ImDrawData;

namespace penumbra::editor {

struct ViewportOptions {
  bool validation = false;  // the Khronos validation layer; messages are counted by the Device
  VkPresentModeKHR present_mode = VK_PRESENT_MODE_FIFO_KHR;
};

// Where the last frame's time went, in milliseconds.
struct ViewportTimes {
  double wait_ms = 0.0;     // acquire: waiting for the previous frame's GPU work (lavapipe: the rasteriser)
  double record_ms = 0.0;   // renderer sync + record, UI record
  double present_ms = 0.0;  // submit + present (+ read-back when capturing)
};

class Viewport {
 public:
  // Creates the Device (with GLFW's instance extensions), the window surface, the Swapchain, the
  // Renderer and ImGui's Vulkan backend (the ImGui context and its GLFW backend must exist).
  static Result<std::unique_ptr<Viewport>> create(GLFWwindow* window, const ViewportOptions& options);
  ~Viewport();
  Viewport(const Viewport&) = delete;
  Viewport& operator=(const Viewport&) = delete;

  // Draws one frame: sync + record of the World, then `ui` on top, then present. With `capture`,
  // the presented image is also read back into capture->rgba8 (RGBA, sRGB-encoded). A resized
  // window recreates the swapchain and skips the frame (returns success).
  Status draw(World& world, const CameraView& camera, const RenderSettings& settings, ImDrawData* ui,
              Image* capture = nullptr);

  // The 3D view is rendered at `scale` x the window size (0.25 to 1) into an image of its own and
  // scaled up to the window with a linear blit; the UI stays at full resolution. On a CPU device
  // the per-pixel shading dominates the frame, so 0.5 costs about a quarter of it.
  void set_render_scale(float scale);
  float render_scale() const;

  Device& device() { return *device_; }
  Renderer& renderer() { return *renderer_; }
  VkExtent2D extent() const;
  const ViewportTimes& times() const { return times_; }

 private:
  struct Impl;
  explicit Viewport(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  Device* device_ = nullptr;
  Renderer* renderer_ = nullptr;
  ViewportTimes times_;
};

}  // namespace penumbra::editor
