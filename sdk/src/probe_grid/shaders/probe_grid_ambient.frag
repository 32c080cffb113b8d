#version 450
// The probe grid's ambient pass, fragment stage (a source, render/feature.h): the blended grids'
// irradiance at the receiver of one sample of the ambient image (ambient_sample.glsl: the world
// point from the pre-pass depth, the shading normal and whether it is static geometry from the
// G-buffer; it also writes the sample's depth and key), times frame.ambient_scale.x so that half
// floats hold it, with an open fraction of 1: written as it is by the first source, added to the
// image's rgb (a kept) by the blend state of a later one.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "ambient_sample.glsl"
#include "probe_grid.glsl"

layout(location = 0) out vec4 out_ambient;

void main() {
  vec3 x, n;
  bool on_static;
  vec3 e = ambient_sample(x, n, on_static) ? probe_irradiance(x, n, on_static) : vec3(0.0);
  out_ambient = vec4(e * frame.ambient_scale.x, 1.0);
}
