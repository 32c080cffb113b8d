// The AO-field render feature's GPU interface, shared by its C++ (ao_field_render.cpp) and its
// GLSL (ao_field.glsl): descriptor set 2 of its pipelines and the receiver code it writes into
// the G-buffer (shaders/shared/layout.h).
#ifndef PENUMBRA_AO_FIELD_LAYOUT_H
#define PENUMBRA_AO_FIELD_LAYOUT_H

// Set 2, binding 0: storage vec4[], the ao_field_gpu.h layout (a placeholder without casters).
#define PENUMBRA_AO_BINDING_FIELDS 0

// The G-buffer's receiver code (DrawFeatureValues::receiver): 0 where the pixel takes no
// per-pixel AO-field occlusion, else 2 + the record of the drawn entity's own caster (-1: none),
// which the pass skips (no self-shadow). Half floats hold it exactly up to 2048, hence at most
// 2046 casters.
#define PENUMBRA_AO_MAX_CASTERS 2046

// Push constants (gpu::DrawPush) of the AO-field pass: draw.x the caster's record.

#endif  // PENUMBRA_AO_FIELD_LAYOUT_H
