// Ambient occlusion fields, per pixel: one caster's occlusion at a world point, a port of
// evaluate_packed() in sdk/include/penumbra/ao_field/ao_field_gpu.h (Kontkanen & Laine 2005,
// section 3.3; the grid of Malmer et al. 2007). Included by ao_field.vert and ao_field.frag after
// common.glsl: the AO-field pass draws each caster's reach over the pixels it can darken (a
// deferred pass, as for light volumes) and multiplies 1 - A_i into the ambient image.
#include "ao_field_layout.h"

layout(std430, set = 2, binding = PENUMBRA_AO_BINDING_FIELDS) readonly buffer AoFields { vec4 ao_fields[]; };

const float kAoFieldFourPi = 12.566370614359172;

// The cap-occlusion table lookup (cap_occlusion_table, bilinear, clamped): value q of the
// (K + 1) x (K + 1) table is component q % 4 of ao_fields[table + q / 4].
float ao_field_table_value(uint table, int q) { return ao_fields[table + uint(q) / 4u][q % 4]; }
float ao_field_table(uint table, int k, float omega, float cos_beta) {
  float n = float(k);
  float u = min(max(0.0, omega * (n / kAoFieldFourPi)), n);
  float v = min(max(0.0, (cos_beta + 1.0) * (0.5 * n)), n);
  int i = min(int(u), k - 1), j = min(int(v), k - 1);
  float fu = u - float(i), fv = v - float(j);
  int q0 = i * (k + 1) + j, q1 = q0 + k + 1;
  float v00 = ao_field_table_value(table, q0), v01 = ao_field_table_value(table, q0 + 1);
  float v10 = ao_field_table_value(table, q1), v11 = ao_field_table_value(table, q1 + 1);
  float a0 = v00 + (v01 - v00) * fv;
  float a1 = v10 + (v11 - v10) * fv;
  return a0 + (a1 - a0) * fu;
}

