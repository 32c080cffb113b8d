#version 450
// Forward pass, fragment stage: Lambertian shading with
//   direct light   directional / point / spot (KHR_lights_punctual, as bake/light_sampling.h) and
//                  rect lights by their exact unshadowed irradiance (the polygon formula, clipped to
//                  the horizon), each with a PCF-filtered shadow map (a rect's is a cube from its
//                  centre, at 16 taps filtered over the penumbra the rect casts: percentage-closer
//                  soft shadows);
//   indirect light the ambient image's irradiance times its open fraction (what the render
//                  features' sources and occluders drew into it before this pass;
//                  render/feature.h), upsampled; times the draw's entity-wide open fraction and
//                  the per-vertex AO attribute (VertexAO);
//   emission       the material's emitted radiance;
// then exposure, the ACES filmic fit of Narkowicz (2015) and, for UNORM targets, the sRGB transfer
// (output.glsl).
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "output.glsl"

layout(std430, set = 0, binding = PENUMBRA_BINDING_LIGHTS) readonly buffer Lights { GpuLight lights[]; };
layout(set = 0, binding = PENUMBRA_BINDING_SHADOW_MAP) uniform sampler2DArrayShadow shadow_map;
layout(set = 0, binding = PENUMBRA_BINDING_SHADOW_DEPTH) uniform sampler2DArray shadow_depth;
layout(set = 0, binding = PENUMBRA_BINDING_AMBIENT) uniform sampler2D ambient_image;
layout(set = 0, binding = PENUMBRA_BINDING_AMBIENT_KEY) uniform sampler2D ambient_key;
layout(set = 1, binding = PENUMBRA_BINDING_BASE_COLOR) uniform sampler2D base_color_texture;

layout(location = 0) in vec3 in_world;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in float in_ao;

layout(location = 0) out vec4 out_color;

// The debug view is a specialisation constant (one pipeline per view): llvmpipe runs shaders as
// SIMD with masks, so a run-time switch would pay for every view's code on every pixel.
layout(constant_id = 0) const uint kView = PENUMBRA_VIEW_LIT;
// The ambient image was drawn (an active render feature and a view that shows it): else its code
// is compiled out.
layout(constant_id = 1) const bool kAmbient = false;
// Shadow-map taps per light (RenderSettings::shadow_taps; 0: no shadows this frame, compiled out;
// 16: rect lights by percentage-closer soft shadows, the others as 4).
layout(constant_id = 2) const uint kShadowTaps = 4u;
// The light count when the renderer fixes it (up to PENUMBRA_UNROLLED_LIGHTS): the loop over the
// lights is unrolled and every light's data is read at a constant offset, which llvmpipe loads
// once per draw instead of per pixel; 0: the count is frame.params.y.
layout(constant_id = 3) const uint kLightCount = 0u;
// Some light is a rect: else the polygon irradiance is compiled out (llvmpipe would run it masked
// for every light of every pixel).
layout(constant_id = 4) const bool kRectLights = false;

const float kPi = 3.14159265358979323846;

