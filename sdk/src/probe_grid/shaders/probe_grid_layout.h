// The probe-grid render feature's GPU interface, shared by its C++ (probe_grid_render.cpp) and its
// GLSL (probe_grid.glsl): descriptor set 2 of its pipelines. Only vec4, uvec4 and mat4 members, as
// shaders/shared/layout.h.
#ifndef PENUMBRA_PROBE_GRID_LAYOUT_H
#define PENUMBRA_PROBE_GRID_LAYOUT_H

#ifdef __cplusplus
#include "shared/layout.h"  // penumbra::gpu's vec4, uvec4, mat4
namespace penumbra::gpu {
#endif

// Set 2 bindings.
#define PENUMBRA_PROBE_BINDING_GRIDS 0     // uniform ProbeGrids
#define PENUMBRA_PROBE_BINDING_SH 1        // sampler3D[PENUMBRA_PROBE_TEXTURES]: the grids' atlas
#define PENUMBRA_PROBE_BINDING_NODES 2     // sampler3D: validity (r), reach (g, b), the same atlas

// L2 SH: 27 slots in 7 RGBA textures (pack_probe_grid_textures).
#define PENUMBRA_PROBE_TEXTURES 7
// The grids blended per pixel at most (the highest priorities; more are logged and left out).
#define PENUMBRA_PROBE_MAX_GRIDS 4
// The leak guard's lookup constants (probe_grid.h kProbeNormalBias, kProbeStaticNormalBias,
// kProbeReachSlack, kProbePlaneSlack, kProbeSolidValidity; checked at compile time in
// probe_grid_render.cpp).
#define PENUMBRA_PROBE_NORMAL_BIAS 0.01
#define PENUMBRA_PROBE_STATIC_NORMAL_BIAS 0.1
#define PENUMBRA_PROBE_REACH_SLACK (1.0 / 255.0)
#define PENUMBRA_PROBE_PLANE_SLACK 0.15
#define PENUMBRA_PROBE_SOLID_VALIDITY 0.4

// One grid in the atlas: its nodes are texels [0, resolution) + (0, 0, atlas_z) of every atlas
// texture (grids stacked along z; the lookup never filters across a grid's last texel centre).
struct ProbeGridGpu {
  mat4 world_to_grid;  // world -> [0, 1]^3 of the grid
  vec4 resolution;     // xyz nodes per axis, w the blend distance (m)
  vec4 size;           // xyz the box's size (m): spacing x (resolution - 1); w its atlas_z
  uvec4 params;        // x SH bands (2 = L1, 3 = L2), y 1 with the leak guard's reach, zw unused
};

struct ProbeGrids {
  ProbeGridGpu grids[PENUMBRA_PROBE_MAX_GRIDS];  // by descending priority, then entity index
  vec4 atlas;                                    // xyz the atlas textures' size in texels
};

#ifdef __cplusplus
}  // namespace penumbra::gpu
#endif

#endif  // PENUMBRA_PROBE_GRID_LAYOUT_H
