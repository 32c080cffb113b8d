// RenderContext::pipeline's implementation, given the ambient image's formats.
#pragma once

#include "penumbra/render/feature.h"

namespace penumbra {

Result<VkPipeline> make_feature_pipeline(VkDevice device, const FeaturePipeline& p, VkFormat ambient_format,
                                         VkFormat ambient_depth_format);

}  // namespace penumbra
