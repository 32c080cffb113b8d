// The forward renderer: World -> GPU resources (sync); per frame (record) the shadow passes, the
// depth pre-pass, with an active render feature the ambient image, and the forward pass (or a
// feature's debug view).
#include "penumbra/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>
#include <unordered_map>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/ext/vector_uint4_sized.hpp>
#include <glm/gtc/packing.hpp>

#include "feature_pipeline.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"
#include "shared/layout.h"
#include "spirv.h"
#include "penumbra/render/vk_util.h"

namespace penumbra {

using vk::Allocator;
using vk::Buffer;
using vk::image_barrier;
using vk::ImageResource;
using vk::vk_struct;

namespace {

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kGBufferFormat = VK_FORMAT_R16G16B16A16_SFLOAT;  // normal, receiver code (layout.h)
constexpr VkFormat kAmbientFormat = VK_FORMAT_R16G16B16A16_SFLOAT;  // blendable on every device
constexpr std::uint32_t kMaxMaterialSets = 1024;
constexpr std::uint32_t kMaxImageSize = 16384;

// The renderer's own views, in the order of forward.frag's kView (layout.h PENUMBRA_VIEW_*).
constexpr ViewInfo kOwnViews[] = {
    {"lit", "direct + indirect light, AO applied, tone mapped"},
    {"direct", "direct light with shadows"},
    {"indirect", "the ambient sources' irradiance x albedo x AO"},
    {"ao", "the product of every AO term, as grey"},
    {"albedo", "base colour x texture"},
    {"position", "world position (linear data, not tone mapped)"},
    {"normal", "world normal, facing the camera (linear data)"},
};
static_assert(std::size(kOwnViews) == PENUMBRA_VIEW_COUNT);

// The renderer's views, then each feature's.
std::vector<ViewInfo> all_views(const RenderFeatures& features) {
  std::vector<ViewInfo> all(std::begin(kOwnViews), std::end(kOwnViews));
  for (const auto& f : features) all.insert(all.end(), f->views().begin(), f->views().end());
  return all;
}

// One interleaved vertex (binding 0); the AO attribute is binding 1.
struct GpuVertex {
  glm::vec3 position;
  glm::vec3 normal;
  glm::vec2 uv;
  glm::u16vec4 joints;
  glm::vec4 weights;
};

struct GpuMesh {
  std::shared_ptr<const MeshData> source;  // keeps the key alive
  Buffer vertices, indices;
  std::uint32_t index_count = 0, vertex_count = 0;
};
struct GpuTexture {
  std::shared_ptr<const Texture> source;
  ImageResource image;
  VkDescriptorSet set = VK_NULL_HANDLE;
};
// An entity's uploaded VertexAO and the change tick it was uploaded at.
struct VertexAoBuffer {
  Buffer buffer;
  Entity entity;
  std::uint64_t tick = 0;
};
struct Draw {
  const GpuMesh* mesh = nullptr;
  VkBuffer ao = VK_NULL_HANDLE;  // per-vertex AO, or the shared buffer of ones
  VkDescriptorSet material = VK_NULL_HANDLE;
  gpu::DrawPush push{};
  bool casts_shadow = true;
  std::uint32_t joint_count = 0;  // skinned: its joints[push.draw.x ..) in Impl::joints
  Aabb world_bounds;              // holds every posed vertex (skinned: over every joint's transform)
};

// Extends `out` by the eight corners of `box` through `m`.
void extend_by_box(Aabb& out, const Aabb& box, const glm::mat4& m) {
  for (int i = 0; i < 8; ++i) {
    const glm::vec3 c((i & 1) ? box.max.x : box.min.x, (i & 2) ? box.max.y : box.min.y, (i & 4) ? box.max.z : box.min.z);
    out.extend(glm::vec3(m * glm::vec4(c, 1.0f)));
  }
}

// Whether any of the world box's points may lie in the clip volume of `clip_from_world` (Vulkan:
// -w <= x, y <= w, 0 <= z <= w): false when all eight corners are outside one plane.
bool may_intersect(const glm::mat4& clip_from_world, const Aabb& box) {
  int outside[6] = {0, 0, 0, 0, 0, 0};
  for (int i = 0; i < 8; ++i) {
    const glm::vec3 c((i & 1) ? box.max.x : box.min.x, (i & 2) ? box.max.y : box.min.y,
                      (i & 4) ? box.max.z : box.min.z);
    const glm::vec4 p = clip_from_world * glm::vec4(c, 1.0f);
    outside[0] += p.x < -p.w;
    outside[1] += p.x > p.w;
    outside[2] += p.y < -p.w;
    outside[3] += p.y > p.w;
    outside[4] += p.z < 0.0f;
    outside[5] += p.z > p.w;
  }
  return std::none_of(std::begin(outside), std::end(outside), [](int n) { return n == 8; });
}

void set_viewport(VkCommandBuffer cmd, std::uint32_t w, std::uint32_t h) {
  const VkViewport vp{0.0f, 0.0f, float(w), float(h), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

// Copies `values` to the start of the mapped buffer `b` (nothing for none: an empty vector's data()
// may be null, which memcpy must not get).
template <typename T>
void copy_into(const Buffer& b, const std::vector<T>& values) {
  if (!values.empty()) std::memcpy(b.mapped, values.data(), values.size() * sizeof(T));
}

// Appends the bytes of `value` to `key`.
template <typename T>
void append_bytes(std::vector<std::byte>& key, const T& value) {
  const auto* bytes = reinterpret_cast<const std::byte*>(&value);
  key.insert(key.end(), bytes, bytes + sizeof(T));
}

VkShaderModule make_module(VkDevice device, std::span<const std::uint32_t> words) {
  auto info = vk_struct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  VkShaderModule module = VK_NULL_HANDLE;
  if (words.empty() || vkCreateShaderModule(device, &info, nullptr, &module) != VK_SUCCESS) return VK_NULL_HANDLE;
  return module;
}

bool is_float_format(VkFormat f) {
  return f == VK_FORMAT_R32G32B32A32_SFLOAT || f == VK_FORMAT_R16G16B16A16_SFLOAT;
}
bool is_unorm_format(VkFormat f) {
  return f == VK_FORMAT_R8G8B8A8_UNORM || f == VK_FORMAT_B8G8R8A8_UNORM || f == VK_FORMAT_A2B10G10R10_UNORM_PACK32;
}

}  // namespace

struct Renderer::Impl final : RenderContext {
  Device* gpu_device = nullptr;
  VkDevice vk = VK_NULL_HANDLE;
  std::unique_ptr<Allocator> alloc;
  FrameStats stats;

  VkDescriptorSetLayout frame_layout = VK_NULL_HANDLE, material_layout = VK_NULL_HANDLE;
  VkPipelineLayout renderer_layout = VK_NULL_HANDLE;
  VkShaderModule forward_vert = VK_NULL_HANDLE, forward_frag = VK_NULL_HANDLE, shadow_vert = VK_NULL_HANDLE,
                 gbuffer_frag = VK_NULL_HANDLE, screen_vert = VK_NULL_HANDLE, ambient_key_frag = VK_NULL_HANDLE,
                 sky_frag = VK_NULL_HANDLE;
  Environment sky;  // the World's environment at the last sync (the lit view's background)
  // The environment map's texels x its scale, uploaded when the map or the scale changes.
  ImageResource sky_image;
  std::uint64_t sky_digest = 0;
  float sky_scale = 0.0f;
  std::shared_ptr<const MeshData> emitter_quad;  // a unit quad: every rect light's emitter
  // The graphics pipelines by pass, colour format, view, flag, shadow taps, light count and
  // whether a light is a rect (see pipeline()).
  enum class Pass { Shadow, DepthPrepass, GBufferPrepass, AmbientKey, Forward, Sky };
  std::map<std::tuple<Pass, VkFormat, std::uint32_t, bool, std::uint32_t, std::uint32_t, bool>, VkPipeline> pipelines;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet frame_set = VK_NULL_HANDLE;
  VkSampler texture_sampler = VK_NULL_HANDLE, linear_clamp_sampler = VK_NULL_HANDLE, shadow_sampler = VK_NULL_HANDLE,
            sky_sampler = VK_NULL_HANDLE,
            point_sampler = VK_NULL_HANDLE;
  // The render features, and what the renderer made for them through RenderContext.
  RenderFeatures features;
  std::vector<VkPipelineLayout> feature_layouts;
  std::vector<VkDescriptorSetLayout> feature_set_layouts;
  std::vector<VkDescriptorPool> feature_pools;
  std::vector<VkShaderModule> feature_shaders;
  std::vector<VkPipeline> feature_pipelines;

  // Assets and per-frame data.
  std::unordered_map<const MeshData*, GpuMesh> meshes;
  std::unordered_map<const Texture*, GpuTexture> textures;
  GpuTexture white;
  std::unordered_map<std::uint32_t, VertexAoBuffer> vertex_ao;  // by entity index
  Buffer ones;                                          // AO = 1 for entities without the attribute
  std::vector<Draw> draws;
  std::vector<gpu::GpuLight> lights;
  std::vector<glm::mat4> shadow_matrices;
  std::vector<glm::mat4> joints;
  Aabb bounds;
  Buffer frame_buffer, light_buffer, shadow_matrix_buffer, joint_buffer;

  // Targets. The G-buffer and the ambient image exist only while the ambient image or a
  // feature's view is drawn.
  // ambient_key: per sample its surface (layout.h); ambient_depth: per sample depth, stencil.
  ImageResource depth, gbuffer, ambient, ambient_key, ambient_depth;
  VkFormat ambient_depth_format = VK_FORMAT_UNDEFINED;    // D32_SFLOAT_S8_UINT or D24_UNORM_S8_UINT
  std::uint32_t depth_width = 0, depth_height = 0, ambient_step = 0;  // 0: no G-buffer nor ambient image
  ImageResource shadow_map;
  std::vector<VkImageView> shadow_layer_views;
  std::uint32_t shadow_size = 0, shadow_layers = 0;
  bool shadow_initialised = false;
  // Per shadow layer, what it holds: its matrix, the map size and the casters drawn into it
  // (mesh, transform, joints), compared byte for byte with the frame's; cleared with the map.
  std::vector<std::vector<std::byte>> shadow_layer_keys;
  ImageResource offscreen;
  VkFormat offscreen_format = VK_FORMAT_UNDEFINED;
  std::uint32_t offscreen_width = 0, offscreen_height = 0;
  Buffer readback;
  bool descriptors_dirty = true;

  ~Impl() override {
    if (!vk) return;
    vkDeviceWaitIdle(vk);
    for (auto& f : features) f->release(*this);
    for (VkPipeline p : feature_pipelines) vkDestroyPipeline(vk, p, nullptr);
    for (VkPipelineLayout l : feature_layouts) vkDestroyPipelineLayout(vk, l, nullptr);
    for (VkDescriptorPool p : feature_pools) vkDestroyDescriptorPool(vk, p, nullptr);
    for (VkDescriptorSetLayout l : feature_set_layouts) vkDestroyDescriptorSetLayout(vk, l, nullptr);
    for (VkShaderModule m : feature_shaders) vkDestroyShaderModule(vk, m, nullptr);
    for (auto& [k, m] : meshes) { alloc->destroy(m.vertices); alloc->destroy(m.indices); }
    for (auto& [k, t] : textures) alloc->destroy(t.image);
    alloc->destroy(white.image);
    for (auto& [k, b] : vertex_ao) alloc->destroy(b.buffer);
    for (Buffer* b : {&ones, &frame_buffer, &light_buffer, &shadow_matrix_buffer, &joint_buffer, &readback}) alloc->destroy(*b);
    for (ImageResource* i : {&depth, &gbuffer, &ambient, &ambient_key, &ambient_depth, &shadow_map, &offscreen, &sky_image})
      alloc->destroy(*i);
    for (VkImageView v : shadow_layer_views) vkDestroyImageView(vk, v, nullptr);
    for (auto& [key, p] : pipelines) vkDestroyPipeline(vk, p, nullptr);
    for (VkShaderModule m : {forward_vert, forward_frag, shadow_vert, gbuffer_frag, screen_vert, ambient_key_frag, sky_frag})
      if (m) vkDestroyShaderModule(vk, m, nullptr);
    for (VkSampler s : {texture_sampler, linear_clamp_sampler, shadow_sampler, point_sampler, sky_sampler})
      if (s) vkDestroySampler(vk, s, nullptr);
    if (pool) vkDestroyDescriptorPool(vk, pool, nullptr);
    if (renderer_layout) vkDestroyPipelineLayout(vk, renderer_layout, nullptr);
    if (frame_layout) vkDestroyDescriptorSetLayout(vk, frame_layout, nullptr);
    if (material_layout) vkDestroyDescriptorSetLayout(vk, material_layout, nullptr);
  }

  Status init();
  // Uploads the environment map x its scale when either changed since the last upload.
  Status upload_sky();

  // RenderContext.
  VkDevice device() const override { return vk; }
  vk::Allocator& allocator() override { return *alloc; }
  void wait_idle() override { vkDeviceWaitIdle(vk); }
  Status upload_image(ImageResource& dst, const VkImageCreateInfo& info, VkImageViewType type, const void* data,
                      VkDeviceSize size) override;
  Status ensure_host_buffer(Buffer& b, VkDeviceSize size, VkBufferUsageFlags usage) override;
  Result<VkShaderModule> shader(std::span<const std::uint32_t> words) override;
  Result<FeatureSet> feature_set(std::span<const VkDescriptorSetLayoutBinding> bindings) override;
  VkSampler linear_sampler() const override { return linear_clamp_sampler; }
  VkSampler nearest_sampler() const override { return point_sampler; }
  VkShaderModule screen_vertex() const override { return screen_vert; }
  Result<VkPipeline> pipeline(const FeaturePipeline& p) override;

  Result<VkPipeline> pipeline(Pass pass, VkFormat format, std::uint32_t view = 0, bool flag = false,
                              std::uint32_t shadow_taps = 0, std::uint32_t light_count = 0, bool rect_lights = false);
  Status upload_buffer(Buffer& dst, const void* data, VkDeviceSize size, VkBufferUsageFlags usage);
  Result<GpuTexture*> texture(const std::shared_ptr<const Texture>& tex);
  Result<const GpuMesh*> mesh(const std::shared_ptr<const MeshData>& data);
  void plan_shadows(const std::vector<WorldLight>& world_lights);
  Status ensure_targets(std::uint32_t width, std::uint32_t height, std::uint32_t shadow_map_size,
                        std::uint32_t ambient_step);
  void write_descriptors();
  Status record(VkCommandBuffer cmd, const RenderTarget& target, const CameraView& camera,
                const RenderSettings& settings);
  // The parts of record(): one draw of a pass, every draw; the shadow layers whose content changed; the
  // ambient image's passes after the G-buffer pre-pass (the key pass, then the features').
  void draw(VkCommandBuffer cmd, Pass pass, const Draw& d, std::uint32_t layer) const;
  void draw_all(VkCommandBuffer cmd, Pass pass) const;
  void record_shadow_layers(VkCommandBuffer cmd, bool shadows, VkPipeline shadow);
  Status record_ambient_passes(VkCommandBuffer cmd, VkPipeline key, const FeatureFrame& frame, bool sources);
  Status offscreen_frame(const CameraView& camera, std::uint32_t width, std::uint32_t height,
                         const RenderSettings& settings, bool linear_float, bool read, Image* out);
};

Status Renderer::Impl::init() {
  vk = gpu_device->device();
  alloc = std::make_unique<Allocator>(gpu_device->physical_device(), vk);

  // Descriptor set layouts: set 0 per frame, set 1 per material.
  const VkShaderStageFlags both = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  const VkDescriptorSetLayoutBinding frame_bindings[] = {
      {PENUMBRA_BINDING_FRAME, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, both, nullptr},
      {PENUMBRA_BINDING_LIGHTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_SHADOW_MATRICES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, both, nullptr},
      {PENUMBRA_BINDING_JOINTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr},
      {PENUMBRA_BINDING_SHADOW_MAP, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_SCENE_DEPTH, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_GBUFFER, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_AMBIENT, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_AMBIENT_KEY, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_SKY, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {PENUMBRA_BINDING_SHADOW_DEPTH, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
  };
  auto layout_info = vk_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  layout_info.bindingCount = std::size(frame_bindings);
  layout_info.pBindings = frame_bindings;
  const VkDescriptorSetLayoutBinding material_binding = {PENUMBRA_BINDING_BASE_COLOR,
                                                         VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                                         VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  auto material_info = vk_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  material_info.bindingCount = 1;
  material_info.pBindings = &material_binding;
  const VkPushConstantRange push{both, 0, sizeof(gpu::DrawPush)};
  if (vkCreateDescriptorSetLayout(vk, &layout_info, nullptr, &frame_layout) != VK_SUCCESS ||
      vkCreateDescriptorSetLayout(vk, &material_info, nullptr, &material_layout) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Renderer: cannot create descriptor set layouts");
  }
  const VkDescriptorSetLayout set_layouts[] = {frame_layout, material_layout};
  auto pl_info = vk_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  pl_info.setLayoutCount = 2;
  pl_info.pSetLayouts = set_layouts;
  pl_info.pushConstantRangeCount = 1;
  pl_info.pPushConstantRanges = &push;
  if (vkCreatePipelineLayout(vk, &pl_info, nullptr, &renderer_layout) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Renderer: cannot create the pipeline layout");
  }

  // Descriptor pool: the frame set and one set per texture.
  const VkDescriptorPoolSize sizes[] = {
      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3},
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 7 + kMaxMaterialSets},
  };
  auto pool_info = vk_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pool_info.maxSets = 1 + kMaxMaterialSets;
  pool_info.poolSizeCount = std::size(sizes);
  pool_info.pPoolSizes = sizes;
  if (vkCreateDescriptorPool(vk, &pool_info, nullptr, &pool) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Renderer: cannot create the descriptor pool");
  }
  auto set_info = vk_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  set_info.descriptorPool = pool;
  set_info.descriptorSetCount = 1;
  set_info.pSetLayouts = &frame_layout;
  if (vkAllocateDescriptorSets(vk, &set_info, &frame_set) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Renderer: cannot allocate the frame descriptor set");
  }

  // Samplers: textures (linear, repeat), the features' (trilinear, clamp), shadow map
  // (comparison), the screen images the passes read with texelFetch (nearest, clamp), the sky
  // (linear, around the longitudes, clamped at the poles as sample_environment_map).
  auto sampler = vk_struct<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
  sampler.magFilter = VK_FILTER_LINEAR;
  sampler.minFilter = VK_FILTER_LINEAR;
  sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  sampler.maxLod = 0.0f;
  VkResult r = vkCreateSampler(vk, &sampler, nullptr, &texture_sampler);
  sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  if (r == VK_SUCCESS) r = vkCreateSampler(vk, &sampler, nullptr, &linear_clamp_sampler);
  sampler.addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  if (r == VK_SUCCESS) r = vkCreateSampler(vk, &sampler, nullptr, &sky_sampler);
  sampler.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sampler.magFilter = sampler.minFilter = VK_FILTER_NEAREST;
  if (r == VK_SUCCESS) r = vkCreateSampler(vk, &sampler, nullptr, &point_sampler);
  sampler.magFilter = sampler.minFilter = VK_FILTER_LINEAR;
  sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER;
  sampler.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
  sampler.compareEnable = VK_TRUE;
  sampler.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  if (r == VK_SUCCESS) r = vkCreateSampler(vk, &sampler, nullptr, &shadow_sampler);
  if (r != VK_SUCCESS) return make_error(ErrorCode::Internal, "Renderer: cannot create samplers");

  // The ambient image's depth-stencil format (the spec requires one of the two).
  for (VkFormat f : {VK_FORMAT_D32_SFLOAT_S8_UINT, VK_FORMAT_D24_UNORM_S8_UINT}) {
    VkFormatProperties props;
    vkGetPhysicalDeviceFormatProperties(gpu_device->physical_device(), f, &props);
    if (props.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) {
      ambient_depth_format = f;
      break;
    }
  }
  if (ambient_depth_format == VK_FORMAT_UNDEFINED)
    return make_error(ErrorCode::Unsupported, "Renderer: the device has no depth-stencil format with stencil");

  forward_vert = make_module(vk, shaders::renderer("forward.vert"));
  forward_frag = make_module(vk, shaders::renderer("forward.frag"));
  shadow_vert = make_module(vk, shaders::renderer("shadow.vert"));
  gbuffer_frag = make_module(vk, shaders::renderer("gbuffer.frag"));
  screen_vert = make_module(vk, shaders::renderer("screen.vert"));
  ambient_key_frag = make_module(vk, shaders::renderer("ambient_key.frag"));
  sky_frag = make_module(vk, shaders::renderer("sky.frag"));
  if (!forward_vert || !forward_frag || !shadow_vert || !gbuffer_frag || !screen_vert || !ambient_key_frag ||
      !sky_frag) {
    return make_error(ErrorCode::Internal, "Renderer: the embedded SPIR-V is missing or invalid; rebuild the SDK");
  }

  // Defaults: a white texture, the per-frame buffers.
  const std::uint8_t white_texel[4] = {255, 255, 255, 255};
  auto image = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  image.imageType = VK_IMAGE_TYPE_2D;
  image.format = VK_FORMAT_R8G8B8A8_SRGB;
  image.extent = {1, 1, 1};
  image.mipLevels = 1;
  image.arrayLayers = 1;
  image.samples = VK_SAMPLE_COUNT_1_BIT;
  image.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  PENUMBRA_TRY(upload_image(white.image, image, VK_IMAGE_VIEW_TYPE_2D, white_texel, 4));
  auto alloc_set = set_info;
  alloc_set.pSetLayouts = &material_layout;
  if (vkAllocateDescriptorSets(vk, &alloc_set, &white.set) != VK_SUCCESS) {
    return make_error(ErrorCode::Internal, "Renderer: cannot allocate a material descriptor set");
  }
  VkDescriptorImageInfo white_info{texture_sampler, white.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  auto write = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  write.dstSet = white.set;
  write.dstBinding = PENUMBRA_BINDING_BASE_COLOR;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  write.pImageInfo = &white_info;
  vkUpdateDescriptorSets(vk, 1, &write, 0, nullptr);
  PENUMBRA_TRY(ensure_host_buffer(frame_buffer, sizeof(gpu::FrameUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));

  // The features, whose names and views must be unique.
  std::vector<std::string_view> names;
  for (const ViewInfo& v : kOwnViews) names.push_back(v.name);
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (!features[i]) return make_error(ErrorCode::InvalidArgument, "Renderer: render feature " + std::to_string(i) + " is null");
    for (std::size_t j = 0; j < i; ++j)
      if (features[j]->name() == features[i]->name())
        return make_error(ErrorCode::InvalidArgument, "Renderer: two render features are named '" +
                                                          std::string(features[i]->name()) + "'; pass each once");
    for (const ViewInfo& v : features[i]->views()) {
      if (std::find(names.begin(), names.end(), v.name) != names.end())
        return make_error(ErrorCode::InvalidArgument, "Renderer: render feature '" + std::string(features[i]->name()) +
                                                          "' names its view '" + std::string(v.name) +
                                                          "', which another view has; rename it");
      names.push_back(v.name);
    }
    PENUMBRA_TRY(features[i]->init(*this));
  }
  return {};
}

Result<VkShaderModule> Renderer::Impl::shader(std::span<const std::uint32_t> words) {
  const VkShaderModule m = make_module(vk, words);
  if (!m) return make_error(ErrorCode::Internal, "Renderer: a render feature's SPIR-V is missing or invalid; rebuild the SDK");
  feature_shaders.push_back(m);
  return m;
}

Result<RenderContext::FeatureSet> Renderer::Impl::feature_set(std::span<const VkDescriptorSetLayoutBinding> bindings) {
  auto layout_info = vk_struct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  layout_info.bindingCount = static_cast<std::uint32_t>(bindings.size());
  layout_info.pBindings = bindings.data();
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  if (vkCreateDescriptorSetLayout(vk, &layout_info, nullptr, &set_layout) != VK_SUCCESS)
    return make_error(ErrorCode::Internal, "Renderer: cannot create a render feature's descriptor set layout");
  feature_set_layouts.push_back(set_layout);
  std::vector<VkDescriptorPoolSize> sizes;
  for (const VkDescriptorSetLayoutBinding& b : bindings) sizes.push_back({b.descriptorType, b.descriptorCount});
  auto pool_info = vk_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
  pool_info.pPoolSizes = sizes.data();
  VkDescriptorPool feature_pool = VK_NULL_HANDLE;
  if (vkCreateDescriptorPool(vk, &pool_info, nullptr, &feature_pool) != VK_SUCCESS)
    return make_error(ErrorCode::Internal, "Renderer: cannot create a render feature's descriptor pool");
  feature_pools.push_back(feature_pool);
  FeatureSet out;
  auto set_info = vk_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  set_info.descriptorPool = feature_pool;
  set_info.descriptorSetCount = 1;
  set_info.pSetLayouts = &set_layout;
  if (vkAllocateDescriptorSets(vk, &set_info, &out.set) != VK_SUCCESS)
    return make_error(ErrorCode::Internal, "Renderer: cannot allocate a render feature's descriptor set");
  const VkDescriptorSetLayout sets[] = {frame_layout, material_layout, set_layout};
  const VkPushConstantRange push{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(gpu::DrawPush)};
  auto info = vk_struct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  info.setLayoutCount = 3;
  info.pSetLayouts = sets;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &push;
  if (vkCreatePipelineLayout(vk, &info, nullptr, &out.layout) != VK_SUCCESS)
    return make_error(ErrorCode::Internal, "Renderer: cannot create a render feature's pipeline layout");
  feature_layouts.push_back(out.layout);
  return out;
}

Result<VkPipeline> Renderer::Impl::pipeline(const FeaturePipeline& p) {
  auto made = make_feature_pipeline(vk, p, kAmbientFormat, ambient_depth_format);
  if (made) feature_pipelines.push_back(*made);
  return made;
}

Status Renderer::Impl::ensure_host_buffer(Buffer& b, VkDeviceSize size, VkBufferUsageFlags usage) {
  size = std::max<VkDeviceSize>(size, 256);
  if (b.buffer && b.size >= size) return {};
  vkDeviceWaitIdle(vk);  // the old buffer may be in use by the previous frame
  alloc->destroy(b);
  auto created = alloc->create_buffer(size + size / 2, usage, true);
  if (!created) return created.error();
  b = *created;
  descriptors_dirty = true;
  return {};
}

Status Renderer::Impl::upload_buffer(Buffer& dst, const void* data, VkDeviceSize size, VkBufferUsageFlags usage) {
  auto staging = alloc->create_buffer(size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  std::memcpy(staging->mapped, data, size);
  auto created = alloc->create_buffer(size, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, false);
  if (!created) {
    alloc->destroy(*staging);
    return created.error();
  }
  dst = *created;
  const VkBuffer src = staging->buffer, to = dst.buffer;
  Status s = gpu_device->submit_and_wait([&](VkCommandBuffer cmd) {
    const VkBufferCopy region{0, 0, size};
    vkCmdCopyBuffer(cmd, src, to, 1, &region);
  });
  alloc->destroy(*staging);
  return s;
}

Status Renderer::Impl::upload_image(ImageResource& dst, const VkImageCreateInfo& info, VkImageViewType type,
                                    const void* data, VkDeviceSize size) {
  auto created = alloc->create_image(info, type, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!created) return created.error();
  dst = *created;
  auto staging = alloc->create_buffer(size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  std::memcpy(staging->mapped, data, size);
  const VkBuffer src = staging->buffer;
  const VkImage image = dst.image;
  Status s = gpu_device->submit_and_wait([&](VkCommandBuffer cmd) {
    image_barrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
                  VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = info.extent;
    vkCmdCopyBufferToImage(cmd, src, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    image_barrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                  VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
  });
  alloc->destroy(*staging);
  return s;
}

Status Renderer::Impl::upload_sky() {
  const std::uint64_t digest = sky.map_data ? sky.map_data->digest : 0;
  const float scale = sky.map_data ? sky.map_scale : 0.0f;
  if (digest == sky_digest && scale == sky_scale) return {};
  if (sky_image.image) {
    vkDeviceWaitIdle(vk);  // the previous frame may still sample it
    alloc->destroy(sky_image);
  }
  descriptors_dirty = true;
  sky_digest = 0;  // set once the new map is up, so that a failed upload is tried again
  sky_scale = 0.0f;
  if (!sky.map_data) return {};
  // Half floats: linear filtering of them is required of every device (of 32-bit floats it is not);
  // radiance above their range (65504) saturates in the background only, never in the bakes.
  const EnvironmentMap& map = *sky.map_data;
  std::vector<glm::uint64> texels(map.texels.size());
  for (std::size_t i = 0; i < texels.size(); ++i)
    texels[i] = glm::packHalf4x16(glm::vec4(glm::min(map.texels[i] * scale, glm::vec3(65504.0f)), 1.0f));
  auto image = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  image.imageType = VK_IMAGE_TYPE_2D;
  image.format = VK_FORMAT_R16G16B16A16_SFLOAT;
  image.extent = {map.width, map.height, 1};
  image.mipLevels = 1;
  image.arrayLayers = 1;
  image.samples = VK_SAMPLE_COUNT_1_BIT;
  image.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  PENUMBRA_TRY(upload_image(sky_image, image, VK_IMAGE_VIEW_TYPE_2D, texels.data(), texels.size() * sizeof(glm::uint64)));
  sky_digest = digest;
  sky_scale = scale;
  return {};
}

Result<const GpuMesh*> Renderer::Impl::mesh(const std::shared_ptr<const MeshData>& data) {
  if (auto it = meshes.find(data.get()); it != meshes.end()) return &it->second;
  const MeshData& m = *data;
  std::vector<GpuVertex> vertices(m.positions.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    GpuVertex& v = vertices[i];
    v.position = m.positions[i];
    v.normal = i < m.normals.size() ? m.normals[i] : glm::vec3(0.0f, 1.0f, 0.0f);
    v.uv = i < m.uvs.size() ? m.uvs[i] : glm::vec2(0.0f);
    v.joints = i < m.joints.size() ? m.joints[i] : glm::u16vec4(0);
    v.weights = i < m.weights.size() ? m.weights[i] : glm::vec4(0.0f);
  }
  GpuMesh g;
  g.source = data;
  g.vertex_count = static_cast<std::uint32_t>(vertices.size());
  g.index_count = static_cast<std::uint32_t>(m.indices.size());
  if (vertices.empty() || m.indices.empty()) return make_error(ErrorCode::InvalidInput, "mesh '" + m.name + "' is empty");
  PENUMBRA_TRY(upload_buffer(g.vertices, vertices.data(), vertices.size() * sizeof(GpuVertex),
                             VK_BUFFER_USAGE_VERTEX_BUFFER_BIT));
  PENUMBRA_TRY(upload_buffer(g.indices, m.indices.data(), m.indices.size() * sizeof(std::uint32_t),
                             VK_BUFFER_USAGE_INDEX_BUFFER_BIT));
  return &(meshes[data.get()] = std::move(g));
}

Result<GpuTexture*> Renderer::Impl::texture(const std::shared_ptr<const Texture>& tex) {
  if (!tex || tex->width <= 0 || tex->height <= 0 ||
      tex->rgba8.size() != std::size_t(tex->width) * std::size_t(tex->height) * 4) {
    return &white;
  }
  if (auto it = textures.find(tex.get()); it != textures.end()) return &it->second;
  if (textures.size() + 1 >= kMaxMaterialSets) {
    return make_error(ErrorCode::OutOfBudget, "Renderer: more than " + std::to_string(kMaxMaterialSets) +
                                                  " textures; merge textures into atlases");
  }
  GpuTexture g;
  g.source = tex;
  auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = VK_FORMAT_R8G8B8A8_SRGB;
  info.extent = {static_cast<std::uint32_t>(tex->width), static_cast<std::uint32_t>(tex->height), 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  PENUMBRA_TRY(upload_image(g.image, info, VK_IMAGE_VIEW_TYPE_2D, tex->rgba8.data(), tex->rgba8.size()));
  auto set_info = vk_struct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  set_info.descriptorPool = pool;
  set_info.descriptorSetCount = 1;
  set_info.pSetLayouts = &material_layout;
  if (vkAllocateDescriptorSets(vk, &set_info, &g.set) != VK_SUCCESS) {
    alloc->destroy(g.image);
    return make_error(ErrorCode::Internal, "Renderer: cannot allocate a material descriptor set");
  }
  VkDescriptorImageInfo image_info{texture_sampler, g.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  auto write = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  write.dstSet = g.set;
  write.dstBinding = PENUMBRA_BINDING_BASE_COLOR;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  write.pImageInfo = &image_info;
  vkUpdateDescriptorSets(vk, 1, &write, 0, nullptr);
  return &(textures[tex.get()] = std::move(g));
}

// Shadow views: directional 1 orthographic layer fitted to the scene bounds, spot 1 perspective
// layer over the outer cone, point and rect 6 cube faces (+X, -X, +Y, -Y, +Z, -Z as cube_face()).
void Renderer::Impl::plan_shadows(const std::vector<WorldLight>& world_lights) {
  lights.clear();
  shadow_matrices.clear();
  const glm::vec3 centre = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  const float radius = bounds.empty() ? 1.0f : std::max(0.5f * glm::length(bounds.extent()), 0.01f);
  auto far_from = [&](glm::vec3 p) { return glm::length(p - centre) + radius; };
  for (const WorldLight& wl : world_lights) {
    const Light& l = wl.light;
    gpu::GpuLight g{};
    const glm::vec3 dir = glm::normalize(wl.direction);
    int type = PENUMBRA_LIGHT_POINT;
    switch (l.type) {
      case Light::Type::Directional: type = PENUMBRA_LIGHT_DIRECTIONAL; break;
      case Light::Type::Point: type = PENUMBRA_LIGHT_POINT; break;
      case Light::Type::Spot: type = PENUMBRA_LIGHT_SPOT; break;
      case Light::Type::Rect: type = PENUMBRA_LIGHT_RECT; break;
    }
    g.position_type = glm::vec4(wl.position, float(type));
    g.direction_range = glm::vec4(dir, l.range);
    g.color = glm::vec4(l.color * l.intensity, 0.0f);
    g.cone_shadow = glm::vec4(std::cos(l.outer_cone_angle), std::cos(l.inner_cone_angle),
                              float(shadow_matrices.size()), 1.0f);
    g.half_x = glm::vec4(wl.half_x, 0.0f);
    g.half_y = glm::vec4(wl.half_y, 0.0f);
    const glm::vec3 up = std::abs(dir.y) > 0.99f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    if (type == PENUMBRA_LIGHT_DIRECTIONAL) {
      const glm::vec3 eye = centre - dir * (radius * 1.05f);
      shadow_matrices.push_back(glm::orthoRH_ZO(-radius, radius, -radius, radius, 0.0f, radius * 2.1f) *
                                glm::lookAtRH(eye, centre, up));
    } else if (type == PENUMBRA_LIGHT_SPOT) {
      const float fov = std::min(2.0f * l.outer_cone_angle + 0.1f, 3.0f);
      const float zfar = l.range > 0.0f ? l.range : far_from(wl.position);
      shadow_matrices.push_back(glm::perspectiveRH_ZO(fov, 1.0f, zfar * 1e-3f, zfar) *
                                glm::lookAtRH(wl.position, wl.position + dir, up));
    } else {
      static const glm::vec3 kFaces[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
      static const glm::vec3 kUps[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
      const float zfar = l.range > 0.0f ? l.range : far_from(wl.position), znear = zfar * 1e-3f;
      g.half_x.w = znear;  // the rect's soft shadows linearise the cube's depths
      g.half_y.w = zfar;
      for (int f = 0; f < 6; ++f) {
        shadow_matrices.push_back(glm::perspectiveRH_ZO(glm::radians(90.0f), 1.0f, znear, zfar) *
                                  glm::lookAtRH(wl.position, wl.position + kFaces[f], kUps[f]));
      }
      g.cone_shadow.w = 6.0f;
    }
    lights.push_back(g);
  }
}

// The depth buffer at the target's size; with a G-buffer pass (step > 0) the G-buffer and the
// ambient image at 1 / step of it; the shadow map array.
Status Renderer::Impl::ensure_targets(std::uint32_t width, std::uint32_t height, std::uint32_t shadow_map_size,
                                      std::uint32_t step) {
  if (!depth.image || depth_width != width || depth_height != height || ambient_step != step) {
    vkDeviceWaitIdle(vk);
    for (ImageResource* i : {&depth, &gbuffer, &ambient, &ambient_key, &ambient_depth}) alloc->destroy(*i);
    auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = kDepthFormat;
    info.extent = {width, height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    auto created = alloc->create_image(info, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_DEPTH_BIT);
    if (!created) return created.error();
    depth = *created;
    if (step > 0) {
      info.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
      for (auto [image, format] : {std::pair{&gbuffer, kGBufferFormat}, std::pair{&ambient, kAmbientFormat},
                                   std::pair{&ambient_key, kAmbientFormat}}) {
        info.format = format;
        if (image != &gbuffer) info.extent = {(width + step - 1) / step, (height + step - 1) / step, 1};
        auto made = alloc->create_image(info, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
        if (!made) return made.error();
        *image = *made;
      }
      info.format = ambient_depth_format;
      info.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
      auto made =
          alloc->create_image(info, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT);
      if (!made) return made.error();
      ambient_depth = *made;
    }
    depth_width = width;
    depth_height = height;
    ambient_step = step;
    descriptors_dirty = true;
  }
  const auto layers = std::max<std::uint32_t>(1, static_cast<std::uint32_t>(shadow_matrices.size()));
  if (!shadow_map.image || shadow_size != shadow_map_size || shadow_layers != layers) {
    vkDeviceWaitIdle(vk);
    for (VkImageView v : shadow_layer_views) vkDestroyImageView(vk, v, nullptr);
    shadow_layer_views.clear();
    alloc->destroy(shadow_map);
    auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = kDepthFormat;
    info.extent = {shadow_map_size, shadow_map_size, 1};
    info.mipLevels = 1;
    info.arrayLayers = layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    auto created = alloc->create_image(info, VK_IMAGE_VIEW_TYPE_2D_ARRAY, VK_IMAGE_ASPECT_DEPTH_BIT);
    if (!created) return created.error();
    shadow_map = *created;
    for (std::uint32_t i = 0; i < layers; ++i) {
      auto view = vk_struct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
      view.image = shadow_map.image;
      view.viewType = VK_IMAGE_VIEW_TYPE_2D;
      view.format = kDepthFormat;
      view.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
      VkImageView v = VK_NULL_HANDLE;
      if (vkCreateImageView(vk, &view, nullptr, &v) != VK_SUCCESS) {
        return make_error(ErrorCode::Internal, "Renderer: cannot create a shadow map view");
      }
      shadow_layer_views.push_back(v);
    }
    shadow_size = shadow_map_size;
    shadow_layers = layers;
    shadow_initialised = false;
    shadow_layer_keys.assign(layers, {});
    descriptors_dirty = true;
  }
  return {};
}

void Renderer::Impl::write_descriptors() {
  if (!descriptors_dirty) return;
  descriptors_dirty = false;
  const VkDescriptorBufferInfo frame_info{frame_buffer.buffer, 0, sizeof(gpu::FrameUniforms)};
  const VkDescriptorBufferInfo light_info{light_buffer.buffer, 0, VK_WHOLE_SIZE};
  const VkDescriptorBufferInfo matrix_info{shadow_matrix_buffer.buffer, 0, VK_WHOLE_SIZE};
  const VkDescriptorBufferInfo joint_info{joint_buffer.buffer, 0, VK_WHOLE_SIZE};
  const VkDescriptorImageInfo shadow_info{shadow_sampler, shadow_map.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  const VkDescriptorImageInfo shadow_depth_info{point_sampler, shadow_map.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  // The screen images, or the white texture where they do not exist (only pipelines that do not
  // run then read them).
  const bool ambient_pass = gbuffer.view != VK_NULL_HANDLE;
  const VkDescriptorImageInfo screen_info[4] = {
      {point_sampler, ambient_pass ? depth.view : white.image.view,
       ambient_pass ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
      {point_sampler, ambient_pass ? gbuffer.view : white.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
      {point_sampler, ambient_pass ? ambient.view : white.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
      {point_sampler, ambient_pass ? ambient_key.view : white.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}};
  const VkDescriptorImageInfo sky_info{sky_sampler, sky_image.view ? sky_image.view : white.image.view,
                                       VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet writes[11];
  auto buffer_write = [&](int i, std::uint32_t binding, VkDescriptorType type, const VkDescriptorBufferInfo* info) {
    writes[i] = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = frame_set;
    writes[i].dstBinding = binding;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = type;
    writes[i].pBufferInfo = info;
  };
  auto image_write = [&](int i, std::uint32_t binding, std::uint32_t count, const VkDescriptorImageInfo* info) {
    writes[i] = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = frame_set;
    writes[i].dstBinding = binding;
    writes[i].descriptorCount = count;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = info;
  };
  buffer_write(0, PENUMBRA_BINDING_FRAME, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, &frame_info);
  buffer_write(1, PENUMBRA_BINDING_LIGHTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, &light_info);
  buffer_write(2, PENUMBRA_BINDING_SHADOW_MATRICES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, &matrix_info);
  buffer_write(3, PENUMBRA_BINDING_JOINTS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, &joint_info);
  image_write(4, PENUMBRA_BINDING_SHADOW_MAP, 1, &shadow_info);
  image_write(5, PENUMBRA_BINDING_SCENE_DEPTH, 1, &screen_info[0]);
  image_write(6, PENUMBRA_BINDING_GBUFFER, 1, &screen_info[1]);
  image_write(7, PENUMBRA_BINDING_AMBIENT, 1, &screen_info[2]);
  image_write(8, PENUMBRA_BINDING_AMBIENT_KEY, 1, &screen_info[3]);
  image_write(9, PENUMBRA_BINDING_SKY, 1, &sky_info);
  image_write(10, PENUMBRA_BINDING_SHADOW_DEPTH, 1, &shadow_depth_info);
  vkUpdateDescriptorSets(vk, std::size(writes), writes, 0, nullptr);
}

// Graphics pipelines for dynamic rendering, made on first use:
//   Shadow          depth only, from the lights (`format` unused);
//   DepthPrepass    the forward vertex stage without a fragment stage, colour writes off: the
//                   camera's depth, in the forward pass's rendering;
//   GBufferPrepass  the same depth plus the G-buffer (`format` kGBufferFormat), when the ambient
//                   image or a feature's view is drawn;
//   AmbientKey      one triangle over the ambient image: each sample's key and depth, when no
//                   source pass writes them;
//   Forward         per colour format, shading only the fragments the pre-pass left in front
//                   (depth EQUAL, no depth writes): each pixel runs the costly fragment stage once
//                   whatever the overdraw; specialised on the debug view (constant_id 0), in
//                   `flag` on whether the ambient image was drawn (constant_id 1), on the shadow
//                   taps (constant_id 2; 0 without shadows), on the light count (constant_id
//                   3; 0: not fixed) and on whether any light is a rect (constant_id 4: the
//                   polygon irradiance is compiled out without one; on llvmpipe it made a frame
//                   of the courtyard, which has none, 3.4x slower);
//   Sky             one triangle at the far plane after the forward pass (depth LESS_OR_EQUAL, no
//                   writes): the environment map wherever nothing was drawn, in the lit view.
Result<VkPipeline> Renderer::Impl::pipeline(Pass pass, VkFormat format, std::uint32_t view, bool flag,
                                            std::uint32_t shadow_taps, std::uint32_t light_count, bool rect_lights) {
  if (pass != Pass::Forward) view = shadow_taps = light_count = 0, flag = rect_lights = false;
  if (pass == Pass::Shadow) format = VK_FORMAT_UNDEFINED;
  const auto key = std::tuple{pass, format, view, flag, shadow_taps, light_count, rect_lights};
  if (auto it = pipelines.find(key); it != pipelines.end()) return it->second;
  const bool shadow = pass == Pass::Shadow, forward = pass == Pass::Forward, screen = pass == Pass::AmbientKey;
  const bool sky_pass = pass == Pass::Sky;
  const bool depth_writes = pass == Pass::Shadow || pass == Pass::DepthPrepass || pass == Pass::GBufferPrepass;
  const bool forward_vertex = !shadow && !screen && !sky_pass;  // the pre-passes run the forward vertex stage: equal depths
  const struct {
    std::uint32_t view;
    VkBool32 flag;
    std::uint32_t shadow_taps;
    std::uint32_t light_count;
    VkBool32 rect_lights;
  } forward_constants{view, flag ? VK_TRUE : VK_FALSE, shadow_taps, light_count, rect_lights ? VK_TRUE : VK_FALSE};
  const VkSpecializationMapEntry entries[] = {{0, 0, sizeof(std::uint32_t)},
                                              {1, sizeof(std::uint32_t), sizeof(VkBool32)},
                                              {2, sizeof(std::uint32_t) + sizeof(VkBool32), sizeof(std::uint32_t)},
                                              {3, 2 * sizeof(std::uint32_t) + sizeof(VkBool32), sizeof(std::uint32_t)},
                                              {4, 3 * sizeof(std::uint32_t) + sizeof(VkBool32), sizeof(VkBool32)}};
  const VkSpecializationInfo specialization{5, entries, sizeof forward_constants, &forward_constants};
  VkPipelineShaderStageCreateInfo stages[2];
  for (auto& s : stages) s = vk_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = screen || sky_pass ? screen_vert : forward_vertex ? forward_vert : shadow_vert;
  stages[0].pName = "main";
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = sky_pass ? sky_frag : screen ? ambient_key_frag : forward ? forward_frag : gbuffer_frag;
  stages[1].pName = "main";
  stages[1].pSpecializationInfo = forward ? &specialization : nullptr;
  const bool has_fragment = forward || screen || sky_pass || pass == Pass::GBufferPrepass;

  const VkVertexInputBindingDescription bindings[] = {
      {0, sizeof(GpuVertex), VK_VERTEX_INPUT_RATE_VERTEX},
      {1, sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX},
  };
  const VkVertexInputAttributeDescription forward_attributes[] = {
      {0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(GpuVertex, position)},
      {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(GpuVertex, normal)},
      {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(GpuVertex, uv)},
      {3, 0, VK_FORMAT_R16G16B16A16_UINT, offsetof(GpuVertex, joints)},
      {4, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(GpuVertex, weights)},
      {5, 1, VK_FORMAT_R32_SFLOAT, 0},
  };
  const VkVertexInputAttributeDescription shadow_attributes[] = {
      {0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(GpuVertex, position)},
      {3, 0, VK_FORMAT_R16G16B16A16_UINT, offsetof(GpuVertex, joints)},
      {4, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(GpuVertex, weights)},
  };
  auto vertex_input = vk_struct<VkPipelineVertexInputStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  vertex_input.vertexBindingDescriptionCount = screen || sky_pass ? 0 : (forward_vertex ? 2 : 1);
  vertex_input.pVertexBindingDescriptions = bindings;
  vertex_input.vertexAttributeDescriptionCount =
      screen || sky_pass ? 0 : (forward_vertex ? std::size(forward_attributes) : std::size(shadow_attributes));
  vertex_input.pVertexAttributeDescriptions = forward_vertex ? forward_attributes : shadow_attributes;
  auto assembly = vk_struct<VkPipelineInputAssemblyStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  auto viewport = vk_struct<VkPipelineViewportStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  auto raster = vk_struct<VkPipelineRasterizationStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;  // two-sided (open scenes: Cornell's front, thin walls)
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  raster.depthBiasEnable = shadow ? VK_TRUE : VK_FALSE;  // slope-scaled bias against shadow acne
  raster.depthBiasConstantFactor = 1.5f;
  raster.depthBiasSlopeFactor = 2.0f;
  auto multisample = vk_struct<VkPipelineMultisampleStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  auto depth_state = vk_struct<VkPipelineDepthStencilStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  depth_state.depthTestEnable = VK_TRUE;
  depth_state.depthWriteEnable = depth_writes || screen ? VK_TRUE : VK_FALSE;
  depth_state.depthCompareOp = depth_writes ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_EQUAL;
  if (screen) depth_state.depthCompareOp = VK_COMPARE_OP_ALWAYS;
  if (sky_pass) depth_state.depthCompareOp = VK_COMPARE_OP_LESS_OR_EQUAL;  // only where the clear's 1 is left
  VkPipelineColorBlendAttachmentState blend_attachment{};
  blend_attachment.colorWriteMask = pass != Pass::DepthPrepass ? VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                                                     VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT
                                                               : 0;
  // The key pass writes the ambient image and its key.
  const VkPipelineColorBlendAttachmentState blend_attachments[2] = {blend_attachment, blend_attachment};
  const std::uint32_t colour_attachments = shadow ? 0 : screen ? 2 : 1;
  const VkFormat colour_formats[2] = {format, format};
  auto blend = vk_struct<VkPipelineColorBlendStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  blend.attachmentCount = colour_attachments;
  blend.pAttachments = blend_attachments;
  const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  auto dynamic = vk_struct<VkPipelineDynamicStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dynamic_states;
  auto rendering = vk_struct<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  rendering.colorAttachmentCount = colour_attachments;
  rendering.pColorAttachmentFormats = colour_formats;
  rendering.depthAttachmentFormat = screen ? ambient_depth_format : kDepthFormat;
  rendering.stencilAttachmentFormat = screen ? ambient_depth_format : VK_FORMAT_UNDEFINED;

  auto info = vk_struct<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
  info.pNext = &rendering;
  info.stageCount = has_fragment ? 2 : 1;
  info.pStages = stages;
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth_state;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = renderer_layout;
  VkPipeline made = VK_NULL_HANDLE;
  if (VkResult r = vkCreateGraphicsPipelines(vk, VK_NULL_HANDLE, 1, &info, nullptr, &made); r != VK_SUCCESS) {
    return make_error(ErrorCode::Unsupported, std::string("Renderer: cannot create a pipeline for colour format ") +
                                                  std::to_string(int(format)) + " (" + vk_result_name(r) + ")");
  }
  pipelines[key] = made;
  return made;
}

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Renderer::~Renderer() = default;

Result<std::unique_ptr<Renderer>> Renderer::create(Device& device, RenderFeatures features) {
  auto impl = std::make_unique<Impl>();
  impl->gpu_device = &device;
  impl->features = std::move(features);
  PENUMBRA_TRY(impl->init());
  return std::unique_ptr<Renderer>(new Renderer(std::move(impl)));
}

const FrameStats& Renderer::stats() const { return impl_->stats; }

std::uint64_t FrameStats::counter(std::string_view name) const {
  for (const auto& [n, value] : counters)
    if (n == name) return value;
  return 0;
}

std::vector<ViewInfo> Renderer::views() const { return all_views(impl_->features); }

Status Renderer::sync(World& world) {
  Impl& r = *impl_;
  const auto start = std::chrono::steady_clock::now();
  r.draws.clear();
  r.joints.clear();
  r.bounds = Aabb{};
  r.sky = world_environment(world);
  PENUMBRA_TRY(r.upload_sky());
  r.stats.vertex_ao_uploads = 0;
  r.stats.counters.clear();
  std::uint32_t max_vertices = 0;
  for (auto& f : r.features) {
    PENUMBRA_TRY(f->sync(world, r));
    f->add_counters(r.stats);
  }

  // Draws in entity order: mesh, material texture, skin pose, per-vertex AO, the features' values.
  const std::vector<Entity> entities = world.view<const Mesh, const WorldTransform>().sorted_entities();
  for (Entity e : entities) {
    const Mesh& m = world.get<Mesh>(e);
    if (!m.data || m.data->positions.empty() || m.data->indices.empty()) continue;
    auto gm = r.mesh(m.data);
    if (!gm) return gm.error();
    const auto* material = world.try_get<Material>(e);
    const Material mat = material ? *material : Material{};
    auto tex = r.texture(mat.base_color_texture);
    if (!tex) return tex.error();
    Draw d;
    d.mesh = *gm;
    d.material = (*tex)->set;
    d.push.model = world.get<WorldTransform>(e).matrix;
    d.push.base_color = mat.base_color;
    d.push.emissive = glm::vec4(mat.emissive, 0.0f);
    d.casts_shadow = mat.emissive == glm::vec3(0.0f);
    const auto* pose = world.try_get<SkinPose>(e);
    if (pose && !pose->joint_matrices.empty() && !m.data->joints.empty()) {
      d.push.draw = glm::uvec4(static_cast<std::uint32_t>(r.joints.size()), 1u, 0u, 0u);
      d.joint_count = static_cast<std::uint32_t>(pose->joint_matrices.size());
      r.joints.insert(r.joints.end(), pose->joint_matrices.begin(), pose->joint_matrices.end());
      // A skinned vertex is a convex combination of its joints' transforms of it: within the
      // box of every joint's transform of the mesh's box.
      for (const glm::mat4& joint : pose->joint_matrices)
        extend_by_box(d.world_bounds, m.data->bounds, d.push.model * joint);
    } else {
      extend_by_box(d.world_bounds, m.data->bounds, d.push.model);
    }
    const auto* ao = world.try_get<VertexAO>(e);
    if (ao && ao->ao.size() == m.data->positions.size()) {
      // Uploaded again only when the component's change tick moved (an animated one: the frames that changed it).
      VertexAoBuffer& b = r.vertex_ao[e.index];
      const std::uint64_t tick = world.changed_tick<VertexAO>(e);
      if (!b.buffer.buffer || b.entity != e || b.tick != tick || b.buffer.size < ao->ao.size() * sizeof(float)) {
        PENUMBRA_TRY(r.ensure_host_buffer(b.buffer, ao->ao.size() * sizeof(float), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT));
        std::memcpy(b.buffer.mapped, ao->ao.data(), ao->ao.size() * sizeof(float));
        b.entity = e;
        b.tick = tick;
        ++r.stats.vertex_ao_uploads;
      }
      d.ao = b.buffer.buffer;
      d.push.draw.w = ao->static_occluders ? 1u : 0u;
    }
    DrawFeatureValues values;
    for (const auto& f : r.features) f->draw_values(world, e, values);
    d.push.feature = glm::vec4(values.receiver, values.open, world.has<Static>(e) ? 1.0f : 0.0f, 0.0f);
    max_vertices = std::max(max_vertices, d.mesh->vertex_count);
    extend_by_box(r.bounds, m.data->bounds, d.push.model);  // the scene's bounds, unposed
    r.draws.push_back(d);
  }

  // Rect lights' emitters: a quad of the light's radiance where the light is (a light, not geometry:
  // it casts no shadow and the bakes do not see it), moved off its plane along where it shines by
  // 0.5 % of its diagonal, so that a light mounted on a surface does not fight it for depth; seen
  // from both sides (no culling).
  const std::vector<WorldLight> world_lights = gather_lights(world);
  for (const WorldLight& wl : world_lights) {
    if (wl.light.type != Light::Type::Rect) continue;
    if (!r.emitter_quad) r.emitter_quad = std::make_shared<const MeshData>(make_quad(1.0f, 1.0f, "rect light"));
    auto gm = r.mesh(r.emitter_quad);
    if (!gm) return gm.error();
    auto tex = r.texture(nullptr);
    if (!tex) return tex.error();
    const glm::vec3 dir = glm::normalize(wl.direction);
    const float lift = 0.005f * 2.0f * glm::length(wl.half_x + wl.half_y);
    Draw d;
    d.mesh = *gm;
    d.material = (*tex)->set;
    d.push.model = glm::mat4(glm::vec4(2.0f * wl.half_x, 0.0f), glm::vec4(2.0f * wl.half_y, 0.0f), glm::vec4(dir, 0.0f),
                             glm::vec4(wl.position + lift * dir, 1.0f));
    d.push.base_color = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    d.push.emissive = glm::vec4(wl.light.color * wl.light.intensity, 0.0f);
    d.push.feature = glm::vec4(0.0f, 1.0f, 0.0f, 0.0f);
    d.casts_shadow = false;
    max_vertices = std::max(max_vertices, d.mesh->vertex_count);
    extend_by_box(d.world_bounds, r.emitter_quad->bounds, d.push.model);
    r.draws.push_back(d);
  }

  // The shared AO = 1 attribute, long enough for the largest mesh.
  if (r.ones.size < VkDeviceSize{max_vertices} * sizeof(float)) {
    PENUMBRA_TRY(r.ensure_host_buffer(r.ones, max_vertices * sizeof(float), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT));
    std::fill_n(static_cast<float*>(r.ones.mapped), r.ones.size / sizeof(float), 1.0f);
  }
  for (Draw& d : r.draws) {
    if (!d.ao) d.ao = r.ones.buffer;
  }

  r.plan_shadows(world_lights);
  r.stats.draws = static_cast<std::uint32_t>(r.draws.size());
  r.stats.cpu_record_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return {};
}

Status Renderer::record(VkCommandBuffer cmd, const RenderTarget& target, const CameraView& camera,
                        const RenderSettings& settings) {
  return impl_->record(cmd, target, camera, settings);
}

Status Renderer::Impl::record(VkCommandBuffer cmd, const RenderTarget& target, const CameraView& camera,
                              const RenderSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  if (!target.image || !target.view || target.width == 0 || target.height == 0) {
    return make_error(ErrorCode::InvalidArgument, "Renderer::record: the target has no image, view or size");
  }
  if (settings.shadow_map_size < 16 || settings.shadow_map_size > 8192) {
    return make_error(ErrorCode::InvalidArgument, "Renderer: shadow_map_size " + std::to_string(settings.shadow_map_size) +
                                                      " is outside [16, 8192]");
  }
  if (settings.shadow_taps != 1 && settings.shadow_taps != 4 && settings.shadow_taps != 16) {
    return make_error(ErrorCode::InvalidArgument, "Renderer: shadow_taps " + std::to_string(settings.shadow_taps) +
                                                      " is not 1 (bilinear), 4 (tent over 3x3 texels) or 16 (rect lights soft)");
  }
  if (settings.ambient_step < 1 || settings.ambient_step > 2) {
    return make_error(ErrorCode::InvalidArgument, "Renderer: ambient_step " + std::to_string(settings.ambient_step) +
                                                      " is neither 1 (every pixel) nor 2 (half resolution)");
  }
  // The view: the renderer's own (forward.frag's kView) or a feature's.
  int own_view = -1;
  RenderFeature* view_feature = nullptr;
  std::size_t feature_view = 0;
  for (std::size_t v = 0; v < std::size(kOwnViews); ++v)
    if (kOwnViews[v].name == settings.view) own_view = static_cast<int>(v);
  for (const auto& f : features)
    for (std::size_t v = 0; own_view < 0 && !view_feature && v < f->views().size(); ++v)
      if (f->views()[v].name == settings.view) view_feature = f.get(), feature_view = v;
  if (own_view < 0 && !view_feature) {
    std::string all;
    for (const ViewInfo& v : all_views(features)) all += (all.empty() ? "" : ", ") + std::string(v.name);
    return make_error(ErrorCode::InvalidArgument, "Renderer: unknown view '" + settings.view + "'; use one of " + all);
  }
  // The ambient image is drawn in the views that show indirect light or AO, when a feature is
  // active; its sources only when the view shows indirect light.
  const bool ambient_view = own_view == PENUMBRA_VIEW_LIT || own_view == PENUMBRA_VIEW_INDIRECT ||
                            own_view == PENUMBRA_VIEW_AO;
  bool any_active = false, sources = false;
  float irradiance_bound = 0.0f;
  for (const auto& f : features) {
    if (!f->active()) continue;
    any_active = true;
    if (f->role() == AmbientRole::Source && own_view != PENUMBRA_VIEW_AO) {
      sources = true;
      irradiance_bound += f->irradiance_bound();
    }
  }
  const bool ambient_pass = ambient_view && any_active;
  const bool gbuffer_pass = ambient_pass || view_feature != nullptr;
  const bool shadows = settings.shadows && !shadow_matrices.empty() && !view_feature;
  const auto light_count = static_cast<std::uint32_t>(lights.size());
  const bool rect_lights = std::any_of(lights.begin(), lights.end(), [](const gpu::GpuLight& l) {
    return l.position_type.w == float(PENUMBRA_LIGHT_RECT);
  });
  auto forward = pipeline(Pass::Forward, target.format, static_cast<std::uint32_t>(std::max(own_view, 0)), ambient_pass,
                          shadows ? settings.shadow_taps : 0,
                          light_count <= PENUMBRA_UNROLLED_LIGHTS ? light_count : 0, rect_lights);
  if (!forward) return forward.error();
  auto prepass =
      gbuffer_pass ? pipeline(Pass::GBufferPrepass, kGBufferFormat) : pipeline(Pass::DepthPrepass, target.format);
  if (!prepass) return prepass.error();
  auto shadow = pipeline(Pass::Shadow, VK_FORMAT_UNDEFINED);
  if (!shadow) return shadow.error();
  // The environment map behind the scene in the lit view (without a map the clear colour is the sky).
  const bool sky_map = own_view == PENUMBRA_VIEW_LIT && !view_feature && sky.map_data != nullptr;
  VkPipeline sky_pipeline = VK_NULL_HANDLE;
  if (sky_map) {
    auto made = pipeline(Pass::Sky, target.format);
    if (!made) return made.error();
    sky_pipeline = *made;
  }
  VkPipeline key = VK_NULL_HANDLE;
  if (ambient_pass && !sources) {
    auto made = pipeline(Pass::AmbientKey, kAmbientFormat);
    if (!made) return made.error();
    key = *made;
  }
  PENUMBRA_TRY(ensure_targets(target.width, target.height, settings.shadow_map_size,
                              gbuffer_pass ? settings.ambient_step : 0));

  // Per-frame data.
  PENUMBRA_TRY(ensure_host_buffer(light_buffer, std::max<std::size_t>(1, lights.size()) * sizeof(gpu::GpuLight),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
  PENUMBRA_TRY(ensure_host_buffer(shadow_matrix_buffer, std::max<std::size_t>(1, shadow_matrices.size()) * sizeof(glm::mat4),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
  PENUMBRA_TRY(ensure_host_buffer(joint_buffer, std::max<std::size_t>(1, joints.size()) * sizeof(glm::mat4),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
  copy_into(light_buffer, lights);
  copy_into(shadow_matrix_buffer, shadow_matrices);
  copy_into(joint_buffer, joints);
  gpu::FrameUniforms frame{};
  frame.view_proj = camera.projection * camera.view;
  frame.camera_exposure = glm::vec4(camera.position, settings.exposure);
  std::uint32_t flags = 0;
  if (ambient_pass && sources) flags |= PENUMBRA_FLAG_INDIRECT;
  if (is_float_format(target.format)) flags |= PENUMBRA_FLAG_LINEAR;
  if (is_unorm_format(target.format)) flags |= PENUMBRA_FLAG_ENCODE_SRGB;
  frame.params = glm::uvec4(static_cast<std::uint32_t>(std::max(own_view, 0)), light_count, flags, 0u);
  // Normal offset: about one shadow texel of the widest (directional) map.
  const float radius = bounds.empty() ? 1.0f : 0.5f * glm::length(bounds.extent());
  frame.shadow_params = glm::vec4(1.0f / float(settings.shadow_map_size), 0.0f,
                                  2.0f * radius / float(settings.shadow_map_size), 0.0f);
  frame.clip_to_world = glm::inverse(frame.view_proj);
  frame.target_size = glm::vec4(float(target.width), float(target.height), 1.0f / float(target.width),
                                1.0f / float(target.height));
  frame.ambient_params = glm::uvec4(settings.ambient_step, 0u, 0u, 0u);
  // The ambient image's scale: 1 / a bound on the sources' irradiance, so that half floats hold it.
  const float scale = std::isfinite(irradiance_bound) && irradiance_bound > 0.0f ? 1.0f / irradiance_bound : 1.0f;
  frame.ambient_scale = glm::vec4(scale, 0.0f, 0.0f, 0.0f);
  std::memcpy(frame_buffer.mapped, &frame, sizeof frame);
  write_descriptors();

  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, renderer_layout, 0, 1, &frame_set, 0, nullptr);
  record_shadow_layers(cmd, shadows, *shadow);

  // Depth pre-pass; with the ambient image or a feature's view it also writes the G-buffer and
  // is followed by them, and the forward pass then reads its depth (read-only). Without them the
  // pre-pass and the forward pass share one rendering.
  const VkImageLayout forward_depth_layout =
      gbuffer_pass ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  image_barrier(cmd, depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, 0,
                VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
  auto depth_attachment = vk_struct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  depth_attachment.imageView = depth.view;
  depth_attachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth_attachment.storeOp = gbuffer_pass ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE;
  depth_attachment.clearValue.depthStencil = {1.0f, 0};
  auto color_attachment = vk_struct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  color_attachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  color_attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  auto info = vk_struct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  info.renderArea = {{0, 0}, {target.width, target.height}};
  info.layerCount = 1;
  info.colorAttachmentCount = 1;
  info.pColorAttachments = &color_attachment;
  FeatureFrame feature_frame;
  feature_frame.camera = &camera;
  feature_frame.settings = &settings;
  feature_frame.width = target.width;
  feature_frame.height = target.height;
  feature_frame.ambient_width = (target.width + settings.ambient_step - 1) / settings.ambient_step;
  feature_frame.ambient_height = (target.height + settings.ambient_step - 1) / settings.ambient_step;
  feature_frame.target_format = target.format;
  if (gbuffer_pass) {
    // Pre-pass: depth and G-buffer.
    image_barrier(cmd, gbuffer.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, 0,
                  VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    // Not cleared: the passes read the G-buffer only where the depth says a surface was drawn.
    color_attachment.imageView = gbuffer.view;
    color_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    info.pDepthAttachment = &depth_attachment;
    vkCmdBeginRendering(cmd, &info);
    color_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    set_viewport(cmd, target.width, target.height);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, *prepass);
    draw_all(cmd, Pass::GBufferPrepass);
    vkCmdEndRendering(cmd);
    image_barrier(cmd, depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                  forward_depth_layout, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                      VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
    image_barrier(cmd, gbuffer.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                  VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);

    if (ambient_pass) PENUMBRA_TRY(record_ambient_passes(cmd, key, feature_frame, sources));
    depth_attachment.imageLayout = forward_depth_layout;
    depth_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    depth_attachment.storeOp = VK_ATTACHMENT_STORE_OP_NONE;
  }

  // Forward pass into the target.
  image_barrier(cmd, target.image, VK_IMAGE_ASPECT_COLOR_BIT, target.layout, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, 0,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
  color_attachment.imageView = target.view;
  // The background: a constant sky in the lit view (exposed and tone mapped as the forward pass
  // does; a map is drawn after the forward pass), else black.
  glm::vec3 background(0.0f);
  if (own_view == PENUMBRA_VIEW_LIT && !view_feature && !sky_map)
    background = is_float_format(target.format)
                     ? sky.radiance * settings.exposure
                     : display_colour(sky.radiance, settings.exposure, is_unorm_format(target.format));
  color_attachment.clearValue.color = {{background.r, background.g, background.b, 1.0f}};
  info.pDepthAttachment = view_feature ? nullptr : &depth_attachment;
  vkCmdBeginRendering(cmd, &info);
  set_viewport(cmd, target.width, target.height);
  Status drawn;
  if (view_feature) {  // the feature's view instead of the forward pass
    drawn = view_feature->record_view(cmd, *this, feature_frame, feature_view);
  } else {
    if (!gbuffer_pass) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, *prepass);
      draw_all(cmd, Pass::DepthPrepass);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, *forward);
    draw_all(cmd, Pass::Forward);
    if (sky_map) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sky_pipeline);
      vkCmdDraw(cmd, 3, 1, 0, 0);
    }
  }
  vkCmdEndRendering(cmd);
  PENUMBRA_TRY(drawn);
  if (target.final_layout != VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL) {
    image_barrier(cmd, target.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                  target.final_layout, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                  VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                  VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  }
  stats.gpu_bytes = alloc->bytes();
  stats.cpu_record_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return {};
}

// One draw of a pass: the shadow pass binds positions only (into shadow layer `layer`), the
// pre-passes bind what the forward pass binds, only the forward pass reads materials.
void Renderer::Impl::draw(VkCommandBuffer cmd, Pass pass, const Draw& d, std::uint32_t layer) const {
  gpu::DrawPush push = d.push;
  push.draw.z = layer;
  const VkBuffer buffers[2] = {d.mesh->vertices.buffer, d.ao};
  const VkDeviceSize offsets[2] = {0, 0};
  vkCmdBindVertexBuffers(cmd, 0, pass == Pass::Shadow ? 1 : 2, buffers, offsets);
  vkCmdBindIndexBuffer(cmd, d.mesh->indices.buffer, 0, VK_INDEX_TYPE_UINT32);
  if (pass == Pass::Forward)
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, renderer_layout, 1, 1, &d.material, 0, nullptr);
  vkCmdPushConstants(cmd, renderer_layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                     sizeof push, &push);
  vkCmdDrawIndexed(cmd, d.mesh->index_count, 1, 0, 0, 0);
}

void Renderer::Impl::draw_all(VkCommandBuffer cmd, Pass pass) const {
  for (const Draw& d : draws) draw(cmd, pass, d, 0);
}

void Renderer::Impl::record_shadow_layers(VkCommandBuffer cmd, bool shadows, VkPipeline shadow) {
  // Shadow passes: one depth-only pass per shadow layer whose content changed (its key: the
  // layer's matrix, the map's size, the casters that may be within it with their transforms and
  // joints); the others keep what they hold. A layer draws only those casters.
  std::vector<std::pair<std::uint32_t, std::vector<const Draw*>>> stale_layers;
  if (shadows) {
    for (std::uint32_t layer = 0; layer < shadow_matrices.size(); ++layer) {
      std::vector<const Draw*> casters;
      std::vector<std::byte> key;
      append_bytes(key, shadow_matrices[layer]);
      append_bytes(key, shadow_size);
      for (const Draw& d : draws) {
        if (!d.casts_shadow || !may_intersect(shadow_matrices[layer], d.world_bounds)) continue;
        casters.push_back(&d);
        append_bytes(key, d.mesh);
        append_bytes(key, d.push.model);
        for (std::uint32_t j = 0; j < d.joint_count; ++j) append_bytes(key, joints[d.push.draw.x + j]);
      }
      if (!shadow_initialised || key != shadow_layer_keys[layer]) {
        shadow_layer_keys[layer] = std::move(key);
        stale_layers.emplace_back(layer, std::move(casters));
      }
    }
  }
  stats.shadow_layers = shadows ? static_cast<std::uint32_t>(shadow_matrices.size()) : 0;
  stats.shadow_layers_rendered = static_cast<std::uint32_t>(stale_layers.size());
  const VkImageLayout shadow_from =
      shadow_initialised ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
  if (!stale_layers.empty()) {
    image_barrier(cmd, shadow_map.image, VK_IMAGE_ASPECT_DEPTH_BIT, shadow_from, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, 0, VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                  VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, shadow);
    set_viewport(cmd, shadow_size, shadow_size);
    for (const auto& [layer, casters] : stale_layers) {
      auto depth_attachment = vk_struct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
      depth_attachment.imageView = shadow_layer_views[layer];
      depth_attachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
      depth_attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
      depth_attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
      depth_attachment.clearValue.depthStencil = {1.0f, 0};
      auto info = vk_struct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
      info.renderArea = {{0, 0}, {shadow_size, shadow_size}};
      info.layerCount = 1;
      info.pDepthAttachment = &depth_attachment;
      vkCmdBeginRendering(cmd, &info);
      for (const Draw* d : casters) draw(cmd, Pass::Shadow, *d, layer);
      vkCmdEndRendering(cmd);
    }
    image_barrier(cmd, shadow_map.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    shadow_initialised = true;
  } else if (!shadow_initialised) {
    // Unused this frame, but bound: give it a valid layout once.
    image_barrier(cmd, shadow_map.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    shadow_initialised = true;
  }
}

Status Renderer::Impl::record_ambient_passes(VkCommandBuffer cmd, VkPipeline key, const FeatureFrame& frame,
                                             bool sources) {
  // The ambient image at 1 / ambient_step resolution: the sources' passes, the first of which
  // writes every sample, with its key and depth (ambient_sample.glsl), or without them the key
  // pass (no irradiance, open fraction 1); then the occluders' passes (render/feature.h).
  for (VkImage image : {ambient.image, ambient_key.image}) {
    image_barrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, 0,
                  VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                  VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT);
  }
  image_barrier(cmd, ambient_depth.image, VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT,
                VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, 0,
                VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
  VkRenderingAttachmentInfo ambient_attachments[2];
  for (int k = 0; k < 2; ++k) {
    ambient_attachments[k] = vk_struct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
    ambient_attachments[k].imageView = k == 0 ? ambient.view : ambient_key.view;
    ambient_attachments[k].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ambient_attachments[k].loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;  // the first pass writes every sample
    ambient_attachments[k].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  }
  auto sample_depth = vk_struct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  sample_depth.imageView = ambient_depth.view;
  sample_depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  sample_depth.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  sample_depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  auto sample_stencil = sample_depth;
  sample_stencil.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  sample_stencil.clearValue.depthStencil = {1.0f, 0};
  auto info = vk_struct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  info.renderArea = {{0, 0}, {frame.ambient_width, frame.ambient_height}};
  info.layerCount = 1;
  info.colorAttachmentCount = 2;
  info.pColorAttachments = ambient_attachments;
  info.pDepthAttachment = &sample_depth;
  info.pStencilAttachment = &sample_stencil;
  vkCmdBeginRendering(cmd, &info);
  set_viewport(cmd, frame.ambient_width, frame.ambient_height);
  if (!sources) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, key);
    vkCmdDraw(cmd, 3, 1, 0, 0);
  }
  Status recorded;
  FeatureFrame feature_frame = frame;
  feature_frame.first_source = true;
  for (AmbientRole role : {AmbientRole::Source, AmbientRole::Occluder}) {
    if (role == AmbientRole::Source && !sources) continue;
    for (const auto& f : features) {
      if (!recorded.ok() || f->role() != role || !f->active()) continue;
      recorded = f->record_ambient(cmd, *this, feature_frame);
      if (role == AmbientRole::Source) feature_frame.first_source = false;
    }
  }
  vkCmdEndRendering(cmd);
  for (VkImage image : {ambient.image, ambient_key.image}) {
    image_barrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                  VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
  }
  return recorded;
}

Status Renderer::Impl::offscreen_frame(const CameraView& camera, std::uint32_t width,
                                       std::uint32_t height, const RenderSettings& settings, bool linear_float,
                                       bool read, Image* out) {
  if (width == 0 || height == 0 || width > kMaxImageSize || height > kMaxImageSize) {
    return make_error(ErrorCode::InvalidArgument, "Renderer: image size " + std::to_string(width) + "x" +
                                                      std::to_string(height) + " is outside 1..16384");
  }
  const VkFormat format = linear_float ? VK_FORMAT_R32G32B32A32_SFLOAT : VK_FORMAT_R8G8B8A8_SRGB;
  if (!offscreen.image || offscreen_format != format || offscreen_width != width || offscreen_height != height) {
    vkDeviceWaitIdle(vk);
    alloc->destroy(offscreen);
    auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {width, height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    auto created = alloc->create_image(info, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
    if (!created) return created.error();
    offscreen = *created;
    offscreen_format = format;
    offscreen_width = width;
    offscreen_height = height;
  }
  const VkDeviceSize texel = linear_float ? 16 : 4;
  const VkDeviceSize bytes = VkDeviceSize{width} * height * texel;
  if (read) PENUMBRA_TRY(ensure_host_buffer(readback, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT));
  RenderTarget target;
  target.image = offscreen.image;
  target.view = offscreen.view;
  target.format = format;
  target.width = width;
  target.height = height;
  target.layout = VK_IMAGE_LAYOUT_UNDEFINED;
  target.final_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  Status recorded;
  PENUMBRA_TRY(gpu_device->submit_and_wait([&](VkCommandBuffer cmd) {
    recorded = record(cmd, target, camera, settings);
    if (!recorded.ok() || !read) return;
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, offscreen.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer, 1, &region);
  }));
  PENUMBRA_TRY(recorded);
  if (!read) return {};
  out->width = width;
  out->height = height;
  if (linear_float) {
    out->rgba32f.resize(std::size_t{width} * height * 4);
    std::memcpy(out->rgba32f.data(), readback.mapped, bytes);
  } else {
    out->rgba8.resize(std::size_t{width} * height * 4);
    std::memcpy(out->rgba8.data(), readback.mapped, bytes);
  }
  return {};
}

Result<Image> Renderer::render_image(World& world, const CameraView& camera, std::uint32_t width,
                                     std::uint32_t height, const RenderSettings& settings, bool linear_float) {
  PENUMBRA_TRY(sync(world));
  Image image;
  PENUMBRA_TRY(impl_->offscreen_frame(camera, width, height, settings, linear_float, true, &image));
  return image;
}

Status Renderer::render_frame(World& world, const CameraView& camera, std::uint32_t width, std::uint32_t height,
                              const RenderSettings& settings) {
  PENUMBRA_TRY(sync(world));
  return impl_->offscreen_frame(camera, width, height, settings, false, false, nullptr);
}

}  // namespace penumbra
