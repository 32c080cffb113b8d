#version 450
// Ambient pass, fragment stage: the probe grid's irradiance at the receiver of one sample of the
// ambient image (RenderSettings::ambient_step; the world point from the pre-pass depth, the
// shading normal from the G-buffer), times frame.ambient_scale.x so that half floats hold it, and
// an open fraction of 1 for the AO-field pass to multiply (without a grid, kProbe false: 1
// everywhere); the sample's depth, against which that pass tests its boxes; and the sample's
// surface key (normal, 1 / clip w) for the forward pass's upsampling. The forward pass
// upsamples the image (forward.frag, ambient_at_pixel): the probe lookup runs at a quarter of the
// pixels at step 2.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "probe_grid.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

layout(constant_id = 0) const bool kProbe = true;

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
  if (kProbe) {
    vec3 e = depth < 1.0 ? probe_irradiance(x, normalize(n)) : vec3(0.0);
    out_ambient = vec4(e * frame.ambient_scale.x, 1.0);
  } else {
    out_ambient = vec4(1.0);
  }
}
