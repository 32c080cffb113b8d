// The indirect-transport render feature (indirect_transport_render.h).
#include "penumbra/indirect_transport/indirect_transport_render.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "indirect_transport_layout.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/render/renderer.h"

// The shader's seam margin is the CPU lookup's.
static_assert(float(PENUMBRA_TRANSPORT_MARGIN) == penumbra::kTransportMargin);
static_assert(float(PENUMBRA_TRANSPORT_PLANE_SNAP) == penumbra::kTransportPlaneSnap);
static_assert(float(PENUMBRA_TRANSPORT_PROBE_OFFSET) == penumbra::kBounceProbeOffset);

namespace penumbra {
namespace shaders {
std::span<const std::uint32_t> indirect_transport(std::string_view name);
}

using vk::vk_struct;

namespace {

constexpr ViewInfo kViews[] = {
    {"lightmap", "the indirect transport's bounce light of the DynamicLights in W/m^2 (the lightmap on its "
                 "patches, the bounce probes elsewhere), tone mapped"},
    {"patches", "the indirect transport's patches, one colour each, over their leaf texels"},
    {"bounce-probes", "the indirect transport's bounce probes: their irradiance at every surface, tone mapped"},
};

class IndirectTransportRenderFeature final : public RenderFeature {
 public:
  std::string_view name() const override { return "indirect-transport"; }
  AmbientRole role() const override { return AmbientRole::Source; }
  std::span<const ViewInfo> views() const override { return kViews; }

  Status init(RenderContext& gpu) override {
    const VkDescriptorSetLayoutBinding bindings[] = {
        {PENUMBRA_TRANSPORT_BINDING_PATCHES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
         nullptr},
        {PENUMBRA_TRANSPORT_BINDING_TEXELS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
         nullptr},
        {PENUMBRA_TRANSPORT_BINDING_CELLS, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
         nullptr},
        {PENUMBRA_TRANSPORT_BINDING_PROBES, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
         nullptr},
    };
    PENUMBRA_TRY(passes_.init(gpu, bindings, shaders::indirect_transport("indirect_transport_ambient.frag"),
                              shaders::indirect_transport("indirect_transport_view.frag")));
    PENUMBRA_TRY(resize(gpu, 0, 0, 0, 0));
    return {};
  }

  void release(RenderContext& gpu) override {
    gpu.allocator().destroy(patches_);
    gpu.allocator().destroy(texels_);
    gpu.allocator().destroy(cells_);
    gpu.allocator().destroy(probes_);
  }