// PCF with the hardware 2x2 comparison filter: at kShadowTaps 4 four taps at (+-0.5, +-0.5)
// texels, a tent over 3x3 texels (the footprint of nine taps on texel centres at under half the
// cost on llvmpipe, where every filtered tap is software); at 1 one tap, bilinear over 2x2 texels.
// The lit fraction at world point p.
float shadow_factor(uint layer, vec3 p) {
  vec4 clip = shadow_matrices[layer] * vec4(p, 1.0);
  if (clip.w <= 0.0) return 1.0;
  vec3 ndc = clip.xyz / clip.w;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  float depth = ndc.z - frame.shadow_params.y;
  if (kShadowTaps == 1u) return texture(shadow_map, vec4(uv, float(layer), depth));
  float texel = frame.shadow_params.x;
  float h = 0.5 * texel;
  float lit = texture(shadow_map, vec4(uv + vec2(-h, -h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(h, -h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(-h, h), float(layer), depth)) +
              texture(shadow_map, vec4(uv + vec2(h, h), float(layer), depth));
  return 0.25 * lit;
}

// The widest penumbra and blocker search, in shadow-map uv (a cube face spans 0..1).
const float kMaxPenumbra = 0.08;

// Shadow-map uv and depth of world point p in layer `layer`.
vec3 shadow_uv_depth(uint layer, vec3 p) {
  vec4 clip = shadow_matrices[layer] * vec4(p, 1.0);
  return vec3(clip.xy / clip.w * 0.5 + 0.5, clip.z / clip.w);
}

// A rect light's lit fraction at world point p (normal-offset), by percentage-closer soft shadows
// (Fernando 2005) on its shadow cube from the centre. A face maps tangent t to uv 0.5 + 0.5 t, so
// a blocker at depth z_b hides part of a light of half-extent L (along a face axis) from a
// receiver at depth z_r within k (z_r / z_b - 1) of its uv, k = L / (2 z_r) (similar triangles),
// per axis: L is the rect's half-extent along the face's right and up axes (hx, hy its half-size
// vectors), so a rect seen edge-on casts sharp edges that way. The blocker search covers blockers
// down to a third of z_r (5x5 depth taps over +-2k, one at uv) and keeps those that can hide part
// of the light (within that distance of uv: a wall beside p is no blocker of it); their mean
// depth gives the penumbra, over which 4x4 comparison taps (each the hardware's 2x2 filter)
// average. Each tap compares against the depth of the receiver's plane (through p, normal n) at
// its own uv, not p's (receiver plane depth bias, Isidoro 2006), less the plane's depth change
// over a texel, so a wide kernel does not shadow the receiver by itself. No blocker: lit. emit:
// the direction the rect's light travels; near / far: the cube's planes, which linearise the
// stored depths.
float rect_shadow_factor(uint layer, vec3 p, vec3 n, vec3 emit, vec3 hx, vec3 hy, float near, float far) {
  mat4 m = shadow_matrices[layer];
  vec4 clip = m * vec4(p, 1.0);
  if (clip.w <= 0.0) return 1.0;
  vec3 ndc = clip.xyz / clip.w;
  if (ndc.z > 1.0) return 1.0;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  float depth = ndc.z - frame.shadow_params.y;
  float z_r = clip.w;  // a perspective face's w is the depth along its axis
  // The plane's depth gradient in uv, from two steps along it: d(uv, depth) = [a b] c for plane
  // coordinates c, so depth(uv + o) = depth + g . o with g = [a b]^-T (a.z, b.z). Seen edge-on
  // (no gradient to take) the taps keep p's depth.
  vec3 t1 = normalize(cross(n, abs(n.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
  vec3 t2 = cross(n, t1);
  vec3 here = vec3(uv, ndc.z);
  vec3 a = shadow_uv_depth(layer, p + t1 * (1e-2 * z_r)) - here;
  vec3 b = shadow_uv_depth(layer, p + t2 * (1e-2 * z_r)) - here;
  mat2 jac = mat2(a.xy, b.xy);
  float det = determinant(jac);
  vec2 g = abs(det) > 1e-12 ? inverse(transpose(jac)) * vec2(a.z, b.z) : vec2(0.0);
  float texel = frame.shadow_params.x;
  // The map holds depths at texel centres, up to a texel from a tap's uv: the plane's depth
  // change over that is given up (slope-scaled bias).
  depth -= (abs(g.x) + abs(g.y)) * texel;
  vec3 right = vec3(m[0][0], m[1][0], m[2][0]), up = vec3(m[0][1], m[1][1], m[2][1]);
  vec2 k = vec2(abs(dot(hx, right)) + abs(dot(hy, right)), abs(dot(hx, up)) + abs(dot(hy, up))) * (0.5 / z_r);
  vec2 search = clamp(2.0 * k, vec2(texel), vec2(kMaxPenumbra));
  // The face sees direction forward + t.x right + t.y up at uv = 0.5 + 0.5 t (the rows of its
  // matrix); a tap whose direction leaves the rect's lit side (emit) sees what lies behind the
  // light (the ceiling it hangs from): no blocker there, and lit.
  float e_right = dot(right, emit);
  float e_up = dot(up, emit);
  float e_forward = dot(vec3(m[0][3], m[1][3], m[2][3]), emit);
  float blockers = 0.0, z_sum = 0.0;
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 5; ++i) {
      vec2 o = (vec2(i, j) - 2.0) * (search / 2.0);
      vec2 t = 2.0 * (uv + o) - 1.0;
      if (e_forward + t.x * e_right + t.y * e_up <= 0.0) continue;
      float d = texture(shadow_depth, vec3(uv + o, float(layer))).r;
      float z = near * far / (far - d * (far - near));
      if (d < depth + dot(g, o) && all(lessThanEqual(abs(o), k * (z_r / z - 1.0)))) {
        z_sum += z;
        blockers += 1.0;
      }
    }
  }
  if (blockers == 0.0) return 1.0;
  float z_b = z_sum / blockers;
  vec2 penumbra = clamp(k * (z_r / z_b - 1.0), vec2(0.5 * texel), vec2(kMaxPenumbra));
  float lit = 0.0;
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) {
      vec2 o = (vec2(i, j) - 1.5) * (penumbra / 1.5);
      vec2 t = 2.0 * (uv + o) - 1.0;
      bool behind = e_forward + t.x * e_right + t.y * e_up <= 0.0;
      lit += behind ? 1.0 : texture(shadow_map, vec4(uv + o, float(layer), depth + dot(g, o)));
    }
  }
  return lit / 16.0;
}

// The cube face of a point/rect light's six shadow layers that sees direction d (from the light).
uint cube_face(vec3 d) {
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
  if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
  return d.z > 0.0 ? 4u : 5u;
}

// Irradiance per unit radiance at p (unit normal n) from a rect of centre c and half-size vectors
// hx, hy: the exact polygon formula E / L = 1/2 sum_i angle(v_i, v_i+1) n . unit(v_i x v_i+1)
// (Lambert 1760; Baum, Rushmeier & Winget 1989), over the rect clipped to the hemisphere above p
// (Sutherland-Hodgman against the tangent plane), unshadowed.
float rect_irradiance(vec3 p, vec3 n, vec3 c, vec3 hx, vec3 hy) {
  vec3 q[4] = vec3[4](c - hx - hy - p, c + hx - hy - p, c + hx + hy - p, c - hx + hy - p);
  vec3 poly[5];
  int m = 0;
  for (int i = 0; i < 4; ++i) {
    vec3 a = q[i], b = q[(i + 1) & 3];
    float da = dot(n, a), db = dot(n, b);
    if (da > 0.0) poly[m++] = a;
    if ((da > 0.0) != (db > 0.0)) poly[m++] = a + (b - a) * (da / (da - db));
  }
  if (m < 3) return 0.0;
  float sum = 0.0;
  for (int i = 0; i < 5; ++i) {
    if (i >= m) break;
    vec3 a = normalize(poly[i]), b = normalize(poly[i + 1 < m ? i + 1 : 0]);
    vec3 x = cross(a, b);
    float s = length(x);
    if (s > 1e-9) sum += atan(s, dot(a, b)) * dot(n, x) / s;  // the edge's angle, stable when small
  }
  return 0.5 * abs(sum);
}

// Irradiance E (W/m^2 per channel) at p with unit normal n from every light, shadowed.
vec3 direct_irradiance(vec3 p, vec3 n) {
  vec3 e = vec3(0.0);
  vec3 p_offset = p + n * frame.shadow_params.z;  // normal offset against acne
  uint count = kLightCount > 0u ? kLightCount : frame.params.y;
  for (uint i = 0u; i < count; ++i) {
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
      } else if (kRectLights && type == PENUMBRA_LIGHT_RECT) {  // one-sided: nothing behind its plane
        falloff = cos_l > 0.0 ? rect_irradiance(p, n, light.position_type.xyz, light.half_x.xyz, light.half_y.xyz) : 0.0;
      }
      power *= falloff;
    }
    float cos_x = (kRectLights && type == PENUMBRA_LIGHT_RECT) ? 1.0 : dot(n, l);  // the rect's E already holds the cosine
    if (cos_x <= 0.0 || all(equal(power, vec3(0.0)))) continue;
    float visible = 1.0;
    if (kShadowTaps != 0u && light.cone_shadow.z >= 0.0) {
      uint layer = uint(light.cone_shadow.z);
      if (light.cone_shadow.w > 1.0) layer += cube_face(p - light.position_type.xyz);
      if (kRectLights && kShadowTaps == 16u && type == PENUMBRA_LIGHT_RECT) {
        visible = rect_shadow_factor(layer, p_offset, n, light.direction_range.xyz, light.half_x.xyz,
                                     light.half_y.xyz, light.half_x.w, light.half_y.w);
      } else {
        visible = shadow_factor(layer, p_offset);
      }
    }
    e += power * (cos_x * visible);
  }
  return e;
}

