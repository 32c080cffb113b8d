// The forward renderer: draws a World, with what each lighting technique adds drawn by its render
// feature (render/feature.h).
//
// Mirrors the World into GPU resources (sync), then records a frame into a command buffer
// (record) that draws into a RenderTarget. Passes: shadow maps for the shadowed lights (a layer
// is drawn again only when its view or the casters within it changed); a depth pre-pass (so the
// costly fragment stage runs once per pixel); when a feature is active, in the views that show
// ambient light, a G-buffer (normal, receiver code) in that pre-pass and the ambient image at
// every RenderSettings::ambient_step-th pixel (the samples' keys and depths, then the features'
// passes: the probe grid's irradiance, the AO-field casters' occlusion); then one forward pass
// (GPU skinning, base colour textures, direct light with filtered shadow maps, the ambient image
// upsampled along surfaces, per-vertex AO (VertexAO: vertex-AO bakes, pose-AO) as a vertex
// attribute, emission, tone mapping in the same pass). A feature's debug view replaces the
// forward pass by the feature's own full-screen pass. What the scene lacks is skipped and costs
// nothing. The layouts shared with the GLSL in shaders/ are defined once, in shaders/shared/
// layout.h. On llvmpipe, which runs both sides of every branch, what is fixed for a frame (debug
// view, shadow taps, light count, whether the ambient image exists) specialises the pipelines.
//
// Light models (as bake/light_sampling.h): directional illuminance, point/spot intensity with the
// KHR_lights_punctual range window and smooth cone; a Rect light's irradiance is the exact
// unshadowed one (Lambert's polygon formula over the rect clipped to the receiver's horizon), its
// visibility one six-face (cube) shadow map from its centre, so its shadows are hard-edged where the
// real area light's are soft. Its emitter is drawn as a quad of its radiance (a light, not geometry:
// it casts no shadow and no bake sees it). The World's Environment (the sky) is the lit view's
// background.
// Shadow maps: directional orthographic over the bounds of every mesh, spot perspective over the
// outer cone, point and rect six 90-degree faces; PCF over the 2x2 comparison filter (a 3x3 tent
// of four taps, or one tap; at 16 taps a rect light's shadows are percentage-closer soft shadows:
// RenderSettings::shadow_taps). Emissive meshes cast no shadows (an
// emitter would occlude its own light).
// Indirect: L = albedo / pi x E x AO, E the ambient image's irradiance (its sources: the probe
// grid's feature), AO = VertexAO x the ambient image's open fraction (its occluders: the AO-field
// casters) x the draw's entity-wide open fraction (DrawFeatureValues::open). Composition rule:
// each occlusion is counted once. A source's bake already shadows its light by the static
// geometry, so a VertexAO of static occluders (VertexAO::static_occluders: a vertex-AO bake) is
// left out of E's product (it darkened the Cornell box's indirect light to 0.72x the reference:
// penumbra bench image-accuracy); the occluders no bake saw (AO-field casters, pose-AO of
// characters) multiply it. The "ao" view shows every term.
// Tone mapping: exposure, then the ACES filmic fit of Narkowicz (2015), then sRGB.
//
// sync() and render_image() take a mutable World (views need one; nothing is written). One frame
// in flight: record() rewrites the per-frame buffers, so the previous frame's submission must have
// finished (Swapchain::acquire and render_image wait for it).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/device.h"
#include "penumbra/image/image.h"
#include "penumbra/render/feature.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