  // The patches when the baked data changed; the texels of the lightmap that changed.
  Status sync(World& world, RenderContext& gpu) override {
    texels_uploaded_ = 0;
    std::shared_ptr<const TransportData> data;
    const IndirectLightmap* map = nullptr;
    for (Entity e : world.view<IndirectTransport>().sorted_entities()) {
      const IndirectTransport& t = world.get<IndirectTransport>(e);
      if (!t.data) continue;
      data = t.data;
      map = world.try_get<IndirectLightmap>(e);
      break;
    }
    const bool usable = data && map != nullptr && map->irradiance.size() == data->leaf_count() &&
                        map->probes.size() == 6 * data->probes.nodes();
    if (!usable) {
      if (data_) {
        gpu.wait_idle();
        data_.reset();
        PENUMBRA_TRY(resize(gpu, 0, 0, 0, 0));
      }
      return {};
    }
    if (data != data_) {
      gpu.wait_idle();
      data_ = data;
      gpu::TransportGrid grid{};
      const std::vector<std::uint32_t> cells = lookup_grid(*data, grid);
      PENUMBRA_TRY(resize(gpu, data->patches.size(), data->leaf_count(), cells.size(), data->probes.nodes()));
      auto* out = static_cast<std::uint8_t*>(patches_.mapped);
      std::memcpy(out, &grid, sizeof grid);
      std::memcpy(cells_.mapped, cells.data(), cells.size() * sizeof(std::uint32_t));
      for (std::size_t i = 0; i < data->patches.size(); ++i) {
        const TransportPatch& p = data->patches[i];
        gpu::TransportPatchGpu g{};
        g.origin = glm::vec4(p.origin, float(p.side()));
        g.axis_u = glm::vec4(p.edge_u / glm::dot(p.edge_u, p.edge_u), float(p.first));
        g.axis_v = glm::vec4(p.edge_v / glm::dot(p.edge_v, p.edge_v), 0.0f);
        g.plane = glm::vec4(p.normal, patch_plane_tolerance(p));
        std::memcpy(out + sizeof grid + i * sizeof g, &g, sizeof g);
      }
      shown_.assign(data->leaf_count(), glm::vec3(-1.0f));  // every texel differs from this
      const TransportProbes& probes = data->probes;
      gpu::TransportProbeGrid probe_grid{};
      probe_grid.count = glm::uvec4(probes.count, probes.nodes() > 0 ? 1u : 0u);
      probe_grid.origin = glm::vec4(probes.origin, probes.spacing);
      std::memcpy(probes_.mapped, &probe_grid, sizeof probe_grid);
      updated_tick_ = 0;
    }
    if (map->updated_tick == updated_tick_) return {};
    updated_tick_ = map->updated_tick;
    auto* texels = static_cast<glm::vec4*>(texels_.mapped);
    bound_ = 0.0f;
    for (std::size_t k = 0; k < map->irradiance.size(); ++k) {
      const glm::vec3 e = map->irradiance[k];
      bound_ = std::max({bound_, e.x, e.y, e.z});
      if (e == shown_[k]) continue;
      shown_[k] = e;
      texels[k] = glm::vec4(e, 0.0f);
      ++texels_uploaded_;
    }
    // The probes: six irradiances each, with the reach that way (-1 on a closed probe).
    auto* cubes = reinterpret_cast<glm::vec4*>(static_cast<std::uint8_t*>(probes_.mapped) +
                                               sizeof(gpu::TransportProbeGrid));
    const TransportProbes& probes = data_->probes;
    for (std::size_t k = 0; k < map->probes.size(); ++k) {
      const glm::vec3 e = map->probes[k];
      bound_ = std::max({bound_, e.x, e.y, e.z});
      cubes[k] = glm::vec4(e, probes.open[k / 6] != 0 ? probes.reach[k / 6][k % 6] : -1.0f);
    }
    return {};
  }

  bool active() const override { return data_ != nullptr; }
  float irradiance_bound() const override { return bound_; }

  Status record_ambient(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame) override {
    return passes_.record_ambient(cmd, gpu, frame);
  }
  Status record_view(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::size_t view) override {
    return passes_.record_view(cmd, gpu, frame, view);
  }

  void add_counters(FrameStats& stats) const override {
    stats.counters.emplace_back("indirect-transport.patches", data_ ? data_->patches.size() : 0);
    stats.counters.emplace_back("indirect-transport.texels_uploaded", texels_uploaded_);
  }

 private:
  // The lookup grid (indirect_transport_layout.h): cells about the median patch's size, at most
  // 64 per axis; the cells' offsets, then their patch lists.
  static std::vector<std::uint32_t> lookup_grid(const TransportData& data, gpu::TransportGrid& grid) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    std::vector<std::pair<glm::vec3, glm::vec3>> boxes;
    std::vector<float> sizes;
    for (const TransportPatch& p : data.patches) {
      const float pad = patch_plane_tolerance(p);
      const glm::vec3 a = p.origin - kTransportMargin * (p.edge_u + p.edge_v);
      const glm::vec3 du = (1.0f + 2.0f * kTransportMargin) * p.edge_u, dv = (1.0f + 2.0f * kTransportMargin) * p.edge_v;
      glm::vec3 blo = glm::min(glm::min(a, a + du), glm::min(a + dv, a + du + dv)) - glm::vec3(pad);
      glm::vec3 bhi = glm::max(glm::max(a, a + du), glm::max(a + dv, a + du + dv)) + glm::vec3(pad);
      boxes.push_back({blo, bhi});
      lo = glm::min(lo, blo);
      hi = glm::max(hi, bhi);
      sizes.push_back(std::sqrt(p.area()));
    }
    std::nth_element(sizes.begin(), sizes.begin() + static_cast<std::ptrdiff_t>(sizes.size() / 2), sizes.end());
    const float cell = std::max(sizes[sizes.size() / 2], 1e-6f);
    const glm::vec3 extent = glm::max(hi - lo, glm::vec3(cell * 1e-3f));
    const glm::uvec3 n = glm::clamp(glm::uvec3(glm::ceil(extent / cell)), glm::uvec3(1u), glm::uvec3(64u));
    grid.size = glm::uvec4(n, static_cast<std::uint32_t>(data.patches.size()));
    grid.origin = glm::vec4(lo, 0.0f);
    grid.scale = glm::vec4(glm::vec3(n) / extent, 0.0f);
    const std::size_t count = std::size_t{n.x} * n.y * n.z;
    std::vector<std::vector<std::uint32_t>> lists(count);
    for (std::uint32_t i = 0; i < boxes.size(); ++i) {
      const glm::uvec3 c0 = glm::min(glm::uvec3(glm::max((boxes[i].first - lo) * glm::vec3(grid.scale), glm::vec3(0.0f))), n - 1u);
      const glm::uvec3 c1 = glm::min(glm::uvec3(glm::max((boxes[i].second - lo) * glm::vec3(grid.scale), glm::vec3(0.0f))), n - 1u);
      for (std::uint32_t z = c0.z; z <= c1.z; ++z)
        for (std::uint32_t y = c0.y; y <= c1.y; ++y)
          for (std::uint32_t x = c0.x; x <= c1.x; ++x) lists[x + n.x * (y + n.y * std::size_t{z})].push_back(i);
    }
    std::vector<std::uint32_t> out(count + 1);
    for (std::size_t c = 0; c < count; ++c) {
      out[c] = static_cast<std::uint32_t>(out.size());
      out.insert(out.end(), lists[c].begin(), lists[c].end());
    }
    out[count] = static_cast<std::uint32_t>(out.size());
    return out;
  }

