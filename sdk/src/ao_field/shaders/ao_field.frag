#version 450
// AO-field pass, fragment stage: caster push.draw.x's occlusion A_i at the receiver of one
// sample of the ambient image (RenderSettings::ambient_step; the world point from the pre-pass
// depth, the normal from the G-buffer), written as 1 - A_i in every channel, which the blend
// state multiplies in: the image's irradiance (rgb) and open fraction (a) take the factor
// 1 - A = prod (1 - A_i) over the casters (Kontkanen & Laine 2005; ao_field_gpu.h). Samples off
// receivers, on the caster itself (no self-shadow) and beyond its reach keep their value. The
// forward pass upsamples the image (forward.frag, ambient_at_pixel).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ao_field.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

// The caster's representation: its pipeline is chosen per caster.
layout(constant_id = 0) const bool kGrid = false;

layout(location = 0) out vec4 out_factor;

void main() {
  ivec2 pixel = ambient_sample_pixel(ivec2(gl_FragCoord.xy));
  vec4 g = texelFetch(gbuffer, pixel, 0);
  float depth = texelFetch(scene_depth, pixel, 0).r;
  uint caster = push.draw.x;
  vec3 x = world_at_pixel(pixel, depth);
  vec4 reach = ao_fields[1u + 7u * caster + 6u];
  // Receiver code: 0 not a receiver, else 2 + the pixel's own caster record (ao_field_layout.h).
  // (No discard: it would turn llvmpipe's early depth and stencil tests, which cull the box's
  // samples, into late ones.)
  float code = gbuffer_receiver(g);
  if (code < 1.0 || depth >= 1.0 || int(code) - 2 == int(caster) || !(distance(x, reach.xyz) < reach.w)) {
    out_factor = vec4(1.0);
    return;
  }
  out_factor = vec4(1.0 - ao_field_occlusion(caster, x, normalize(g.xyz), kGrid));
}
