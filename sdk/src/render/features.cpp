// standard_render_features() and Renderer::create(Device&): every module's render feature, from
// the generated list (render_features.inc: the modules whose penumbra_lighting_module names RENDER).
#include "penumbra/render/features.h"

#include "penumbra/render/renderer.h"

namespace penumbra {

#define PENUMBRA_RENDER_FEATURE(m) std::unique_ptr<RenderFeature> make_##m##_render_feature();
#include "render_features.inc"
#undef PENUMBRA_RENDER_FEATURE

RenderFeatures standard_render_features() {
  RenderFeatures features;
#define PENUMBRA_RENDER_FEATURE(m) features.push_back(make_##m##_render_feature());
#include "render_features.inc"
#undef PENUMBRA_RENDER_FEATURE
  return features;
}

Result<std::unique_ptr<Renderer>> Renderer::create(Device& device) {
  return create(device, standard_render_features());
}

}  // namespace penumbra
