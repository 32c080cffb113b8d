// The probe-grid render feature (probe_grid_render.h): the grids' atlas, the ambient pass and the
// debug views.
#include "penumbra/probe_grid/probe_grid_render.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/log.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/probe_grid/probe_grid_gpu.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/render/renderer.h"
#include "probe_grid_layout.h"

// The shader's leak-guard constants are the CPU lookup's (probe_grid.h).
static_assert(float(PENUMBRA_PROBE_NORMAL_BIAS) == penumbra::kProbeNormalBias);
static_assert(float(PENUMBRA_PROBE_STATIC_NORMAL_BIAS) == penumbra::kProbeStaticNormalBias);
static_assert(float(PENUMBRA_PROBE_REACH_SLACK) == penumbra::kProbeReachSlack);
static_assert(float(PENUMBRA_PROBE_PLANE_SLACK) == penumbra::kProbePlaneSlack);
static_assert(float(PENUMBRA_PROBE_SOLID_VALIDITY) == penumbra::kProbeSolidValidity);

namespace penumbra {
namespace shaders {
std::span<const std::uint32_t> probe_grid(std::string_view name);
}

using vk::vk_struct;

namespace {

constexpr ViewInfo kViews[] = {
    {"validity", "the probe grids' interpolated validity: red (0) to green (1); blue without a grid"},
    {"irradiance", "the probe grids' irradiance E(x, n) in W/m^2, exposed and tone mapped"},
};

// A bound on grid `d`'s irradiance anywhere: per node and channel the sum of |coefficient| x 1.1
// (>= max |Y_k| of the L2 basis).
float irradiance_bound(const ProbeGridData& d) {
  const std::size_t per_node = sh_coefficients(d.sh_order);
  float bound = 0.0f;
  for (std::size_t node = 0; node + 1 <= d.coefficients.size() / per_node; ++node) {
    glm::vec3 sum(0.0f);
    for (std::size_t c = 0; c < per_node; ++c) sum += glm::abs(d.coefficients[node * per_node + c]);
    bound = std::max({bound, 1.1f * sum.x, 1.1f * sum.y, 1.1f * sum.z});
  }
  return bound;
}

class ProbeGridRenderFeature final : public RenderFeature {
 public:
  std::string_view name() const override { return "probe-grid"; }
  AmbientRole role() const override { return AmbientRole::Source; }
  std::span<const ViewInfo> views() const override { return kViews; }

