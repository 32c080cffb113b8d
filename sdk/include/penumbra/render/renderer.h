// The forward renderer: draws a World with every lighting technique's data it finds.
//
// Mirrors the World into GPU resources (sync), then records a frame into a command buffer
// (record) that draws into a RenderTarget. Passes: shadow maps for the shadowed lights, then one
// forward pass (GPU skinning, base colour textures, direct light with filtered shadow maps,
// indirect diffuse from the probe grid per pixel, AO fields per pixel, pose-AO / vertex AO as a
// vertex attribute), then tone mapping. A pass whose data the scene lacks is skipped and costs
// nothing. The layouts shared with the GLSL in shaders/ are defined once, in shaders/shared/.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/device.h"

namespace penumbra {

enum class DebugView : std::uint8_t {
  Lit,            // direct + indirect, AO applied, tone mapped
  DirectOnly,     // direct light with shadows
  IndirectOnly,   // probe-grid irradiance x albedo (x AO)
  AoOnly,         // the product of every AO term as grey
  Albedo,         // base colour x texture
  ProbeValidity,  // the probe grid's interpolated validity as a colour ramp
};
// "lit", "direct", "indirect", "ao", "albedo", "validity"; nullopt-like error for anything else.
Result<DebugView> parse_debug_view(std::string_view name);
std::string_view debug_view_name(DebugView view);

struct CameraView {
  glm::mat4 view{1.0f};        // world -> camera
  glm::mat4 projection{1.0f};  // camera -> clip, Vulkan conventions (y down, depth 0..1)
  glm::vec3 position{0.0f};    // world-space eye
};
// The CameraView of a Camera entity at its WorldTransform, for a target of the given aspect.
CameraView camera_view(const World& world, Entity camera, float aspect);
// A camera that frames the bounds of every mesh, looking from the front and above.
CameraView framing_camera_view(const World& world, float aspect);

struct RenderSettings {
  DebugView view = DebugView::Lit;
  float exposure = 1.0f;               // scene-referred radiance multiplier before tone mapping
  bool shadows = true;
  std::uint32_t shadow_map_size = 1024;
};

// A colour image the renderer draws into (offscreen, or a swapchain image wrapped by the caller).
// The renderer owns the matching depth buffer. On entry of record() the image is in `layout`;
// on exit it is in `final_layout`.
struct RenderTarget {
  VkImage image = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  std::uint32_t width = 0, height = 0;
  VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageLayout final_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
};

// A CPU image read back from a target: RGBA, 8-bit sRGB or 32-bit float linear.
struct Image {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgba8;  // when read as 8-bit
  std::vector<float> rgba32f;       // when read as float
};
// PNG (8-bit) or OpenEXR (float) by extension; atomic (temporary file, then rename).
Status write_image(const Image& image, const std::string& path);

struct FrameStats {
  double cpu_record_ms = 0.0;   // sync + record on the CPU
  std::uint32_t draws = 0;
  std::uint64_t gpu_bytes = 0;  // buffers and images the renderer holds
};

class Renderer {
 public:
  static Result<std::unique_ptr<Renderer>> create(Device& device);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Uploads what changed since the last call (meshes, materials, textures, lights, skin poses,
  // baked lighting data attached to components). Call after world.update(), before record().
  Status sync(const World& world);

  // Records shadow passes, the forward pass and tone mapping into `cmd` for `target`.
  // Precondition: sync() was called for this frame. Not thread-safe.
  Status record(VkCommandBuffer cmd, const RenderTarget& target, const CameraView& camera,
                const RenderSettings& settings);

  // Convenience for tools and tests: an offscreen frame of size width x height, submitted, waited
  // and read back (8-bit tone-mapped, or float linear when `linear_float`).
  Result<Image> render_image(const World& world, const CameraView& camera, std::uint32_t width,
                             std::uint32_t height, const RenderSettings& settings,
                             bool linear_float = false);

  const FrameStats& stats() const;

 private:
  struct Impl;
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
