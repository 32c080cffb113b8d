// The AO-field render feature (render/feature.h): an occluder. Per frame, each baked
// AOFieldCaster's reach box is drawn over the ambient image, and at the samples whose surface lies
// in the box (depth and stencil tests) on an AOFieldReceiver of Mode::Surface, 1 - A_i is
// multiplied in, A_i evaluated as evaluate_packed() (ao_field_gpu.h) does, skipping the drawn
// entity's own field (no self-shadow). Mode::Entity receivers take AOFieldReceiver::occlusion over
// the whole entity (DrawFeatureValues::open). Counters: "ao-field.casters" (in the pass; 0: no
// pass), "ao-field.bytes_uploaded" (by the last sync; 0 when nothing changed).
#pragma once

#include <memory>

#include "penumbra/render/feature.h"

namespace penumbra {

std::unique_ptr<RenderFeature> make_ao_field_render_feature();

}  // namespace penumbra
