#version 450
// Forward pass, fragment stage: Lambertian shading with
//   direct light   directional / point / spot (KHR_lights_punctual, as bake/light_sampling.h) and
//                  rect lights as Lambertian emitters of intensity L A cos(theta_l) from their centre,
//                  each with a PCF-filtered shadow map;
//   indirect light the probe grid's irradiance per pixel (Kontkanen & Laine 2006; the thesis
//                  section 3.2): trilinear SH from 3D textures, evaluated as core/sh.h;
//   AO             the per-vertex AO attribute (vertex AO, pose-AO) times, on AO-field receivers,
//                  the open fraction under the moving casters' AO fields (per pixel on surfaces,
//                  from the AO-field pass before this one: ao_field.frag; per entity on dynamic
//                  receivers);
//   emission       the material's emitted radiance;
// then exposure, the ACES filmic fit of Narkowicz (2015) and, for UNORM targets, the sRGB transfer.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(std430, set = 0, binding = PENUMBRA_BINDING_LIGHTS) readonly buffer Lights { GpuLight lights[]; };
layout(set = 0, binding = PENUMBRA_BINDING_SHADOW_MAP) uniform sampler2DArrayShadow shadow_map;
layout(set = 0, binding = PENUMBRA_BINDING_PROBE_SH) uniform sampler3D probe_sh[PENUMBRA_PROBE_TEXTURES];
layout(set = 0, binding = PENUMBRA_BINDING_PROBE_VALIDITY) uniform sampler3D probe_validity;
layout(set = 0, binding = PENUMBRA_BINDING_SCENE_DEPTH) uniform sampler2D scene_depth;
layout(set = 0, binding = PENUMBRA_BINDING_GBUFFER) uniform sampler2D gbuffer;
layout(set = 0, binding = PENUMBRA_BINDING_AO_OPEN) uniform sampler2D ao_open;
layout(set = 1, binding = PENUMBRA_BINDING_BASE_COLOR) uniform sampler2D base_color_texture;

layout(location = 0) in vec3 in_world;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in float in_ao;

layout(location = 0) out vec4 out_color;

// The debug view is a specialisation constant (one pipeline per view): llvmpipe runs shaders as
// SIMD with masks, so a run-time switch would pay for every view's code on every pixel.
layout(constant_id = 0) const uint kView = PENUMBRA_VIEW_LIT;
// The AO-field pass ran: false when the scene has no baked casters, so its code is compiled out.
layout(constant_id = 1) const bool kAoFields = false;

const float kPi = 3.14159265358979323846;

