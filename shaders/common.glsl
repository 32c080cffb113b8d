// Declarations shared by the renderer's shaders: the per-frame set and the draw push constants.
#include "shared/layout.h"

layout(std140, set = 0, binding = PENUMBRA_BINDING_FRAME) uniform FrameBlock { FrameUniforms frame; };
layout(std430, set = 0, binding = PENUMBRA_BINDING_SHADOW_MATRICES) readonly buffer ShadowMatrices { mat4 shadow_matrices[]; };
layout(std430, set = 0, binding = PENUMBRA_BINDING_JOINTS) readonly buffer Joints { mat4 joints[]; };
layout(push_constant) uniform PushBlock { DrawPush push; };

// Linear blend skinning (glTF): the vertex in the mesh's frame, posed by its four joints.
mat4 skin_matrix(uvec4 joint_index, vec4 weight) {
  if (push.draw.y == 0u) return mat4(1.0);
  uint base = push.draw.x;
  return weight.x * joints[base + joint_index.x] + weight.y * joints[base + joint_index.y] +
         weight.z * joints[base + joint_index.z] + weight.w * joints[base + joint_index.w];
}