// The ambient image at this pixel (normal n): (irradiance x open fraction x
// ambient_scale, open fraction), upsampled from the passes' image (at step s sample (i, j) stands
// for pixel (s i, s j)): the bilinear weights of the four nearest samples, restricted to samples
// on this pixel's surface (their 1 / clip w, which is linear in screen space on a plane, within
// 2 % of this pixel's plane, and normals within 25 degrees: the ambient key), so that a crate's
// edge does not bleed into the ground nor light leak across a wall; where none of them
// is, any of the four on the surface, else this pixel's own block. A pixel whose coordinates are
// multiples of s (every pixel at step 1) reads its own sample unchanged.
vec4 ambient_at_pixel(vec3 n) {
  int step = int(frame.ambient_params.x);
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec2 q0 = p / step;
  ivec2 last = textureSize(ambient_image, 0) - 1;
  vec2 f = vec2(p - step * q0) / float(step);
  float inv_w = gl_FragCoord.w, tolerance = 0.02 * inv_w;
  vec2 slope = vec2(dFdx(inv_w), dFdy(inv_w));
  vec4 sum = vec4(0.0), any_sum = vec4(0.0);
  float weight = 0.0, any_weight = 0.0;
  for (int c = 0; c < 4; ++c) {
    ivec2 o = ivec2(c & 1, c >> 1);
    ivec2 q = min(q0 + o, last);
    vec4 key = texelFetch(ambient_key, q, 0);
    float plane = inv_w + dot(vec2(ambient_sample_pixel(q) - p), slope);
    bool same = abs(key.w - plane) <= tolerance && dot(key.xyz, n) > 0.9;
    vec4 value = texelFetch(ambient_image, q, 0);
    float w = same ? (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y) : 0.0;
    sum += w * value;
    weight += w;
    any_sum += same ? value : vec4(0.0);
    any_weight += same ? 1.0 : 0.0;
  }
  if (weight > 0.0) return sum / weight;
  return any_weight > 0.0 ? any_sum / any_weight : texelFetch(ambient_image, q0, 0);
}

