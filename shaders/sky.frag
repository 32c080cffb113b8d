#version 450
// The sky pass, fragment stage: the environment map toward each pixel the scene left empty (the
// pass runs at the far plane with depth LESS_OR_EQUAL), looked up as sample_environment_map does
// (scene/environment.cpp) and exposed and tone mapped as the lit view.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "output.glsl"

layout(set = 0, binding = PENUMBRA_BINDING_SKY) uniform sampler2D sky_map;
layout(location = 0) out vec4 out_colour;

const float kPi = 3.14159265358979;

void main() {
  vec2 ndc = gl_FragCoord.xy * frame.target_size.zw * 2.0 - 1.0;
  vec4 near_point = frame.clip_to_world * vec4(ndc, 0.0, 1.0);
  vec4 far_point = frame.clip_to_world * vec4(ndc, 1.0, 1.0);
  vec3 d = normalize(far_point.xyz / far_point.w - near_point.xyz / near_point.w);
  vec2 uv = vec2(0.5 + atan(d.x, -d.z) / (2.0 * kPi), acos(clamp(d.y, -1.0, 1.0)) / kPi);
  out_colour = output_colour(textureLod(sky_map, uv, 0.0).rgb, true);
  gl_FragDepth = 1.0;
}
