// The AO-field render feature (ao_field_render.h): the casters' buffer (ao_field_gpu.h), and per
// caster a stencil-marked box pass multiplying its open fraction into the ambient image.
#include "penumbra/ao_field/ao_field_render.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ao_field_layout.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ao_field/ao_field_gpu.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/render/renderer.h"
#include "shared/layout.h"

namespace penumbra {
namespace shaders {
std::span<const std::uint32_t> ao_field(std::string_view name);
}

using vk::vk_struct;

namespace {

class AOFieldRenderFeature final : public RenderFeature {
 public:
  std::string_view name() const override { return "ao-field"; }
  AmbientRole role() const override { return AmbientRole::Occluder; }

  Status init(RenderContext& gpu) override {
    const VkDescriptorSetLayoutBinding binding{PENUMBRA_AO_BINDING_FIELDS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
    auto set = gpu.feature_set({&binding, 1});
    if (!set) return set.error();
    set_ = set->set;
    layout_ = set->layout;
    auto vert = gpu.shader(shaders::ao_field("ao_field.vert"));
    auto frag = gpu.shader(shaders::ao_field("ao_field.frag"));
    if (!vert) return vert.error();
    if (!frag) return frag.error();

    // The boxes against the samples' depths (depth clamp: no near or far clipping): the mark
    // (stencil 1, front faces, no fragment stage) where a front face lies in front of the
    // sample's surface; the shading (back faces) where a back face lies behind it and the sample
    // is marked, resetting the stencil for the next caster; with the camera inside the box the
    // shading without the stencil test. Per representation (kGrid: radial fit 0, grid 1).
    FeaturePipeline p;
    p.layout = layout_;
    p.vertex = *vert;
    p.role = AmbientRole::Occluder;
    p.depth_clamp = true;
    p.depth_stencil.depthTestEnable = VK_TRUE;
    p.depth_stencil.depthCompareOp = VK_COMPARE_OP_LESS;
    p.depth_stencil.stencilTestEnable = VK_TRUE;
    p.depth_stencil.front = {VK_STENCIL_OP_KEEP, VK_STENCIL_OP_REPLACE, VK_STENCIL_OP_KEEP, VK_COMPARE_OP_ALWAYS,
                             0xff, 0xff, 1};
    p.depth_stencil.back = p.depth_stencil.front;
    p.cull = VK_CULL_MODE_BACK_BIT;
    p.colour_writes = false;
    auto mark = gpu.pipeline(p);
    if (!mark) return mark.error();
    mark_ = *mark;
    p.fragment = *frag;
    p.colour_writes = true;
    p.cull = VK_CULL_MODE_FRONT_BIT;
    p.depth_stencil.depthCompareOp = VK_COMPARE_OP_GREATER_OR_EQUAL;
    for (int grid = 0; grid < 2; ++grid) {
      const VkBool32 constant = grid ? VK_TRUE : VK_FALSE;
      const VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
      const VkSpecializationInfo specialization{1, &entry, sizeof constant, &constant};
      p.specialization = &specialization;
      p.depth_stencil.stencilTestEnable = VK_TRUE;
      p.depth_stencil.front = {VK_STENCIL_OP_ZERO, VK_STENCIL_OP_ZERO, VK_STENCIL_OP_ZERO, VK_COMPARE_OP_EQUAL,
                               0xff, 0xff, 1};
      p.depth_stencil.back = p.depth_stencil.front;
      auto shade = gpu.pipeline(p);
      if (!shade) return shade.error();
      shade_[grid] = *shade;
      p.depth_stencil.stencilTestEnable = VK_FALSE;
      auto inside = gpu.pipeline(p);
      if (!inside) return inside.error();
      shade_inside_[grid] = *inside;
    }
    // The placeholder bound without casters.
    PENUMBRA_TRY(gpu.ensure_host_buffer(placeholder_, sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    std::memset(placeholder_.mapped, 0, placeholder_.size);
    bind(gpu, placeholder_);
    return {};
  }

  void release(RenderContext& gpu) override {
    gpu.allocator().destroy(buffer_);
    gpu.allocator().destroy(placeholder_);
  }

  // Re-packs the casters when one of them (its AOFieldCaster or WorldTransform) changed; uploads
  // everything when the set of casters or fields changed, else only the caster records (their
  // transforms), which the layout puts first. Without casters the buffer is released and the
  // feature is inactive.
  Status sync(World& world, RenderContext& gpu) override {
    bytes_uploaded_ = 0;
    std::vector<Entity> casters;
    std::vector<AOFieldGpuCaster> packed_casters;
    std::vector<const AOFieldData*> fields;
    std::uint64_t tick = 0;
    for (Entity e : world.view<const AOFieldCaster, const WorldTransform>().sorted_entities()) {
      const AOFieldCaster& c = world.get<AOFieldCaster>(e);
      if (!c.data || !c.data->valid()) continue;
      casters.push_back(e);
      packed_casters.push_back({c.data.get(), world.get<WorldTransform>(e).matrix});
      fields.push_back(c.data.get());
      tick = std::max({tick, world.changed_tick<AOFieldCaster>(e), world.changed_tick<WorldTransform>(e)});
    }
    const bool same_fields = casters == casters_ && fields == fields_;
    if (same_fields && tick <= tick_) return {};
    if (casters.empty()) {
      gpu.wait_idle();
      gpu.allocator().destroy(buffer_);
      bind(gpu, placeholder_);
      casters_.clear();
      grid_.clear();
      reach_.clear();
      fields_.clear();
      tick_ = 0;
      return {};
    }
    if (casters.size() > PENUMBRA_AO_MAX_CASTERS) {
      return make_error(ErrorCode::OutOfBudget, "ao-field render feature: " + std::to_string(casters.size()) +
                                                    " entities have a baked AOFieldCaster; the AO-field pass takes "
                                                    "at most " + std::to_string(PENUMBRA_AO_MAX_CASTERS) +
                                                    ": remove the component from the least visible ones");
    }
    auto packed = pack_ao_fields_gpu(packed_casters);
    if (!packed) return packed.error();
    const VkDeviceSize bytes = packed->bytes();
    VkDeviceSize upload = bytes;
    if (same_fields && buffer_.buffer && buffer_.size >= bytes) {
      upload = (1 + 7 * VkDeviceSize{packed->casters}) * sizeof(glm::vec4);  // the records only
    } else {
      const VkBuffer before = buffer_.buffer;
      PENUMBRA_TRY(gpu.ensure_host_buffer(buffer_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
      if (buffer_.buffer != before) bind(gpu, buffer_);
    }
    std::memcpy(buffer_.mapped, packed->data.data(), upload);
    bytes_uploaded_ = upload;
    casters_ = std::move(casters);
    fields_ = std::move(fields);
    tick_ = tick;
    grid_.resize(packed->casters);
    reach_.resize(packed->casters);
    for (std::uint32_t i = 0; i < packed->casters; ++i) {
      grid_[i] = packed->data[1 + 7 * i + 4].w == 1.0f;
      reach_[i] = packed->data[1 + 7 * i + 6];
    }
    return {};
  }

  // Surface receivers: their receiver code, 2 + their own caster record (-1: not a caster);
  // entity receivers: their occlusion over the whole entity.
  void draw_values(const World& world, Entity e, DrawFeatureValues& values) const override {
    const auto* receiver = world.try_get<AOFieldReceiver>(e);
    if (!receiver) return;
    if (receiver->mode == AOFieldReceiver::Mode::Surface) {
      const auto it = std::lower_bound(casters_.begin(), casters_.end(), e,
                                       [](Entity a, Entity b) { return a.index < b.index; });
      const int record = it != casters_.end() && *it == e ? static_cast<int>(it - casters_.begin()) : -1;
      values.receiver = 2.0f + float(record);
    } else {
      values.open *= 1.0f - std::clamp(receiver->occlusion, 0.0f, 1.0f);
    }
  }

  bool active() const override { return !casters_.empty(); }

  // Per caster its reach box: the mark, then the shading (a sample pays only for the casters
  // whose box holds it; llvmpipe runs the depth and stencil tests before the fragment stage).
  Status record_ambient(VkCommandBuffer cmd, RenderContext&, const FeatureFrame& frame) override {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 2, 1, &set_, 0, nullptr);
    // The camera is inside a box (its front faces can be behind it) when it is within the box
    // grown by the distance to the near plane's corners (znear = P[3][2] / P[2][2] for the
    // right-handed [0, 1]-depth projection of camera.cpp).
    const CameraView& camera = *frame.camera;
    const glm::mat4& p = camera.projection;
    const float znear = p[2][2] != 0.0f ? std::abs(p[3][2] / p[2][2]) : 0.0f;
    const float tan_x = p[0][0] != 0.0f ? 1.0f / std::abs(p[0][0]) : 0.0f;
    const float tan_y = p[1][1] != 0.0f ? 1.0f / std::abs(p[1][1]) : 0.0f;
    const float margin = znear * std::sqrt(1.0f + tan_x * tan_x + tan_y * tan_y);
    for (std::uint32_t i = 0; i < grid_.size(); ++i) {
      gpu::DrawPush push{};
      push.draw.x = i;
      vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                         &push);
      const glm::vec4& reach = reach_[i];
      const glm::vec3 offset = glm::abs(camera.position - glm::vec3(reach));
      const bool inside = std::max({offset.x, offset.y, offset.z}) <= reach.w + margin;
      if (!inside) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, mark_);
        vkCmdDraw(cmd, 36, 1, 0, 0);
      }
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, (inside ? shade_inside_ : shade_)[grid_[i]]);
      vkCmdDraw(cmd, 36, 1, 0, 0);
    }
    return {};
  }