struct RenderSettings {
  // The debug view by name (Renderer::views()): the renderer's own "lit" (direct + indirect, AO
  // applied, tone mapped), "direct" (direct light with shadows), "indirect" (the ambient
  // sources' irradiance x albedo x AO), "ao" (the product of every AO term as grey), "albedo"
  // (base colour x texture), "position" and "normal" (world space, linear data), or a render
  // feature's (the probe grid's "validity" and "irradiance"). InvalidArgument listing the views
  // for any other name.
  std::string view = "lit";
  float exposure = 1.0f;               // scene-referred radiance multiplier before tone mapping
  bool shadows = true;
  std::uint32_t shadow_map_size = 1024;
  // Taps of the hardware 2x2 comparison filter per shadow lookup: 4 (default) a tent over 3x3
  // texels, 1 a bilinear 2x2 footprint with harder edges, about 10 ms less per 1280x720 frame on
  // 2-core lavapipe (README's renderer row); 16 as 4 for every light but rects, whose shadows
  // soften with the distance to their blocker as the rect's size says (percentage-closer soft
  // shadows: 25 depth taps to find the blockers, 16 filter taps over the penumbra; the Cornell
  // box's frame on lavapipe about 2.2x the 4-tap one). InvalidArgument otherwise.
  std::uint32_t shadow_taps = 4;
  // The ambient image (the render features' irradiance and occlusion, in the lit, indirect and AO
  // views) holds every ambient_step-th pixel per axis: 1 every pixel, 2
  // (default) a quarter of them, which the forward pass upsamples along surfaces. The trade on the
  // courtyard at 1280x720 (penumbra bench render-ao; renderer_test): see README's renderer row.
  // InvalidArgument for anything but 1 or 2.
  std::uint32_t ambient_step = 2;
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

struct FrameStats {
  double cpu_record_ms = 0.0;   // sync + record on the CPU
  std::uint32_t draws = 0;
  std::uint64_t gpu_bytes = 0;  // buffers and images the renderer holds
  std::uint32_t vertex_ao_uploads = 0;        // VertexAO attributes uploaded by the last sync (changed ones)
  // Shadow layers the last frame rendered, of shadow_layers: a layer whose light view and the
  // casters within it (meshes, transforms, poses) are those it holds is kept, not drawn again.
  std::uint32_t shadow_layers_rendered = 0, shadow_layers = 0;
  // The render features' counters of the last sync, "<feature>.<counter>" (e.g. "ao-field.casters",
  // "ao-field.bytes_uploaded", "probe-grid.grids").
  std::vector<std::pair<std::string, std::uint64_t>> counters;
  // The counter named `name`, 0 when no feature reported it.
  std::uint64_t counter(std::string_view name) const;
};

class Renderer {
 public:
  // A renderer with the given render features (render/feature.h), initialised in order.
  // InvalidArgument when two features or views share a name; any feature's init() error.
  static Result<std::unique_ptr<Renderer>> create(Device& device, RenderFeatures features);
  // A renderer with every SDK lighting module's feature (standard_render_features()); defined in
  // penumbra::render, the full renderer target (penumbra::render_core has only the overload above).
  static Result<std::unique_ptr<Renderer>> create(Device& device);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Uploads what changed since the last call (meshes, materials, textures, lights, skin poses,
  // baked lighting data attached to components; VertexAO by its change tick; the AO-field buffer
  // when a caster's AOFieldCaster or WorldTransform changed, only the caster records when just
  // transforms did). Call after world.update(), before record(). Errors: a caster with a singular
  // world matrix (pack_ao_fields_gpu). Cost: O(entities) plus uploads of what changed. Not
  // thread-safe.
  Status sync(World& world);

  // Records the frame's passes (above) into `cmd` for `target`.
  // Precondition: sync() was called for this frame. Not thread-safe.
  Status record(VkCommandBuffer cmd, const RenderTarget& target, const CameraView& camera,
                const RenderSettings& settings);

  // Convenience for tools and tests: an offscreen frame of size width x height, submitted, waited
  // and read back (8-bit tone-mapped, or float linear when `linear_float`).
  // Errors: a zero or larger-than-16384 size, and any sync() error.
  Result<Image> render_image(World& world, const CameraView& camera, std::uint32_t width,
                             std::uint32_t height, const RenderSettings& settings,
                             bool linear_float = false);
  // The same frame without the read-back (sync, record, submit, wait): what frame timings measure.
  Status render_frame(World& world, const CameraView& camera, std::uint32_t width, std::uint32_t height,
                      const RenderSettings& settings);

  const FrameStats& stats() const;
  // Every view RenderSettings::view accepts: the renderer's, then each feature's.
  std::vector<ViewInfo> views() const;

 private:
  struct Impl;
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