// PCF: four taps of the hardware 2x2 comparison filter at (+-0.5, +-0.5) texels, a tent over
// 3x3 texels (the same footprint as nine taps on texel centres at under half the cost on
// llvmpipe, where every filtered tap is software): the lit fraction at world point p.
float shadow_factor(uint layer, vec3 p) {
  vec4 clip = shadow_matrices[layer] * vec4(p, 1.0);
  if (clip.w <= 0.0) return 1.0;
  vec3 ndc = clip.xyz / clip.w;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  float depth = ndc.z - frame.shadow_params.y;
  float texel = frame.shadow_params.x;
  float h = 0.5 * texel;
  float lit = texture(shadow_map, vec4(uv + vec2(-h, -h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(h, -h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(-h, h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(h, h), float(layer), depth));
  return 0.25 * lit;
}

// The cube face of a point/rect light's six shadow layers that sees direction d (from the light).
uint cube_face(vec3 d) {
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
  if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
  return d.z > 0.0 ? 4u : 5u;
}

// Irradiance E (W/m^2 per channel) at p with unit normal n from every light, shadowed.
vec3 direct_irradiance(vec3 p, vec3 n) {
  vec3 e = vec3(0.0);
  bool shadows = (frame.params.z & PENUMBRA_FLAG_SHADOWS) != 0u;
  vec3 p_offset = p + n * frame.shadow_params.z;  // normal offset against acne
  for (uint i = 0u; i < frame.params.y; ++i) {
    GpuLight light = lights[i];
    uint type = uint(light.position_type.w);
    vec3 l;
    vec3 power = light.color.rgb;
    if (type == PENUMBRA_LIGHT_DIRECTIONAL) {
      l = -light.direction_range.xyz;
    } else {
      vec3 d = light.position_type.xyz - p;
      float dist2 = max(dot(d, d), 1e-12);
      float dist = sqrt(dist2);
      l = d / dist;
      float falloff = 1.0 / dist2;
      if (light.direction_range.w > 0.0) {  // KHR_lights_punctual range window
        float r = dist / light.direction_range.w;
        float w = clamp(1.0 - r * r * r * r, 0.0, 1.0);
        falloff *= w * w;
      }
      float cos_l = dot(light.direction_range.xyz, -l);
      if (type == PENUMBRA_LIGHT_SPOT) {  // squared linear ramp in cos between outer and inner
        float scale = 1.0 / max(0.001, light.cone_shadow.y - light.cone_shadow.x);
        float a = clamp((cos_l - light.cone_shadow.x) * scale, 0.0, 1.0);
        falloff *= a * a;
      } else if (type == PENUMBRA_LIGHT_RECT) {  // Lambertian emitter: I = L A cos(theta_l)
        falloff *= light.color.w * max(cos_l, 0.0);
      }
      power *= falloff;
    }
    float cos_x = dot(n, l);
    if (cos_x <= 0.0 || all(equal(power, vec3(0.0)))) continue;
    float visible = 1.0;
    if (shadows && light.cone_shadow.z >= 0.0) {
      uint layer = uint(light.cone_shadow.z);
      if (light.cone_shadow.w > 1.0) layer += cube_face(p - light.position_type.xyz);
      visible = shadow_factor(layer, p_offset);
    }
    e += power * (cos_x * visible);
  }
  return e;
}

// The probe grid's texture coordinate at p on a surface with normal n (probe_grid.h: node centres
// at texel centres). With the leak guard's reach, the trilinear lookup moves to the weighted mean
// of the cell corners that no surface hides from p (probe_lookup_fraction in probe_grid.cpp).
vec3 probe_uvw(vec3 p, vec3 n) {
  vec3 res = frame.probe_resolution.xyz;
  vec3 u = clamp((frame.probe_world_to_grid * vec4(p, 1.0)).xyz, 0.0, 1.0) * (res - 1.0);
  if ((frame.params.z & PENUMBRA_FLAG_PROBE_REACH) != 0u) {
    vec3 base = min(floor(u), res - 2.0);
    vec3 f = u - base;
    vec3 nc = mat3(frame.probe_world_to_grid) * n * (res - 1.0);
    float len = length(nc);
    vec3 t = len > 0.0 ? f + nc * (PENUMBRA_PROBE_NORMAL_BIAS / len) : f;  // towards the open side
    float wsum = 0.0;
    vec3 mean = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
      vec3 o = vec3(float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1));
      uvec2 packed = uvec2(texelFetch(probe_validity, ivec3(base + o), 0).gb);
      vec3 d = t - o;
      // Reach bytes: g = +x, -x, +y; b = -y, +z, -z (pack_probe_node_texels).
      uvec3 plus = uvec3(packed.x & 255u, packed.x >> 16, (packed.y >> 8) & 255u);
      uvec3 minus = uvec3((packed.x >> 8) & 255u, packed.y & 255u, packed.y >> 16);
      vec3 r = vec3(mix(plus, minus, lessThan(d, vec3(0.0)))) * (1.0 / 255.0) + PENUMBRA_PROBE_REACH_SLACK;
      if (any(greaterThan(abs(d), r))) continue;
      vec3 w3 = mix(1.0 - f, f, o);
      float w = w3.x * w3.y * w3.z;
      wsum += w;
      mean += w * o;
    }
    if (wsum > 1e-6) f = mean / wsum;
    u = base + f;
  }
  return (u + 0.5) / res;
}

// E(p, n) = the trilinearly interpolated SH expansion evaluated at n, clamped at 0 (evaluate() in
// probe_grid.cpp; basis and signs of core/sh.h).
vec3 probe_irradiance(vec3 p, vec3 n) {
  vec3 uvw = probe_uvw(p, n);
  // Slot s of the 27: channel s % 3 of coefficient s / 3 (constant sampler indices, no dynamic indexing).
  vec4 t0 = texture(probe_sh[0], uvw), t1 = texture(probe_sh[1], uvw), t2 = texture(probe_sh[2], uvw);
  vec3 c[4];
  c[0] = t0.xyz;
  c[1] = vec3(t0.w, t1.xy);
  c[2] = vec3(t1.zw, t2.x);
  c[3] = t2.yzw;
  const float kY0 = 0.28209479177387814, kY1 = 0.48860251190291992;
  const float kY2a = 1.09254843059207907, kY2b = 0.31539156525252005, kY2c = 0.54627421529603959;
  float y[9] = float[9](kY0, -kY1 * n.y, kY1 * n.z, -kY1 * n.x, kY2a * n.x * n.y, -kY2a * n.y * n.z,
                        kY2b * (3.0 * n.z * n.z - 1.0), -kY2a * n.x * n.z, kY2c * (n.x * n.x - n.y * n.y));
  vec3 e = c[0] * y[0] + c[1] * y[1] + c[2] * y[2] + c[3] * y[3];
  if (frame.params.w == 3u) {  // L2: four more textures
    vec4 t3 = texture(probe_sh[3], uvw), t4 = texture(probe_sh[4], uvw), t5 = texture(probe_sh[5], uvw);
    vec4 t6 = texture(probe_sh[6], uvw);
    e += vec3(t3.xyz) * y[4] + vec3(t3.w, t4.xy) * y[5] + vec3(t4.zw, t5.x) * y[6] + t5.yzw * y[7] + t6.xyz * y[8];
  }
  return max(e, vec3(0.0));
}

// The open fraction under the AO-field casters at this pixel (normal n), upsampled from the pass's
// image (ao_field.frag; at step s sample (i, j) stands for pixel (s i, s j)): the bilinear
// weights of the four nearest samples, restricted to samples on this pixel's surface (their depth
// on this pixel's plane, which is linear in screen space, within 2 % of the distance, and normals
// within 25 degrees: the pre-pass images), so that a crate's edge does not bleed into the ground;
// where none of them is, any of the four on the surface, else this pixel's own block. A pixel
// whose coordinates are multiples of s (every pixel at step 1) reads its own sample unchanged.
float ao_field_open(vec3 n) {
  int step = int(frame.ao_params.x);
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec2 q0 = p / step;
  ivec2 last = textureSize(ao_open, 0) - 1, last_pixel = ivec2(frame.target_size.xy) - 1;
  vec2 f = vec2(p - step * q0) / float(step);
  float d = gl_FragCoord.z, tolerance = 0.02 * max(1.0 - d, 1e-7);  // 1 - depth ~ near / distance
  vec2 slope = vec2(dFdx(d), dFdy(d));
  float sum = 0.0, weight = 0.0, any_sum = 0.0, any_weight = 0.0;
  for (int c = 0; c < 4; ++c) {
    ivec2 o = ivec2(c & 1, c >> 1);
    ivec2 q = min(q0 + o, last);
    ivec2 sample_pixel = min(step * q, last_pixel);
    float plane = d + dot(vec2(sample_pixel - p), slope);
    bool same = abs(texelFetch(scene_depth, sample_pixel, 0).r - plane) <= tolerance &&
                dot(texelFetch(gbuffer, sample_pixel, 0).xyz, n) > 0.9;
    float open = texelFetch(ao_open, q, 0).r;
    float w = same ? (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y) : 0.0;
    sum += w * open;
    weight += w;
    any_sum += same ? open : 0.0;
    any_weight += same ? 1.0 : 0.0;
  }
  if (weight > 0.0) return sum / weight;
  return any_weight > 0.0 ? any_sum / any_weight : texelFetch(ao_open, q0, 0).r;
}

// ACES filmic curve, Narkowicz 2015 ("ACES Filmic Tone Mapping Curve"), per channel, to [0, 1].
vec3 tone_map(vec3 x) {
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
  vec3 n = normalize(in_normal);
  if (!gl_FrontFacing) n = -n;  // shade the side the camera sees
  vec3 albedo = push.base_color.rgb * texture(base_color_texture, in_uv).rgb;
  bool has_probe = (frame.params.z & PENUMBRA_FLAG_PROBE_GRID) != 0u;
  float ao = in_ao;
  if (kAoFields) {  // the receiver's open fraction under the casters (1 on non-receivers)
    ao *= ao_field_open(n);
    if (uint(push.ao_field.x) == PENUMBRA_AO_RECEIVER_ENTITY) ao *= 1.0 - push.ao_field.y;
  }
  const uint view = kView;

  vec3 color;
  bool scene_referred = true;  // radiance to expose and tone map, or data to show as is
  if (view == PENUMBRA_VIEW_ALBEDO) {
    color = albedo;
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_AO) {
    color = vec3(ao);
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_VALIDITY) {
    // Red (no valid samples) -> green (fully valid); blue where no grid is bound.
    float v = has_probe ? texture(probe_validity, probe_uvw(in_world, n)).r : 0.0;
    color = has_probe ? vec3(1.0 - v, v, 0.0) : vec3(0.0, 0.0, 1.0);
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_POSITION) {
    color = in_world;
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_NORMAL) {
    color = n;
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_IRRADIANCE) {
    color = has_probe ? probe_irradiance(in_world, n) : vec3(0.0);
  } else {
    vec3 direct = (view == PENUMBRA_VIEW_INDIRECT) ? vec3(0.0) : direct_irradiance(in_world, n);
    vec3 indirect = (view == PENUMBRA_VIEW_DIRECT || !has_probe) ? vec3(0.0) : probe_irradiance(in_world, n) * ao;
    color = albedo / kPi * (direct + indirect);
    if (view == PENUMBRA_VIEW_LIT) color += push.emissive.rgb;
  }

  uint flags = frame.params.z;
  if ((flags & PENUMBRA_FLAG_LINEAR) == 0u) {
    if (scene_referred) color = tone_map(color * frame.camera_exposure.w);
    color = clamp(color, 0.0, 1.0);
    if ((flags & PENUMBRA_FLAG_ENCODE_SRGB) != 0u) color = srgb_encode(color);
  }
  out_color = vec4(color, 1.0);
}
