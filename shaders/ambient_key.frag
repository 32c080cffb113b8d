#version 450
// The ambient image's first pass, fragment stage: per sample (RenderSettings::ambient_step) its
// surface key (the G-buffer normal, 1 / clip w) for the forward pass's upsampling
// (forward.frag, ambient_at_pixel), its depth, against which the features' passes test, and the
// image's start: no irradiance, open fraction 1. The render features then add their irradiance
// (sources) and multiply their open fraction (occluders) into it (render/feature.h).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

layout(location = 0) out vec4 out_ambient;
layout(location = 1) out vec4 out_key;

void main() {
  ivec2 pixel = ambient_sample_pixel(ivec2(gl_FragCoord.xy));
  float depth = texelFetch(scene_depth, pixel, 0).r;
  gl_FragDepth = depth;
  vec3 n = texelFetch(gbuffer, pixel, 0).xyz;
  vec3 x = world_at_pixel(pixel, depth);
  float w = dot(vec4(frame.view_proj[0][3], frame.view_proj[1][3], frame.view_proj[2][3], frame.view_proj[3][3]),
                vec4(x, 1.0));
  out_key = depth < 1.0 ? vec4(n, 1.0 / w) : vec4(0.0);  // the sky matches no surface
  out_ambient = vec4(0.0, 0.0, 0.0, 1.0);
}
