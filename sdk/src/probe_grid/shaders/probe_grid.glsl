// The probe grids per pixel (Kontkanen & Laine 2006; the thesis section 3.2): trilinear SH from the
// atlas of probe_grid.h's GPU layout, evaluated as core/sh.h, with the leak guard, blended over
// the grids as probe_grid_weights() (probe_grid_system.h). Included by probe_grid_ambient.frag
// and probe_grid_view.frag after common.glsl.
#include "probe_grid_layout.h"

layout(std140, set = 2, binding = PENUMBRA_PROBE_BINDING_GRIDS) uniform ProbeGridBlock { ProbeGrids probe; };
layout(set = 2, binding = PENUMBRA_PROBE_BINDING_SH) uniform sampler3D probe_sh[PENUMBRA_PROBE_TEXTURES];
layout(set = 2, binding = PENUMBRA_PROBE_BINDING_NODES) uniform sampler3D probe_nodes;

// The grids bound (0 .. PENUMBRA_PROBE_MAX_GRIDS): the loops over them unroll.
layout(constant_id = 0) const uint kGrids = 1u;

// Grid g's atlas texture coordinate at p on a surface with normal n (probe_grid.h: node centres
// at texel centres), on the level's static geometry when on_static. With the leak guard's reach,
// the trilinear lookup moves to the weighted mean of the cell corners that no surface hides from p,
// that are not inside a solid and, on static geometry, that are not in the solid under p's surface
// (probe_lookup_fraction in probe_grid.cpp).
vec3 probe_uvw(uint g, vec3 p, vec3 n, bool on_static) {
  ProbeGridGpu grid = probe.grids[g];
  vec3 res = grid.resolution.xyz;
  vec3 origin = vec3(0.0, 0.0, grid.size.w);  // the grid's first texel in the atlas
  vec3 u = clamp((grid.world_to_grid * vec4(p, 1.0)).xyz, 0.0, 1.0) * (res - 1.0);
  if (grid.params.y != 0u) {
    vec3 base = min(floor(u), res - 2.0);
    vec3 f = u - base;
    vec3 nc = mat3(grid.world_to_grid) * n * (res - 1.0);
    float len = length(nc);
    bool solid_rule = on_static && len > 0.0;
    float bias = solid_rule ? PENUMBRA_PROBE_STATIC_NORMAL_BIAS : PENUMBRA_PROBE_NORMAL_BIAS;
    vec3 t = len > 0.0 ? f + nc * (bias / len) : f;  // towards the open side
    // The visible corners' weighted mean: by the reach alone (seen), and without the nodes inside
    // solids and, on static geometry, in the surface's own solid (front).
    float seen_sum = 0.0, front_sum = 0.0;
    vec3 seen_mean = vec3(0.0), front_mean = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
      vec3 o = vec3(float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1));
      vec3 node = texelFetch(probe_nodes, ivec3(origin + base + o), 0).rgb;
      uvec2 packed = uvec2(node.gb);
      vec3 d = t - o;
      // Reach bytes: g = +x, -x, +y; b = -y, +z, -z (pack_probe_node_texels).
      uvec3 plus = uvec3(packed.x & 255u, packed.x >> 16, (packed.y >> 8) & 255u);
      uvec3 minus = uvec3((packed.x >> 8) & 255u, packed.y & 255u, packed.y >> 16);
      vec3 r = vec3(mix(plus, minus, lessThan(d, vec3(0.0)))) * (1.0 / 255.0) + PENUMBRA_PROBE_REACH_SLACK;
      if (any(greaterThan(abs(d), r))) continue;
      vec3 w3 = mix(1.0 - f, f, o);
      float w = w3.x * w3.y * w3.z;
      seen_sum += w;
      seen_mean += w * o;
      if (node.r < PENUMBRA_PROBE_SOLID_VALIDITY) continue;
      // probe_node_inside_surface: a node in or against a solid, behind the receiver's tangent plane.
      if (solid_rule && node.r < 1.0 && dot(nc, o - f) / len < -PENUMBRA_PROBE_PLANE_SLACK) continue;
      front_sum += w;
      front_mean += w * o;
    }
    if (front_sum > 1e-6) f = front_mean / front_sum;
    else if (seen_sum > 1e-6) f = seen_mean / seen_sum;
    u = base + f;
  }
  return (origin + u + 0.5) / probe.atlas.xyz;
}

// Grid g's coverage of p (probe_grid_coverage, probe_grid_system.h): 0 outside its box; inside,
// the distance to its border over the blend distance, clamped to [1e-4, 1].
float probe_coverage(uint g, vec3 p) {
  ProbeGridGpu grid = probe.grids[g];
  vec3 u = (grid.world_to_grid * vec4(p, 1.0)).xyz;
  if (any(lessThan(u, vec3(0.0))) || any(greaterThan(u, vec3(1.0)))) return 0.0;
  vec3 border = min(u, 1.0 - u) * grid.size.xyz;
  return clamp(min(border.x, min(border.y, border.z)) / grid.resolution.w, 1e-4, 1.0);
}

// Grid g's E(p, n) = the trilinearly interpolated SH expansion evaluated at n, clamped at 0
// (evaluate() in probe_grid.cpp; basis and signs of core/sh.h).
vec3 probe_grid_irradiance(uint g, vec3 p, vec3 n, bool on_static) {
  vec3 uvw = probe_uvw(g, p, n, on_static);
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
  if (probe.grids[g].params.x == 3u) {  // L2: four more textures
    vec4 t3 = texture(probe_sh[3], uvw), t4 = texture(probe_sh[4], uvw), t5 = texture(probe_sh[5], uvw);
    vec4 t6 = texture(probe_sh[6], uvw);
    e += vec3(t3.xyz) * y[4] + vec3(t3.w, t4.xy) * y[5] + vec3(t4.zw, t5.x) * y[6] + t5.yzw * y[7] + t6.xyz * y[8];
  }
  return max(e, vec3(0.0));
}

// The blend of the grids (probe_grid_weights): by descending priority each covering grid takes its
// coverage of the weight the grids before it left, the last covering one all that is left; where
// none covers, the first grid's clamped lookup.
vec3 probe_irradiance(vec3 p, vec3 n, bool on_static) {
  if (kGrids == 1u) return probe_grid_irradiance(0u, p, n, on_static);
  vec3 sum = vec3(0.0), last = vec3(0.0);
  float left = 1.0;
  for (uint g = 0u; g < kGrids; ++g) {
    float f = probe_coverage(g, p);
    vec3 e = probe_grid_irradiance(g, p, n, on_static);
    if (g == 0u || f > 0.0) last = e;
    sum += (left * f) * e;
    left -= left * f;
  }
  return sum + left * last;
}

// The validity (0: no valid samples, 1: fully valid) the same way.
float probe_validity(vec3 p, vec3 n, bool on_static) {
  float sum = 0.0, last = 0.0, left = 1.0;
  for (uint g = 0u; g < kGrids; ++g) {
    float f = kGrids == 1u ? 1.0 : probe_coverage(g, p);
    float v = texture(probe_nodes, probe_uvw(g, p, n, on_static)).r;
    if (g == 0u || f > 0.0) last = v;
    sum += (left * f) * v;
    left -= left * f;
  }
  return sum + left * last;
}
