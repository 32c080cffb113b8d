#version 450
// AO-field pass, vertex stage: the world-space box around caster push.draw.x's reach (the sphere
// beyond which its field occludes nothing), 36 vertices without a vertex buffer, with depth clamp
// (no near or far clipping). Its front faces mark in the stencil the samples behind them; its back
// faces then shade the marked samples in front of them, those whose surface lies in the box, each
// once. With the camera inside the box (no front faces to mark) the back faces alone shade the
// samples in front of them.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ao_field.glsl"

// The 12 outward triangles (counter-clockwise seen from outside) over corners
// c = (i & 1, i >> 1 & 1, i >> 2 & 1) * 2 - 1.
const int kBoxCorners[36] = int[36](0, 4, 6, 0, 6, 2,  1, 3, 7, 1, 7, 5,  0, 1, 5, 0, 5, 4,
                                    2, 6, 7, 2, 7, 3,  0, 2, 3, 0, 3, 1,  4, 5, 7, 4, 7, 6);

void main() {
  int i = kBoxCorners[gl_VertexIndex];
  vec3 corner = vec3(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)) * 2.0 - 1.0;
  vec4 reach = ao_fields[1u + 7u * push.draw.x + 6u];  // world centre, world reach
  gl_Position = frame.view_proj * vec4(reach.xyz + reach.w * corner, 1.0);
}
