#version 450
// The indirect transport's ambient pass, fragment stage (a source, render/feature.h): the bounce
// light at the receiver of one sample of the ambient image (ambient_sample.glsl), the lightmap on
// the patches and the bounce probes elsewhere, times frame.ambient_scale.x, with an open fraction
// of 1.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ambient_sample.glsl"
#include "indirect_transport.glsl"

layout(location = 0) out vec4 out_ambient;

void main() {
  vec3 x, n;
  vec3 e = ambient_sample(x, n) ? transport_bounce(x, n) : vec3(0.0);
  out_ambient = vec4(e * frame.ambient_scale.x, 1.0);
}
