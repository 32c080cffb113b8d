// The indirect lightmap's and the bounce probes' lookups (indirect_transport_layout.h), the GLSL
// twins of sample_indirect_irradiance, sample_bounce_probes and sample_transport_irradiance
// (indirect_transport.h). Included after common.glsl.
#include "indirect_transport_layout.h"

layout(std430, set = 2, binding = PENUMBRA_TRANSPORT_BINDING_PATCHES) readonly buffer TransportPatches {
  TransportGrid grid;
  TransportPatchGpu patches[];
} transport;
layout(std430, set = 2, binding = PENUMBRA_TRANSPORT_BINDING_CELLS) readonly buffer TransportCells {
  uint data[];  // the cells' first entries (cells + 1 offsets into data), then the patch indices
} cells;
layout(std430, set = 2, binding = PENUMBRA_TRANSPORT_BINDING_TEXELS) readonly buffer TransportTexels {
  vec4 texels[];  // rgb: indirect irradiance (W/m^2)
} lightmap;
layout(std430, set = 2, binding = PENUMBRA_TRANSPORT_BINDING_PROBES) readonly buffer TransportProbeBuffer {
  TransportProbeGrid grid;
  vec4 cubes[];  // six per probe (TransportProbeGrid)
} bounce;

// The patch holding x (its index), or -1: of the patches facing n whose rectangle, widened by
// PENUMBRA_TRANSPORT_MARGIN, contains x, the nearest to x's plane within its tolerance, or the
// first on it (PENUMBRA_TRANSPORT_PLANE_SNAP; the cells list patches in index order).
int transport_patch(vec3 x, vec3 n) {
  int best = -1;
  float best_d = 0.0;
  uvec3 size = transport.grid.size.xyz;
  if (size.x == 0u) return -1;
  vec3 g = (x - transport.grid.origin.xyz) * transport.grid.scale.xyz;
  if (any(lessThan(g, vec3(0.0))) || any(greaterThanEqual(g, vec3(size)))) return -1;
  uvec3 c = uvec3(g);
  uint cell = c.x + size.x * (c.y + size.y * c.z);
  for (uint k = cells.data[cell]; k < cells.data[cell + 1u]; ++k) {
    uint i = cells.data[k];
    TransportPatchGpu p = transport.patches[i];
    vec3 r = x - p.origin.xyz;
    float d = abs(dot(r, p.plane.xyz));
    if (d > p.plane.w || dot(n, p.plane.xyz) < 0.5 || (best >= 0 && d >= best_d)) continue;
    float s = dot(r, p.axis_u.xyz), t = dot(r, p.axis_v.xyz);
    const float m = PENUMBRA_TRANSPORT_MARGIN;
    if (s < -m || s > 1.0 + m || t < -m || t > 1.0 + m) continue;
    best = int(i);
    best_d = d;
    if (d <= PENUMBRA_TRANSPORT_PLANE_SNAP * p.plane.w) break;  // on its plane: none is nearer
  }
  return best;
}

// Patch i's lightmap at x: its leaf texels interpolated bilinearly.
vec3 transport_lightmap(int i, vec3 x) {
  TransportPatchGpu p = transport.patches[i];
  vec3 r = x - p.origin.xyz;
  float side = p.origin.w;
  // Leaf centres at (k + 0.5) / side; clamped to the patch's own leaves.
  vec2 f = clamp(vec2(dot(r, p.axis_u.xyz), dot(r, p.axis_v.xyz)) * side - 0.5, vec2(0.0), vec2(side - 1.0));
  vec2 f0 = floor(f);
  vec2 w = f - f0;
  uint s0 = uint(f0.x), t0 = uint(f0.y), last = uint(side) - 1u;
  uint s1 = min(s0 + 1u, last), t1 = min(t0 + 1u, last);
  uint first = uint(p.axis_u.w), row = uint(side);
  vec3 a = lightmap.texels[first + s0 + t0 * row].rgb, b = lightmap.texels[first + s1 + t0 * row].rgb;
  vec3 c = lightmap.texels[first + s0 + t1 * row].rgb, d = lightmap.texels[first + s1 + t1 * row].rgb;
  return mix(mix(a, b, w.x), mix(c, d, w.x), w.y);
}

// The lightmap at x, 0 off the patches.
vec3 transport_irradiance(vec3 x, vec3 n) {
  int i = transport_patch(x, n);
  return i < 0 ? vec3(0.0) : transport_lightmap(i, x);
}

// The bounce probes at x: the open ones of the eight around x + offset n that reach it (else the
// open ones), trilinearly, each an ambient cube blended by the squares of n's components; 0 with
// none open.
vec3 transport_probe_irradiance(vec3 x, vec3 n) {
  if (bounce.grid.count.w == 0u) return vec3(0.0);
  uvec3 count = bounce.grid.count.xyz;
  float spacing = bounce.grid.origin.w;
  vec3 last = vec3(count) - 1.0;
  vec3 g = clamp((x + PENUMBRA_TRANSPORT_PROBE_OFFSET * spacing * n - bounce.grid.origin.xyz) / spacing, vec3(0.0),
                 last);
  uvec3 c0 = min(uvec3(g), uvec3(last));
  vec3 f = g - vec3(c0);
  vec3 sq = n * n;
  uvec3 neg = uvec3(lessThan(n, vec3(0.0)));
  for (int pass = 0; pass < 2; ++pass) {
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (uint corner = 0u; corner < 8u; ++corner) {
      uvec3 o = uvec3(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u);
      uvec3 c = min(c0 + o, uvec3(last));
      uint base = 6u * (c.x + count.x * (c.y + count.y * c.z));
      if (bounce.cubes[base].w < 0.0) continue;  // closed
      vec3 w3 = mix(1.0 - f, f, vec3(o));
      float w = w3.x * w3.y * w3.z;
      if (!(w > 0.0)) continue;
      if (pass == 0) {
        vec3 d = g - vec3(c);  // from the probe to the point, in spacings
        uvec3 away = uvec3(lessThan(d, vec3(0.0)));
        if (abs(d.x) > bounce.cubes[base + away.x].w || abs(d.y) > bounce.cubes[base + 2u + away.y].w ||
            abs(d.z) > bounce.cubes[base + 4u + away.z].w)
          continue;  // beyond a surface from the probe
      }
      sum += w * (sq.x * bounce.cubes[base + neg.x].rgb + sq.y * bounce.cubes[base + 2u + neg.y].rgb +
                  sq.z * bounce.cubes[base + 4u + neg.z].rgb);
      total += w;
    }
    if (total > 0.0) return sum / total;
  }
  return vec3(0.0);
}

// The bounce light the ambient pass adds: the lightmap on the patches, the probes elsewhere.
vec3 transport_bounce(vec3 x, vec3 n) {
  int i = transport_patch(x, n);
  return i < 0 ? transport_probe_irradiance(x, n) : transport_lightmap(i, x);
}
