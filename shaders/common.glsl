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

// The G-buffer's w: the draw's receiver code r >= 0 (push.feature.x, DrawFeatureValues::receiver),
// stored as -(r + 1) on the level's static geometry (push.feature.z). Half floats hold both
// exactly for r up to 2047.
float gbuffer_w() {
  return push.feature.z != 0.0 ? -(push.feature.x + 1.0) : push.feature.x;
}
float gbuffer_receiver(vec4 g) {
  return g.w < 0.0 ? -g.w - 1.0 : g.w;
}
bool gbuffer_on_static(vec4 g) {
  return g.w < 0.0;
}

// The full-resolution pixel that sample q of the ambient image stands for (RenderSettings::
// ambient_step s: pixel (s q.x, s q.y), clamped to the target).
ivec2 ambient_sample_pixel(ivec2 q) {
  return min(int(frame.ambient_params.x) * q, ivec2(frame.target_size.xy) - 1);
}

// The world point at the centre of pixel p whose depth (pre-pass, Vulkan NDC: x, y in [-1, 1] from
// the top left, depth in [0, 1]) is `depth`, through the inverse view-projection.
vec3 world_at_pixel(ivec2 p, float depth) {
  vec2 ndc = (vec2(p) + 0.5) * frame.target_size.zw * 2.0 - 1.0;
  vec4 world = frame.clip_to_world * vec4(ndc, depth, 1.0);
  return world.xyz / world.w;
}
