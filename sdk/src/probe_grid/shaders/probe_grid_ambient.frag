#version 450
// The probe grid's ambient pass, fragment stage: the blended grids' irradiance at the receiver of
// one sample of the ambient image (RenderSettings::ambient_step; the world point from the pre-pass
// depth, the shading normal from the G-buffer), times frame.ambient_scale.x so that half floats
// hold it, added to the image's rgb by the blend state (a source: render/feature.h).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "probe_grid.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

layout(location = 0) out vec4 out_ambient;

void main() {
  ivec2 pixel = ambient_sample_pixel(ivec2(gl_FragCoord.xy));
  float depth = texelFetch(scene_depth, pixel, 0).r;
  vec3 n = texelFetch(gbuffer, pixel, 0).xyz;
  vec3 e = depth < 1.0 ? probe_irradiance(world_at_pixel(pixel, depth), normalize(n)) : vec3(0.0);
  out_ambient = vec4(e * frame.ambient_scale.x, 0.0);
}