  Status init(RenderContext& gpu) override {
    const VkDescriptorSetLayoutBinding bindings[] = {
        {PENUMBRA_PROBE_BINDING_GRIDS, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {PENUMBRA_PROBE_BINDING_SH, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, PENUMBRA_PROBE_TEXTURES,
         VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {PENUMBRA_PROBE_BINDING_NODES, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
         nullptr},
    };
    PENUMBRA_TRY(passes_.init(gpu, bindings, shaders::probe_grid("probe_grid_ambient.frag"),
                              shaders::probe_grid("probe_grid_view.frag")));
    // The placeholder texture bound where a slot has no grid data, and the uniform buffer.
    const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    PENUMBRA_TRY(gpu.upload_image(placeholder_, texture_info(glm::uvec3(1)), VK_IMAGE_VIEW_TYPE_3D, zero, sizeof zero));
    PENUMBRA_TRY(gpu.ensure_host_buffer(uniforms_, sizeof(gpu::ProbeGrids), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));
    std::memset(uniforms_.mapped, 0, uniforms_.size);
    bind(gpu);
    return {};
  }

  void release(RenderContext& gpu) override {
    for (auto& t : sh_) gpu.allocator().destroy(t);
    gpu.allocator().destroy(nodes_);
    gpu.allocator().destroy(placeholder_);
    gpu.allocator().destroy(uniforms_);
  }

  // Re-packs the atlas when the blended grids (their data, priorities, blend distances) changed.
  Status sync(World& world, RenderContext& gpu) override {
    bytes_uploaded_ = 0;
    std::vector<BlendedProbeGrid> grids = blended_probe_grids(world);
    if (grids.size() > PENUMBRA_PROBE_MAX_GRIDS) {
      if (!warned_too_many_)
        log(LogLevel::Warning, "renderer: " + std::to_string(grids.size()) + " baked probe grids; the renderer blends "
                               "the " + std::to_string(PENUMBRA_PROBE_MAX_GRIDS) +
                               " of highest priority and leaves out the rest: merge or remove grids");
      warned_too_many_ = true;
      grids.resize(PENUMBRA_PROBE_MAX_GRIDS);
    }
    const bool same = grids.size() == grids_.size() &&
                      std::equal(grids.begin(), grids.end(), grids_.begin(), [](const auto& a, const auto& b) {
                        return a.data == b.data && a.priority == b.priority && a.index == b.index && a.blend == b.blend;
                      });
    if (same) return {};
    gpu.wait_idle();
    for (auto& t : sh_) gpu.allocator().destroy(t);
    gpu.allocator().destroy(nodes_);
    grids_ = std::move(grids);
    bound_ = 0.0f;
    if (!grids_.empty()) PENUMBRA_TRY(upload(gpu));
    bind(gpu);
    return {};
  }

  bool active() const override { return !grids_.empty(); }
  float irradiance_bound() const override { return bound_; }

  Status record_ambient(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame) override {
    return passes_.record_ambient(cmd, gpu, frame, static_cast<std::uint32_t>(grids_.size()));
  }
  Status record_view(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::size_t view) override {
    return passes_.record_view(cmd, gpu, frame, view, static_cast<std::uint32_t>(grids_.size()));
  }

  void add_counters(FrameStats& stats) const override {
    stats.counters.emplace_back("probe-grid.grids", grids_.size());
    stats.counters.emplace_back("probe-grid.bytes_uploaded", bytes_uploaded_);
  }

 private:
  static VkImageCreateInfo texture_info(glm::uvec3 extent) {
    auto info = vk_struct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = VK_IMAGE_TYPE_3D;
    info.format = VK_FORMAT_R32G32B32A32_SFLOAT;  // float32: the sampler's trilinear filter is the CPU's interpolation
    info.extent = {extent.x, extent.y, extent.z};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    return info;
  }

  // The atlas (probe_grid_layout.h): grid g's nodes at texels [0, resolution) + (0, 0, z_g + 1),
  // each grid padded by a copy of its last column and row and of its first and last slice, so
  // that the trilinear filter never reads another grid's texels; and the uniforms.
  Status upload(RenderContext& gpu) {
    glm::uvec3 atlas(1u, 1u, 0u);
    std::uint32_t textures = 0;
    for (const BlendedProbeGrid& g : grids_) {
      const glm::uvec3 r = g.data->layout.resolution;
      atlas = glm::uvec3(std::max(atlas.x, r.x + 1), std::max(atlas.y, r.y + 1), atlas.z + r.z + 2);
      textures = std::max<std::uint32_t>(textures, g.data->sh_order == ProbeShOrder::L1 ? 3 : PENUMBRA_PROBE_TEXTURES);
    }
    constexpr std::size_t kTexel = ProbeGridTextures::texel_bytes();
    const std::size_t atlas_texels = std::size_t{atlas.x} * atlas.y * atlas.z;
    std::vector<std::vector<std::byte>> sh(textures, std::vector<std::byte>(atlas_texels * kTexel));
    std::vector<glm::vec4> nodes(atlas_texels, glm::vec4(0.0f));
    gpu::ProbeGrids uniforms{};
    std::uint32_t z0 = 0;
    for (std::size_t i = 0; i < grids_.size(); ++i) {
      const ProbeGridData& d = *grids_[i].data;
      const glm::uvec3 r = d.layout.resolution;
      const ProbeGridTextures packed = pack_probe_grid_textures(d);
      const std::vector<glm::vec4> node_texels = pack_probe_node_texels(d);
      const std::size_t grid_texels = std::size_t{r.x} * r.y * r.z;
      for (std::uint32_t z = 0; z < r.z + 2; ++z)
        for (std::uint32_t y = 0; y <= r.y; ++y)
          for (std::uint32_t x = 0; x <= r.x; ++x) {
            const std::size_t src = (std::size_t{std::clamp(z, 1u, r.z) - 1} * r.y + std::min(y, r.y - 1)) * r.x +
                                    std::min(x, r.x - 1);
            const std::size_t dst = (std::size_t{z0 + z} * atlas.y + y) * atlas.x + x;
            for (std::uint32_t t = 0; t < packed.textures && t < textures; ++t)
              std::memcpy(sh[t].data() + dst * kTexel, packed.data.data() + (t * grid_texels + src) * kTexel, kTexel);
            nodes[dst] = node_texels[src];
          }
      gpu::ProbeGridGpu& u = uniforms.grids[i];
      u.world_to_grid = d.layout.world_to_grid;
      u.resolution = glm::vec4(glm::vec3(r), grids_[i].blend);
      u.size = glm::vec4(d.layout.spacing * glm::vec3(r - 1u), float(z0 + 1));
      u.params = glm::uvec4(d.sh_order == ProbeShOrder::L1 ? 2u : 3u, d.reach.empty() ? 0u : 1u, 0u, 0u);
      z0 += r.z + 2;
      bound_ = std::max(bound_, penumbra::irradiance_bound(d));
      // The renderer adds its own shadow-mapped direct light: an All grid counts that twice.
      if (d.lighting == LightingContent::All && warned_all_.insert(grids_[i].data.get()).second)
        log(LogLevel::Warning, "renderer: a probe grid stores direct + indirect light (lighting = all) and the "
                               "renderer adds its own direct light, so direct light counts twice; bake it with "
                               "lighting = indirect");
    }
    uniforms.atlas = glm::vec4(glm::vec3(atlas), 0.0f);
    for (std::uint32_t t = 0; t < textures; ++t) {
      PENUMBRA_TRY(gpu.upload_image(sh_[t], texture_info(atlas), VK_IMAGE_VIEW_TYPE_3D, sh[t].data(), sh[t].size()));
      bytes_uploaded_ += sh[t].size();
    }
    PENUMBRA_TRY(gpu.upload_image(nodes_, texture_info(atlas), VK_IMAGE_VIEW_TYPE_3D, nodes.data(),
                                  nodes.size() * sizeof(glm::vec4)));
    std::memcpy(uniforms_.mapped, &uniforms, sizeof uniforms);
    bytes_uploaded_ += nodes.size() * sizeof(glm::vec4) + sizeof uniforms;
    return {};
  }

  // Points the descriptor set at the atlas (the placeholder where a texture is absent).
  void bind(RenderContext& gpu) {
    const VkDescriptorBufferInfo buffer{uniforms_.buffer, 0, sizeof(gpu::ProbeGrids)};
    VkDescriptorImageInfo sh[PENUMBRA_PROBE_TEXTURES];
    for (int t = 0; t < PENUMBRA_PROBE_TEXTURES; ++t)
      sh[t] = {gpu.linear_sampler(), sh_[t].view ? sh_[t].view : placeholder_.view,
               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    const VkDescriptorImageInfo nodes{gpu.linear_sampler(), nodes_.view ? nodes_.view : placeholder_.view,
                                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet writes[3];
    for (auto& w : writes) {
      w = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
      w.dstSet = passes_.set();
      w.descriptorCount = 1;
      w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    }
    writes[0].dstBinding = PENUMBRA_PROBE_BINDING_GRIDS;
    writes[0].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    writes[0].pBufferInfo = &buffer;
    writes[1].dstBinding = PENUMBRA_PROBE_BINDING_SH;
    writes[1].descriptorCount = PENUMBRA_PROBE_TEXTURES;
    writes[1].pImageInfo = sh;
    writes[2].dstBinding = PENUMBRA_PROBE_BINDING_NODES;
    writes[2].pImageInfo = &nodes;
    vkUpdateDescriptorSets(gpu.device(), 3, writes, 0, nullptr);
  }

  ScreenPasses passes_;  // the ambient pass and the views, their variant the grid count (kGrids)
  vk::ImageResource sh_[PENUMBRA_PROBE_TEXTURES], nodes_, placeholder_;
  vk::Buffer uniforms_;
  std::vector<BlendedProbeGrid> grids_;  // in the atlas, in blend order
  float bound_ = 0.0f;
  std::uint64_t bytes_uploaded_ = 0;
  bool warned_too_many_ = false;
  std::set<const ProbeGridData*> warned_all_;
};

}  // namespace

std::unique_ptr<RenderFeature> make_probe_grid_render_feature() { return std::make_unique<ProbeGridRenderFeature>(); }

}  // namespace penumbra