// Steps 1-5 of evaluate_local (ao_field.h) for the caster record at `rec`, local point x, local
// unit normal n; `grid` is the record's representation (a specialisation constant of the pass:
// llvmpipe runs both sides of a branch with masks, so a run-time test would pay for both).
float ao_field_caster(uint table, int k, uint rec, vec3 x, vec3 n, bool grid) {
  vec4 geometry = ao_fields[rec + 3u], settings = ao_fields[rec + 4u], layout_ = ao_fields[rec + 5u];
  float r_far = geometry.w, fade_scale = settings.x, a0_inside = settings.y, exponent = settings.z;
  uint size = uint(layout_.x), offset = uint(layout_.y);
  // Step 1: the point relative to the field's centre.
  vec3 p = x - geometry.xyz;
  float r = length(p);
  if (!(r < r_far)) return 0.0;
  if (r == 0.0) return a0_inside;
  vec3 w = p / r;
  float omega;
  vec3 axis;
  float r0 = 0.0;
  if (!grid) {
    // Step 2, radial fit: the cube face of p's major axis, then the bilinear texel lookup.
    // (Selects, not p[m]: a dynamically indexed vector is spilled to memory per lane on llvmpipe.)
    vec3 ap = abs(p);
    bool mx = ap.x >= ap.y && ap.x >= ap.z, my = !mx && ap.y >= ap.z;
    vec3 major_s_t = mx ? p : (my ? p.yzx : p.zxy);  // (p[m], p[(m + 1) % 3], p[(m + 2) % 3])
    float major = abs(major_s_t.x);
    float s = major_s_t.y / major, t = major_s_t.z / major;
    uint face = (mx ? 0u : (my ? 2u : 4u)) + (major_s_t.x < 0.0 ? 1u : 0u);
    float last = float(size - 1u), res = float(size);
    float u = clamp(0.5 * (s + 1.0) * res - 0.5, 0.0, last);
    float v = clamp(0.5 * (t + 1.0) * res - 0.5, 0.0, last);
    uint u0 = uint(u), v0 = uint(v);
    uint u1 = min(u0 + 1u, size - 1u), v1 = min(v0 + 1u, size - 1u);
    float fu = u - float(u0), fv = v - float(v0);
    uint base = offset + 2u * face * size * size;
    uint t00 = base + 2u * (v0 * size + u0), t01 = base + 2u * (v0 * size + u1);
    uint t10 = base + 2u * (v1 * size + u0), t11 = base + 2u * (v1 * size + u1);
    float w00 = (1.0 - fu) * (1.0 - fv), w01 = fu * (1.0 - fv), w10 = (1.0 - fu) * fv, w11 = fu * fv;
    vec4 abc_r0 = w00 * ao_fields[t00] + w01 * ao_fields[t01] + w10 * ao_fields[t10] + w11 * ao_fields[t11];
    vec4 c0 = w00 * ao_fields[t00 + 1u] + w01 * ao_fields[t01 + 1u] + w10 * ao_fields[t10 + 1u] +
              w11 * ao_fields[t11 + 1u];
    r0 = abc_r0.w;
    float rc = max(r, r0);
    float denom = (abc_r0.x * rc + abc_r0.y) * rc + abc_r0.z;
    omega = denom > 0.0 ? min(1.0 / denom, kAoFieldFourPi) : 0.0;
    axis = c0.xyz - rc * w;
  } else {
    // Step 2, grid: per axis the inverse of the warp x = r_far u |u|, then the trilinear lookup.
    vec3 g;
    uvec3 i0;
    float last = float(size - 1u);
    for (int a = 0; a < 3; ++a) {
      float ua = sign(p[a]) * sqrt(abs(p[a]) / r_far);
      float ga = clamp((ua + 1.0) * 0.5 * last, 0.0, last);
      i0[a] = min(uint(ga), size - 2u);
      g[a] = ga - float(i0[a]);
    }
    vec4 sum = vec4(0.0);
    for (uint c = 0u; c < 8u; ++c) {
      uint cx = c & 1u, cy = (c >> 1u) & 1u, cz = c >> 2u;
      float weight = (cx != 0u ? g.x : 1.0 - g.x) * (cy != 0u ? g.y : 1.0 - g.y) * (cz != 0u ? g.z : 1.0 - g.z);
      sum += weight * ao_fields[offset + ((i0.z + cz) * size + i0.y + cy) * size + i0.x + cx];
    }
    omega = sum.x;
    axis = sum.yzw;
  }
  float len = length(axis);
  float cos_beta = len > 0.0 ? dot(n, axis) / len : -dot(n, w);
  // Step 3: the cap's occlusion of the cosine-weighted hemisphere.
  float a = ao_field_table(table, k, omega, cos_beta);
  // Step 4: radial fit inside the hull, the blend towards the inside occlusion.
  if (!grid && r < r0) a = a0_inside + (a - a0_inside) * pow(r / r0, exponent);
  // Step 5: the fade to the falloff distance.
  return clamp(a * min((r_far - r) * fade_scale, 1.0), 0.0, 1.0);
}

// Caster `caster`'s occlusion A_i at world point x with unit world normal n: 0 beyond its world
// reach; `grid` as ao_field_caster.
float ao_field_occlusion(uint caster, vec3 x, vec3 n, bool grid) {
  vec4 header = ao_fields[0];
  uint table = uint(header.y);
  int k = int(header.z) - 1;
  uint rec = 1u + 7u * caster;
  vec4 reach = ao_fields[rec + 6u];
  if (!(distance(x, reach.xyz) < reach.w)) return 0.0;
  vec4 h = vec4(x, 1.0);
  vec4 row0 = ao_fields[rec], row1 = ao_fields[rec + 1u], row2 = ao_fields[rec + 2u];
  vec3 xl = vec3(dot(row0, h), dot(row1, h), dot(row2, h));
  vec3 nl = vec3(dot(row0.xyz, n), dot(row1.xyz, n), dot(row2.xyz, n));
  float len = length(nl);
  if (!(len > 0.0)) return 0.0;
  return ao_field_caster(table, k, rec, xl, nl / len, grid);
}
