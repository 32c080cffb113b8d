#version 450
// Shadow pass: depth only, from the light's view of shadow layer push.draw.z (skinned like the
// forward pass so characters cast their posed shadow).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 3) in uvec4 in_joints;
layout(location = 4) in vec4 in_weights;

void main() {
  vec4 world = push.model * skin_matrix(in_joints, in_weights) * vec4(in_position, 1.0);
  gl_Position = shadow_matrices[push.draw.z] * world;
}