void main() {
  vec3 n = normalize(in_normal);
  if (!gl_FrontFacing) n = -n;  // shade the side the camera sees
  vec3 albedo = push.base_color.rgb * texture(base_color_texture, in_uv).rgb;
  bool has_indirect = (frame.params.z & PENUMBRA_FLAG_INDIRECT) != 0u;
  // AO: the vertex attribute, the draw's entity-wide open fraction, the ambient image's per pixel.
  // Composition (renderer.h): each occlusion counted once, so the static geometry's vertex AO,
  // which the ambient sources' bakes already shadow, stays out of their light (the AO view shows it).
  float ao = in_ao * push.feature.y;
  float ao_unseen = (push.draw.w != 0u ? 1.0 : in_ao) * push.feature.y;
  vec3 indirect = vec3(0.0);
  if (kAmbient) {
    vec4 ambient = ambient_at_pixel(n);
    if (has_indirect) indirect = ambient.rgb * (ao_unseen / frame.ambient_scale.x);
    ao *= ambient.a;
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
  } else if (view == PENUMBRA_VIEW_POSITION) {
    color = in_world;
    scene_referred = false;
  } else if (view == PENUMBRA_VIEW_NORMAL) {
    color = n;
    scene_referred = false;
  } else {
    vec3 direct = (view == PENUMBRA_VIEW_INDIRECT) ? vec3(0.0) : direct_irradiance(in_world, n);
    color = albedo / kPi * (direct + indirect);
    if (view == PENUMBRA_VIEW_LIT) color += push.emissive.rgb;
  }
  out_color = output_colour(color, scene_referred);
}
