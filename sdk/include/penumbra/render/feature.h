// Render features: a lighting module's part of the frame, plugged into the renderer.
//
// The renderer owns the frame: meshes, materials, lights and shadows, the depth pre-pass with the
// G-buffer (shading normal, a per-draw receiver code and whether the draw is static geometry),
// the ambient image (rgb: indirect irradiance times FrameUniforms::ambient_scale.x; a: the open
// fraction, 1 - the occlusion) at 1 / RenderSettings::ambient_step of the target's size, and the
// forward pass that shades with it. A render feature owns what its technique adds: its GPU copy of
// the components it draws, its descriptor set (set 2 of its pipelines; sets 0 and 1 are the
// renderer's, shaders/shared/layout.h), its shaders and passes, and its debug views. Each frame
// the renderer
//   1. sync():   the feature mirrors what changed in the World into its GPU resources;
//   2. per draw: draw_values() tags the draw (a receiver code in the G-buffer, an open fraction
//                over the whole entity);
//   3. record(): in the views that show ambient light, when some feature is active(), records
//                every active Source (the first writes (irradiance, 1) at every sample, the
//                others add their irradiance, blend ONE + ONE on rgb; its fragment stage calls
//                ambient_sample() of shaders/ambient_sample.glsl, which writes each sample's
//                depth and key), then every active Occluder (its open fraction multiplied into
//                rgb and a, blend DST_COLOR x src), in the order of the feature list. Without a
//                Source pass (the AO view, or only occluders active) the renderer's key pass
//                writes the depths and keys;
//   4. a feature's own debug view replaces the forward pass: the feature draws the whole target
//      (record_view) from the pre-pass depth and G-buffer.
// A feature without data this frame is not active and costs nothing but its sync().
// The features of the SDK's lighting modules are made by standard_render_features()
// (render/features.h); Renderer::create takes any list.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include <vulkan/vulkan.h>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/vk_util.h"

namespace penumbra {

struct CameraView;
struct RenderSettings;
struct FrameStats;
struct FeaturePipeline;

// A debug view: its name (RenderSettings::view) and what it shows (the editor's tooltip, the
// tool's --help).
struct ViewInfo {
  std::string_view name;
  std::string_view description;
};

// A draw's values for the features (gpu::DrawPush::feature, shaders/shared/layout.h).
struct DrawFeatureValues {
  // The G-buffer's w at the draw's pixels: a feature's receiver code (0: none), 0..2047; shaders
  // read it with gbuffer_receiver() (common.glsl), which undoes the static-geometry flag's sign.
  float receiver = 0.0f;
  float open = 1.0f;      // multiplies the open fraction at every pixel of the draw (entity-wide occlusion)
};

// How a feature writes the ambient image.
enum class AmbientRole : std::uint8_t {
  Source,    // adds indirect irradiance (W/m^2, times ambient_scale.x) to rgb
  Occluder,  // multiplies rgb and a by its open fraction
};

// The frame as the features see it in record_ambient() and record_view().
struct FeatureFrame {
  const CameraView* camera = nullptr;
  const RenderSettings* settings = nullptr;
  std::uint32_t width = 0, height = 0;                // the target's pixels
  std::uint32_t ambient_width = 0, ambient_height = 0;  // the ambient image's samples
  VkFormat target_format = VK_FORMAT_UNDEFINED;
  // In record_ambient() of a source: whether it is the first source pass this frame (then no
  // blend is needed: llvmpipe pays for reading the destination).
  bool first_source = false;
};

// What the renderer lends its features. Not thread-safe; valid for the renderer's lifetime.
class RenderContext {
 public:
  virtual ~RenderContext() = default;
  virtual VkDevice device() const = 0;
  virtual vk::Allocator& allocator() = 0;
  // Waits until the device is idle: before a resource the previous frame may use is destroyed.
  virtual void wait_idle() = 0;
  // A device-local image filled with `data` (`size` bytes), left in SHADER_READ_ONLY_OPTIMAL.
  // Cost: a staging copy and a queue wait.
  virtual Status upload_image(vk::ImageResource& dst, const VkImageCreateInfo& info, VkImageViewType type,
                              const void* data, VkDeviceSize size) = 0;
  // Makes `b` a host-visible, mapped buffer of at least `size` bytes (reallocated, after a device
  // wait, only when too small).
  virtual Status ensure_host_buffer(vk::Buffer& b, VkDeviceSize size, VkBufferUsageFlags usage) = 0;
  // A shader module from SPIR-V words; the renderer destroys it with itself. Internal error when
  // the words are empty or invalid.
  virtual Result<VkShaderModule> shader(std::span<const std::uint32_t> words) = 0;
  // A feature's descriptor set with `bindings` (its own pool) and the pipeline layout of sets 0
  // (frame), 1 (material) and that set as set 2, with the renderer's push constants
  // (gpu::DrawPush). The renderer destroys them with itself.
  struct FeatureSet {
    VkDescriptorSet set = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
  };
  virtual Result<FeatureSet> feature_set(std::span<const VkDescriptorSetLayoutBinding> bindings) = 0;
  // Samplers: trilinear and nearest, both clamped to the edge.
  virtual VkSampler linear_sampler() const = 0;
  virtual VkSampler nearest_sampler() const = 0;
  // The vertex stage of one triangle over the whole viewport (no vertex input).
  virtual VkShaderModule screen_vertex() const = 0;
  // A graphics pipeline with `p`'s state (below); the renderer destroys it with itself.
  // Unsupported naming the Vulkan result when creation fails.
  virtual Result<VkPipeline> pipeline(const FeaturePipeline& p) = 0;
};

// The state of a pass a feature draws (RenderContext::pipeline; triangle lists, dynamic viewport
// and scissor): into the ambient image (two colour attachments, the image then its key, which
// only sources write, and the samples' depth-stencil, the stencil cleared to 0 before the
// features; a source's depth state is fixed: always pass, write ambient_sample()'s depth) or
// into the target (one colour attachment of `target_format`, no depth).
struct FeaturePipeline {
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkShaderModule vertex = VK_NULL_HANDLE;    // no vertex input: gl_VertexIndex only
  VkShaderModule fragment = VK_NULL_HANDLE;  // null: none (stencil-only passes)
  const VkSpecializationInfo* specialization = nullptr;  // of both stages
  bool ambient = true;
  VkFormat target_format = VK_FORMAT_UNDEFINED;  // when !ambient
  AmbientRole role = AmbientRole::Source;        // the blend, when ambient
  // Sources: add to the sources before this one (blend ONE + ONE on rgb, a kept), or, false, write
  // the sample as it is (the first source, FeatureFrame::first_source; its shader writes a = 1).
  bool accumulate = true;
  bool colour_writes = true;
  VkCullModeFlags cull = VK_CULL_MODE_NONE;
  bool depth_clamp = false;
  VkPipelineDepthStencilStateCreateInfo depth_stencil{};  // occluders; zero: no tests
};

// The passes of a Source feature drawn over the whole screen (the screen triangle): its ambient
// pass and its debug views, one fragment shader each, with the feature's descriptor set as set 2.
// Specialisation constants of both shaders: constant_id 0 the feature's `variant` (e.g. the probe
// grid's grid count), constant_id 1 the view in the view shader (in the ambient pass: 0 for the
// frame's first source, 1 after others); a shader may leave either out. Pipelines are made on
// first use, one per (pass, view or first-source flag, target format, variant).
class ScreenPasses {
 public:
  // The descriptor set with `bindings` (RenderContext::feature_set) and the two shaders (SPIR-V).
  // Errors as RenderContext's.
  Status init(RenderContext& gpu, std::span<const VkDescriptorSetLayoutBinding> bindings,
              std::span<const std::uint32_t> ambient_shader, std::span<const std::uint32_t> view_shader);
  // The feature's set, for its descriptor writes. Valid after init().
  VkDescriptorSet set() const { return set_; }
  // Record the ambient pass (RenderFeature::record_ambient) / view `view` over the target
  // (RenderFeature::record_view). Cost: one draw of three vertices.
  Status record_ambient(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::uint32_t variant = 0);
  Status record_view(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::size_t view,
                     std::uint32_t variant = 0);

