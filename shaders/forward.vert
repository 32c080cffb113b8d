#version 450
// Forward pass, vertex stage: GPU skinning, world position and normal, per-vertex AO. The depth
// pre-pass runs this same module (without a fragment stage), so both depths are equal bit for bit.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in uvec4 in_joints;
layout(location = 4) in vec4 in_weights;
layout(location = 5) in float in_ao;  // VertexAO (baked or evaluated per frame); 1 when the entity has none

layout(location = 0) out vec3 out_world;
layout(location = 1) out vec3 out_normal;
layout(location = 2) out vec2 out_uv;
layout(location = 3) out float out_ao;

void main() {
  mat4 object_to_world = push.model * skin_matrix(in_joints, in_weights);
  vec4 world = object_to_world * vec4(in_position, 1.0);
  out_world = world.xyz;
  out_normal = transpose(inverse(mat3(object_to_world))) * in_normal;
  out_uv = in_uv;
  out_ao = in_ao;
  gl_Position = frame.view_proj * world;
}
