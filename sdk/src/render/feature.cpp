// The fixed-function state of a render feature's pass (RenderContext::pipeline), and the
// screen-wide passes of a source feature (ScreenPasses, feature.h).
#include "feature_pipeline.h"

#include <iterator>
#include <string>

#include "penumbra/render/vk_util.h"

namespace penumbra {

using vk::vk_struct;

Result<VkPipeline> make_feature_pipeline(VkDevice device, const FeaturePipeline& p, VkFormat ambient_format,
                                         VkFormat ambient_depth_format) {
  VkPipelineShaderStageCreateInfo stages[2];
  for (auto& s : stages) {
    s = vk_struct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    s.pName = "main";
    s.pSpecializationInfo = p.specialization;
  }
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = p.vertex;
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = p.fragment;
  auto vertex_input = vk_struct<VkPipelineVertexInputStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  auto assembly = vk_struct<VkPipelineInputAssemblyStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  auto viewport = vk_struct<VkPipelineViewportStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  auto raster = vk_struct<VkPipelineRasterizationStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = p.cull;
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.depthClampEnable = p.depth_clamp ? VK_TRUE : VK_FALSE;
  raster.lineWidth = 1.0f;
  auto multisample = vk_struct<VkPipelineMultisampleStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth_stencil = p.depth_stencil;
  depth_stencil.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depth_stencil.pNext = nullptr;
  const bool source = p.ambient && p.role == AmbientRole::Source;
  if (!p.ambient) depth_stencil = vk_struct<VkPipelineDepthStencilStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  if (source) {  // ambient_sample() writes each sample's depth
    depth_stencil = vk_struct<VkPipelineDepthStencilStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
    depth_stencil.depthTestEnable = VK_TRUE;
    depth_stencil.depthWriteEnable = VK_TRUE;
    depth_stencil.depthCompareOp = VK_COMPARE_OP_ALWAYS;
  }

  // The blend: the first source writes, a later one adds to rgb (alpha kept), both write the key
  // (attachment 1, the same values from every source); an occluder multiplies every channel and
  // leaves the key; a view writes.
  VkPipelineColorBlendAttachmentState attachments[2] = {};
  VkPipelineColorBlendAttachmentState& colour = attachments[0];
  const VkColorComponentFlags rgba =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  colour.colorWriteMask = p.colour_writes ? rgba : 0;
  if (p.ambient && p.colour_writes) {
    colour.blendEnable = VK_TRUE;
    colour.colorBlendOp = colour.alphaBlendOp = VK_BLEND_OP_ADD;
    if (p.role == AmbientRole::Source && !p.accumulate) {
      colour.blendEnable = VK_FALSE;  // the first source writes the sample (rgb, a = 1) as it is
    } else if (p.role == AmbientRole::Source) {
      colour.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT;
      colour.srcColorBlendFactor = colour.dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
      colour.srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
      colour.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    } else {
      colour.srcColorBlendFactor = VK_BLEND_FACTOR_DST_COLOR;
      colour.srcAlphaBlendFactor = VK_BLEND_FACTOR_DST_ALPHA;
      colour.dstColorBlendFactor = colour.dstAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
    }
  }
  if (source) attachments[1].colorWriteMask = rgba;
  auto blend = vk_struct<VkPipelineColorBlendStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  blend.attachmentCount = p.ambient ? 2 : 1;
  blend.pAttachments = attachments;
  const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  auto dynamic = vk_struct<VkPipelineDynamicStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dynamic.dynamicStateCount = static_cast<std::uint32_t>(std::size(dynamic_states));
  dynamic.pDynamicStates = dynamic_states;
  const VkFormat formats[2] = {p.ambient ? ambient_format : p.target_format, ambient_format};
  auto rendering = vk_struct<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  rendering.colorAttachmentCount = p.ambient ? 2 : 1;
  rendering.pColorAttachmentFormats = formats;
  rendering.depthAttachmentFormat = p.ambient ? ambient_depth_format : VK_FORMAT_UNDEFINED;
  rendering.stencilAttachmentFormat = p.ambient ? ambient_depth_format : VK_FORMAT_UNDEFINED;

  auto info = vk_struct<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
  info.pNext = &rendering;
  info.stageCount = p.fragment ? 2 : 1;
  info.pStages = stages;
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth_stencil;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = p.layout;
  VkPipeline made = VK_NULL_HANDLE;
  if (VkResult r = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &made); r != VK_SUCCESS) {
    return make_error(ErrorCode::Unsupported,
                      std::string("render feature: cannot create a pipeline (") + vk_result_name(r) + ")");
  }
  return made;
}

Status ScreenPasses::init(RenderContext& gpu, std::span<const VkDescriptorSetLayoutBinding> bindings,
                          std::span<const std::uint32_t> ambient_shader, std::span<const std::uint32_t> view_shader) {
  auto set = gpu.feature_set(bindings);
  if (!set) return set.error();
  set_ = set->set;
  layout_ = set->layout;
  auto ambient = gpu.shader(ambient_shader);
  if (!ambient) return ambient.error();
  auto view = gpu.shader(view_shader);
  if (!view) return view.error();
  ambient_ = *ambient;
  view_ = *view;
  return {};
}

Status ScreenPasses::record_ambient(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame,
                                   std::uint32_t variant) {
  // "view" 0: the first source, which writes; 1: a later one, which adds.
  return draw(cmd, gpu, true, frame.first_source ? 0u : 1u, VK_FORMAT_UNDEFINED, variant);
}

Status ScreenPasses::record_view(VkCommandBuffer cmd, RenderContext& gpu, const FeatureFrame& frame, std::size_t view,
                                 std::uint32_t variant) {
  return draw(cmd, gpu, false, static_cast<std::uint32_t>(view), frame.target_format, variant);
}

Status ScreenPasses::draw(VkCommandBuffer cmd, RenderContext& gpu, bool ambient, std::uint32_t view, VkFormat format,
                          std::uint32_t variant) {
  const auto key = std::tuple{ambient, view, format, variant};
  auto it = pipelines_.find(key);
  if (it == pipelines_.end()) {
    const std::uint32_t constants[2] = {variant, view};
    const VkSpecializationMapEntry entries[2] = {{0, 0, 4}, {1, 4, 4}};
    const VkSpecializationInfo specialization{2, entries, sizeof constants, constants};
    FeaturePipeline p;
    p.layout = layout_;
    p.vertex = gpu.screen_vertex();
    p.fragment = ambient ? ambient_ : view_;
    p.specialization = &specialization;
    p.ambient = ambient;
    p.target_format = format;
    p.role = AmbientRole::Source;
    p.accumulate = ambient && view == 1;
    auto made = gpu.pipeline(p);
    if (!made) return made.error();
    it = pipelines_.emplace(key, *made).first;
  }
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 2, 1, &set_, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, it->second);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  return {};
}

}  // namespace penumbra
