#version 450
// AO-field pass, fragment stage: caster push.draw.x's occlusion A_i at the receiver of one
// sample of the open-fraction image (at step s = frame.ao_params.x, sample (i, j) stands for
// pixel (s i, s j): the
// world point from the pre-pass depth, the normal from the G-buffer), written as 1 - A_i, which
// the blend state multiplies in: 1 - A = prod (1 - A_i) over the casters (Kontkanen & Laine 2005;
// ao_field_gpu.h). Samples off receivers, on the caster itself (no self-shadow) and beyond its
// reach keep 1. The forward pass upsamples the image (forward.frag, ao_field_open).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ao_field.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

// The caster's representation: its pipeline is chosen per caster.
layout(constant_id = 0) const bool kGrid = false;

layout(location = 0) out float out_open;

void main() {
  ivec2 pixel = min(int(frame.ao_params.x) * ivec2(gl_FragCoord.xy), ivec2(frame.target_size.xy) - 1);
  vec4 g = texelFetch(gbuffer, pixel, 0);
  float depth = texelFetch(scene_depth, pixel, 0).r;
  uint caster = push.draw.x;
  // The pixel centre back to world space through the inverse view-projection (Vulkan NDC: x, y
  // in [-1, 1] from the framebuffer's top left, depth in [0, 1]).
  vec2 ndc = (vec2(pixel) + 0.5) * frame.target_size.zw * 2.0 - 1.0;
  vec4 world = frame.clip_to_world * vec4(ndc, depth, 1.0);
  vec3 x = world.xyz / world.w;
  vec4 reach = ao_fields[1u + 7u * caster + 6u];
  // Receiver code: 0 not a receiver, else 2 + the pixel's own caster record (layout.h). Nothing
  // to multiply (1 - A_i = 1) off receivers, on the caster itself and beyond its reach.
  if (g.w < 1.0 || depth >= 1.0 || int(g.w) - 2 == int(caster) || !(distance(x, reach.xyz) < reach.w)) discard;
  out_open = 1.0 - ao_field_occlusion(caster, x, normalize(g.xyz), kGrid);
}
