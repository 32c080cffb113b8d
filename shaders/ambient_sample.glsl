// The ambient image's sample (render/feature.h), for the passes that start it: the renderer's key
// pass and every render feature's source pass, which therefore need no pass of their own before
// them. ambient_sample() reads the pre-pass depth and G-buffer at the full-resolution pixel the
// sample stands for (RenderSettings::ambient_step), writes the sample's depth, against which the
// occluders' passes test, and its surface key (the normal, 1 / clip w) for the forward pass's
// upsampling (forward.frag, ambient_at_pixel); every such pass writes the same values. Included
// after common.glsl.

layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;

layout(location = 1) out vec4 out_key;

// The sample's world point x, unit shading normal n and whether it lies on the level's static
// geometry (on_static); false on the sky (no surface).
bool ambient_sample(out vec3 x, out vec3 n, out bool on_static) {
  ivec2 pixel = ambient_sample_pixel(ivec2(gl_FragCoord.xy));
  float depth = texelFetch(scene_depth, pixel, 0).r;
  gl_FragDepth = depth;
  vec4 g = texelFetch(gbuffer, pixel, 0);
  n = g.xyz;
  on_static = gbuffer_on_static(g);
  x = world_at_pixel(pixel, depth);
  float w = dot(vec4(frame.view_proj[0][3], frame.view_proj[1][3], frame.view_proj[2][3], frame.view_proj[3][3]),
                vec4(x, 1.0));
  bool surface = depth < 1.0;
  out_key = surface ? vec4(n, 1.0 / w) : vec4(0.0);  // the sky matches no surface
  if (surface) n = normalize(n);
  return surface;
}

bool ambient_sample(out vec3 x, out vec3 n) {
  bool on_static;
  return ambient_sample(x, n, on_static);
}
