#version 450
// The indirect transport's debug views, fragment stage, over the whole target from the pre-pass
// depth and G-buffer: "lightmap", the bounce light in W/m^2 as the ambient pass adds it (the
// lightmap on the patches, the bounce probes elsewhere), exposed and tone mapped (linear in a float
// target: what the CPU/GPU test reads); "patches", each patch in its own colour with its leaf
// texels' grid darkened, grey off the receivers; "bounce-probes", the bounce probes' irradiance
// everywhere.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "output.glsl"
#include "indirect_transport.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

// 0: lightmap, 1: patches, 2: probes (the feature's views, in order).
layout(constant_id = 1) const uint kView = 0u;  // ScreenPasses (render/feature.h)

layout(location = 0) out vec4 out_color;

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  float depth = texelFetch(scene_depth, pixel, 0).r;
  if (depth >= 1.0) {
    out_color = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  vec3 n = normalize(texelFetch(gbuffer, pixel, 0).xyz);
  vec3 x = world_at_pixel(pixel, depth);
  if (kView == 0u || kView == 2u) {
    out_color = output_colour(kView == 0u ? transport_bounce(x, n) : transport_probe_irradiance(x, n), true);
    return;
  }
  int i = transport_patch(x, n);
  if (i < 0) {
    out_color = output_colour(vec3(0.25), false);
    return;
  }
  TransportPatchGpu p = transport.patches[i];
  vec3 r = x - p.origin.xyz;
  vec2 st = vec2(dot(r, p.axis_u.xyz), dot(r, p.axis_v.xyz)) * p.origin.w;
  vec2 edge = abs(fract(st) - 0.5);
  float line = max(edge.x, edge.y) > 0.45 ? 0.55 : 1.0;
  uint h = uint(i) * 2654435761u;
  vec3 colour = 0.35 + 0.65 * vec3(float(h & 255u), float((h >> 8) & 255u), float((h >> 16) & 255u)) / 255.0;
  out_color = output_colour(colour * line, false);
}
