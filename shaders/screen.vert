#version 450
// Screen passes, vertex stage: one triangle over the whole viewport (the ambient image's passes,
// the render features' full-screen passes and views), without a vertex buffer.
void main() {
  vec2 uv = vec2(float((gl_VertexIndex << 1) & 2), float(gl_VertexIndex & 2));
  gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