  // Host-visible buffers for `patches` patches, `texels` texels, `cells` lookup words and `probes`
  // bounce probes (at least one element each, so that the descriptors are valid without data;
  // zeros: an empty grid), bound to the set.
  Status resize(RenderContext& gpu, std::size_t patches, std::size_t texels, std::size_t cells, std::size_t probes) {
    const VkDeviceSize patch_bytes =
        sizeof(gpu::TransportGrid) + std::max<std::size_t>(patches, 1) * sizeof(gpu::TransportPatchGpu);
    const VkDeviceSize texel_bytes = std::max<std::size_t>(texels, 1) * sizeof(glm::vec4);
    const VkDeviceSize cell_bytes = std::max<std::size_t>(cells, 2) * sizeof(std::uint32_t);
    const VkDeviceSize probe_bytes =
        sizeof(gpu::TransportProbeGrid) + 6 * std::max<std::size_t>(probes, 1) * sizeof(glm::vec4);
    PENUMBRA_TRY(gpu.ensure_host_buffer(patches_, patch_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    PENUMBRA_TRY(gpu.ensure_host_buffer(texels_, texel_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    PENUMBRA_TRY(gpu.ensure_host_buffer(cells_, cell_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    PENUMBRA_TRY(gpu.ensure_host_buffer(probes_, probe_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT));
    std::memset(patches_.mapped, 0, patch_bytes);
    std::memset(texels_.mapped, 0, texel_bytes);
    std::memset(cells_.mapped, 0, cell_bytes);
    std::memset(probes_.mapped, 0, probe_bytes);
    const VkDescriptorBufferInfo infos[4] = {{patches_.buffer, 0, patch_bytes},
                                             {texels_.buffer, 0, texel_bytes},
                                             {cells_.buffer, 0, cell_bytes},
                                             {probes_.buffer, 0, probe_bytes}};
    const std::uint32_t bindings[4] = {PENUMBRA_TRANSPORT_BINDING_PATCHES, PENUMBRA_TRANSPORT_BINDING_TEXELS,
                                       PENUMBRA_TRANSPORT_BINDING_CELLS, PENUMBRA_TRANSPORT_BINDING_PROBES};
    VkWriteDescriptorSet writes[4];
    for (int i = 0; i < 4; ++i) {
      writes[i] = vk_struct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
      writes[i].dstSet = passes_.set();
      writes[i].dstBinding = bindings[i];
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(gpu.device(), 4, writes, 0, nullptr);
    bound_ = 0.0f;
    return {};
  }

  ScreenPasses passes_;  // the ambient pass and the views
  vk::Buffer patches_, texels_, cells_, probes_;
  std::shared_ptr<const TransportData> data_;
  std::vector<glm::vec3> shown_;  // what texels_ holds
  std::uint64_t updated_tick_ = 0;
  float bound_ = 0.0f;
  std::uint64_t texels_uploaded_ = 0;
};

}  // namespace

std::unique_ptr<RenderFeature> make_indirect_transport_render_feature() {
  return std::make_unique<IndirectTransportRenderFeature>();
}

}  // namespace penumbra
