#version 450
// The probe grid's debug views, fragment stage, over the whole target from the pre-pass depth and
// G-buffer: "validity", the blended grids' interpolated validity from red (0) to green (1), blue
// without a grid; "irradiance", E(x, n) in W/m^2, exposed and tone mapped (linear in a float
// target), black without a grid. The sky stays black.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "output.glsl"
#include "probe_grid.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

// 0: validity, 1: irradiance (ProbeGridRenderFeature's views, in order).
layout(constant_id = 1) const uint kView = 0u;

layout(location = 0) out vec4 out_color;

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  float depth = texelFetch(scene_depth, pixel, 0).r;
  if (depth >= 1.0) {
    out_color = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  vec4 g = texelFetch(gbuffer, pixel, 0);
  vec3 n = normalize(g.xyz);
  bool on_static = gbuffer_on_static(g);
  vec3 x = world_at_pixel(pixel, depth);
  if (kView == 0u) {
    float v = kGrids > 0u ? probe_validity(x, n, on_static) : 0.0;
    out_color = output_colour(kGrids > 0u ? vec3(1.0 - v, v, 0.0) : vec3(0.0, 0.0, 1.0), false);
  } else {
    out_color = output_colour(kGrids > 0u ? probe_irradiance(x, n, on_static) : vec3(0.0), true);
  }
}
