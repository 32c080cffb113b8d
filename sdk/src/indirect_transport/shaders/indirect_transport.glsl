// The indirect lightmap's lookup (indirect_transport_layout.h), the GLSL twin of
// sample_indirect_irradiance (indirect_transport.h). Included after common.glsl.
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

vec3 transport_irradiance(vec3 x, vec3 n) {
  int i = transport_patch(x, n);
  if (i < 0) return vec3(0.0);
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
