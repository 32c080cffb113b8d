#version 450
// The ambient image's key pass, fragment stage, when no source pass runs (the AO view, or only
// occluders are active): each sample's depth and key (ambient_sample.glsl); the image itself
// keeps its clear value, no irradiance and open fraction 1, for the occluders to multiply.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ambient_sample.glsl"

layout(location = 0) out vec4 out_ambient;

void main() {
  vec3 x, n;
  ambient_sample(x, n);
  out_ambient = vec4(0.0, 0.0, 0.0, 1.0);
}
