#version 450
// Depth pre-pass with the ambient image or a feature's view, fragment stage: the G-buffer, the
// shading normal as the forward pass computes it, the draw's receiver code and whether it is static
// geometry (common.glsl gbuffer_w).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// forward.vert's outputs (all declared: the interfaces match), of which only the normal is read.
layout(location = 0) in vec3 in_world;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in float in_ao;

layout(location = 0) out vec4 out_gbuffer;

void main() {
  vec3 n = normalize(in_normal);
  if (!gl_FrontFacing) n = -n;  // the side the camera sees, as forward.frag
  out_gbuffer = vec4(n, gbuffer_w());
}