  void add_counters(FrameStats& stats) const override {
    stats.counters.emplace_back("ao-field.casters", casters_.size());
    stats.counters.emplace_back("ao-field.bytes_uploaded", bytes_uploaded_);
  }

 private:
  // Points the descriptor set at `b` (the device is idle or the set unused since).
  void bind(RenderContext& gpu, const vk::Buffer& b) {
    const VkDescriptorBufferInfo info{b.buffer, 0, VK_WHOLE_SIZE};
    auto write = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    write.dstSet = set_;
    write.dstBinding = PENUMBRA_AO_BINDING_FIELDS;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    write.pBufferInfo = &info;
    vkUpdateDescriptorSets(gpu.device(), 1, &write, 0, nullptr);
  }

  VkDescriptorSet set_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline mark_ = VK_NULL_HANDLE, shade_[2] = {}, shade_inside_[2] = {};
  vk::Buffer buffer_, placeholder_;
  std::vector<Entity> casters_;             // the packed records' entities, in record order
  std::vector<bool> grid_;                  // their representation: grid (else radial fit)
  std::vector<glm::vec4> reach_;            // their world centre and reach
  std::vector<const AOFieldData*> fields_;  // their fields when packed
  std::uint64_t tick_ = 0;                  // the newest caster change tick packed
  std::uint64_t bytes_uploaded_ = 0;
};

}  // namespace

std::unique_ptr<RenderFeature> make_ao_field_render_feature() { return std::make_unique<AOFieldRenderFeature>(); }

}  // namespace penumbra
