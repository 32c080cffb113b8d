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

// The sample's world point x and unit shading normal n; false on the sky (no surface).
bool ambient_sample(out vec3 x, out vec3 n) {
  ivec2 pixel = ambient_sample_pixel(ivec2(gl_FragCoord.xy));
  float depth = texelFetch(scene_depth, pixel, 0).r;
  gl_FragDepth = depth;
  n = texelFetch(gbuffer, pixel, 0).xyz;
  x = world_at_pixel(pixel, depth);
  float w = dot(vec4(frame.view_proj[0][3], frame.view_proj[1][3], frame.view_proj[2][3], frame.view_proj[3][3]),
                vec4(x, 1.0));
  bool surface = depth < 1.0;
  out_key = surface ? vec4(n, 1.0 / w) : vec4(0.0);  // the sky matches no surface
  if (surface) n = normalize(n);
  return surface;
}