 private:
  Status draw(VkCommandBuffer cmd, RenderContext& gpu, bool ambient, std::uint32_t view, VkFormat format,
              std::uint32_t variant);

  VkDescriptorSet set_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkShaderModule ambient_ = VK_NULL_HANDLE, view_ = VK_NULL_HANDLE;
  std::map<std::tuple<bool, std::uint32_t, VkFormat, std::uint32_t>, VkPipeline> pipelines_;
};

class RenderFeature {
 public:
  virtual ~RenderFeature() = default;
  // The lighting module's name (LightingModule::name), for messages and counters.
  virtual std::string_view name() const = 0;
  virtual AmbientRole role() const = 0;
  // Its debug views; their names must differ from every other view's (Renderer::create checks).
  virtual std::span<const ViewInfo> views() const { return {}; }

  // Once, from Renderer::create: layouts, pipelines, placeholders. release() frees everything it
  // made (the device is idle).
  virtual Status init(RenderContext& gpu) = 0;
  virtual void release(RenderContext& gpu) = 0;
  // Mirrors the components it draws into GPU resources, uploading only what changed (Renderer::
  // sync, before the draws are gathered). Errors name the entity and the fix.
  virtual Status sync(World& world, RenderContext& gpu) = 0;
  // The values of the draw of entity `e` (after sync()); the defaults leave it untouched.
  virtual void draw_values(const World& world, Entity e, DrawFeatureValues& values) const {
    (void)world, (void)e, (void)values;
  }
  // Whether it has anything to draw into the ambient image (after sync()).
  virtual bool active() const = 0;
  // Sources: a bound on the irradiance it adds anywhere (W/m^2, per channel), which scales the
  // half-float ambient image; 0 unknown.
  virtual float irradiance_bound() const { return 0.0f; }
  // Records its passes into the ambient image, inside the renderer's rendering of it (viewport
  // set, set 0 bound). Called only when active().
  virtual Status record_ambient(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame) = 0;
  // Records views()[view] over the whole target, inside the renderer's rendering of it (cleared
  // to black; viewport set, set 0 bound, the pre-pass depth and G-buffer readable).
  virtual Status record_view(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::size_t view) {
    (void)cmd, (void)gpu, (void)frame, (void)view;
    return make_error(ErrorCode::Internal, std::string(name()) + ": has no views to record");
  }
  // Appends its counters for the last sync()/record() ("<name>.<counter>").
  virtual void add_counters(FrameStats& stats) const { (void)stats; }
};

using RenderFeatures = std::vector<std::unique_ptr<RenderFeature>>;

}  // namespace penumbra
