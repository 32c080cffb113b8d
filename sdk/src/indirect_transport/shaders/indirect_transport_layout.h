// The indirect-transport render feature's GPU interface, shared by its C++
// (indirect_transport_render.cpp) and its GLSL (indirect_transport.glsl): descriptor set 2 of its
// pipelines. Only vec4 and uvec4 members, as shaders/shared/layout.h.
#ifndef PENUMBRA_INDIRECT_TRANSPORT_LAYOUT_H
#define PENUMBRA_INDIRECT_TRANSPORT_LAYOUT_H

#ifdef __cplusplus
#include "shared/layout.h"  // penumbra::gpu's vec4, uvec4
namespace penumbra::gpu {
#endif

// Set 2 bindings.
#define PENUMBRA_TRANSPORT_BINDING_PATCHES 0  // buffer TransportPatches
#define PENUMBRA_TRANSPORT_BINDING_TEXELS 1   // buffer TransportTexels
#define PENUMBRA_TRANSPORT_BINDING_CELLS 2    // buffer TransportCells: the lookup grid
#define PENUMBRA_TRANSPORT_BINDING_PROBES 3   // buffer TransportProbeBuffer: the bounce probes

// How far outside its rectangle (in its parameters) a point may be and still be a patch's: the
// seams between patches have no gap (sample_indirect_irradiance, kTransportMargin).
#define PENUMBRA_TRANSPORT_MARGIN 0.01
// A patch whose plane lies within this fraction of its tolerance of the point is taken at once:
// no other can be nearer by more than that, and the search ends (kTransportPlaneSnap).
#define PENUMBRA_TRANSPORT_PLANE_SNAP 0.01

// A patch in the lookup's terms (TransportPatch, indirect_transport.h).
struct TransportPatchGpu {
  vec4 origin;  // xyz the rectangle's corner, w its side in leaves (2^level)
  vec4 axis_u;  // xyz edge_u / |edge_u|^2 (s = dot(x - origin, axis_u)), w the first leaf's index
  vec4 axis_v;  // xyz edge_v / |edge_v|^2, w unused
  vec4 plane;   // xyz the unit normal, w the distance from the plane a point may lie and still be on it
};

// The lookup grid over the patches' bounds: cell (i, j, k) lists the patches whose rectangle,
// widened by the plane tolerance and the seam margin, reaches into it, in patch order.
struct TransportGrid {
  uvec4 size;   // xyz cells per axis, w patches
  vec4 origin;  // xyz the grid's corner
  vec4 scale;   // xyz cells per metre
};

// How far along the normal a point's bounce-probe lookup moves, in probe spacings
// (kBounceProbeOffset).
#define PENUMBRA_TRANSPORT_PROBE_OFFSET 0.5

// The bounce probes' grid (TransportProbes, indirect_transport.h), followed in its buffer by six
// vec4 per probe, towards +x, -x, +y, -y, +z, -z: rgb its irradiance that way, w its reach that
// way (-1 on a closed probe).
struct TransportProbeGrid {
  uvec4 count;  // xyz probes per axis (x fastest), w 1 when there are probes
  vec4 origin;  // xyz probe (0, 0, 0), w the spacing in metres
};

#ifdef __cplusplus
}  // namespace penumbra::gpu
#endif

#endif  // PENUMBRA_INDIRECT_TRANSPORT_LAYOUT_H
