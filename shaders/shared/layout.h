// The data layouts shared by the renderer (C++) and the shaders (GLSL), defined once.
//
// Included by GLSL (GL_GOOGLE_include_directive) and by sdk/src/render (C++). Only vec4, uvec4 and
// mat4 members, so std140 (uniform) and std430 (storage) layouts equal the C++ layout of glm types
// without padding rules to remember. Binding numbers are macros so both languages read them.
#ifndef PENUMBRA_SHADERS_LAYOUT_H
#define PENUMBRA_SHADERS_LAYOUT_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>
#include <glm/ext/vector_uint4.hpp>
namespace penumbra::gpu {
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#endif

// Descriptor set 0 (per frame).
#define PENUMBRA_BINDING_FRAME 0          // uniform FrameUniforms
#define PENUMBRA_BINDING_LIGHTS 1         // storage GpuLight[]
#define PENUMBRA_BINDING_SHADOW_MATRICES 2  // storage mat4[]: light clip from world, per shadow layer
#define PENUMBRA_BINDING_JOINTS 3         // storage mat4[]: every skinned draw's joint matrices
#define PENUMBRA_BINDING_SHADOW_MAP 4     // sampler2DArrayShadow: one layer per shadow view
#define PENUMBRA_BINDING_PROBE_SH 5       // sampler3D[PENUMBRA_PROBE_TEXTURES]: probe_grid.h GPU layout
#define PENUMBRA_BINDING_PROBE_VALIDITY 6 // sampler3D: validity (r), reach (g, b): pack_probe_node_texels
#define PENUMBRA_BINDING_AO_FIELDS 7      // storage vec4[]: the ao_field_gpu.h layout (a placeholder without casters)
// The ambient passes' screen images (placeholders where they do not run), all read with
// texelFetch: the pre-pass depth and G-buffer they read, the ambient image and its key they write
// for the forward pass (at 1 / RenderSettings::ambient_step of the target's size).
#define PENUMBRA_BINDING_SCENE_DEPTH 8    // sampler2D: the camera's depth (pre-pass)
#define PENUMBRA_BINDING_GBUFFER 9        // sampler2D: xyz shading normal, w receiver code (below)
#define PENUMBRA_BINDING_AMBIENT 10       // sampler2D: rgb probe irradiance x open x ambient_scale.x,
                                          // a open fraction prod (1 - A_i) over the AO-field casters
#define PENUMBRA_BINDING_AMBIENT_KEY 11   // sampler2D: per sample its surface, xyz the normal, w 1 / clip w
                                          // (linear in screen space on a plane): what the upsampling compares
// Descriptor set 1 (per material): the base colour texture (sRGB; white when the material has none).
#define PENUMBRA_BINDING_BASE_COLOR 0

// L2 SH: 27 slots in 7 RGBA textures (pack_probe_grid_textures).
#define PENUMBRA_PROBE_TEXTURES 7
// The leak guard's lookup constants (probe_grid.h kProbeNormalBias, kProbeReachSlack; the renderer
// checks at compile time that they agree).
#define PENUMBRA_PROBE_NORMAL_BIAS 0.01
#define PENUMBRA_PROBE_REACH_SLACK (1.0 / 255.0)

// Scenes with up to this many lights get a forward pipeline specialised on their count (the
// shader's kLightCount); more lights loop over frame.params.y.
#define PENUMBRA_UNROLLED_LIGHTS 8

// Light types (GpuLight.position_type.w).
#define PENUMBRA_LIGHT_DIRECTIONAL 0
#define PENUMBRA_LIGHT_POINT 1
#define PENUMBRA_LIGHT_SPOT 2
#define PENUMBRA_LIGHT_RECT 3

// FrameUniforms.flags bits.
#define PENUMBRA_FLAG_PROBE_GRID 1u   // a baked probe grid is bound
#define PENUMBRA_FLAG_LINEAR 4u       // write linear scene-referred values (no exposure, no tone map)
#define PENUMBRA_FLAG_ENCODE_SRGB 8u  // the target is UNORM: apply the sRGB transfer in the shader
#define PENUMBRA_FLAG_PROBE_REACH 16u // the probe grid has the leak guard's reach (probe_grid.h)

// Debug views (FrameUniforms.view), the order of penumbra::DebugView.
#define PENUMBRA_VIEW_LIT 0
#define PENUMBRA_VIEW_DIRECT 1
#define PENUMBRA_VIEW_INDIRECT 2
#define PENUMBRA_VIEW_AO 3
#define PENUMBRA_VIEW_ALBEDO 4
#define PENUMBRA_VIEW_VALIDITY 5
#define PENUMBRA_VIEW_POSITION 6
#define PENUMBRA_VIEW_NORMAL 7
#define PENUMBRA_VIEW_IRRADIANCE 8
#define PENUMBRA_VIEW_COUNT 9

struct FrameUniforms {
  mat4 view_proj;          // world -> clip
  vec4 camera_exposure;    // xyz eye position (world), w exposure
  uvec4 params;            // x view, y light count, z flags, w probe SH bands (2 = L1, 3 = L2)
  mat4 probe_world_to_grid;  // world -> [0, 1]^3 of the probe grid
  vec4 probe_resolution;   // xyz nodes per axis
  vec4 shadow_params;      // x texel size of the shadow map (1 / size), y depth bias (light clip units), z normal offset (m)
  mat4 clip_to_world;      // inverse of view_proj: the AO-field pass's pixel -> world point
  vec4 target_size;        // xy pixels of the target, zw their inverses
  uvec4 ambient_params;    // x the ambient passes' pixel step (RenderSettings::ambient_step)
  vec4 ambient_scale;      // x: the ambient image holds probe irradiance times x (fits half floats)
};

// A light in world space. Radiometric units as penumbra::Light (components.h); color = colour x
// intensity.
struct GpuLight {
  vec4 position_type;   // xyz position (point, spot, rect centre), w type
  vec4 direction_range; // xyz unit direction light travels (directional, spot, rect normal), w range (0: infinite)
  vec4 color;           // rgb colour x intensity, w rect area (m^2)
  vec4 cone_shadow;     // x cos outer, y cos inner (spot), z first shadow layer (-1: none), w layer count (1 or 6)
};

// DrawPush.ao_field.x: how the drawn entity receives AO-field occlusion.
#define PENUMBRA_AO_RECEIVER_NONE 0u
#define PENUMBRA_AO_RECEIVER_SURFACE 1u  // per pixel from the AO-field buffer (static surfaces)
#define PENUMBRA_AO_RECEIVER_ENTITY 2u   // one value per entity (AOFieldReceiver::occlusion), uniform over the draw

// The G-buffer's receiver code (w): 0 where the pixel takes no per-pixel AO-field occlusion, else
// 2 + the record of the drawn entity's own caster (-1: none), which the pass skips (no
// self-shadow). Half floats hold it exactly up to 2048, hence at most 2046 casters.
#define PENUMBRA_AO_MAX_CASTERS 2046

// Push constants of every draw (forward, pre-pass, shadow; the AO-field pass reads only
// draw.x, the caster's record): 128 bytes, Vulkan's guaranteed minimum.
struct DrawPush {
  mat4 model;           // object -> world
  vec4 base_color;      // linear albedo, alpha
  vec4 emissive;        // rgb emitted radiance W/(m^2 sr)
  uvec4 draw;           // x first joint (skinned; the AO-field pass: caster record), y 1 when skinned,
                        // z shadow layer (shadow pass), w unused
  vec4 ao_field;        // x receiver mode (PENUMBRA_AO_RECEIVER_*), y entity occlusion, z the entity's own
                        // caster record in the AO-field buffer (-1: not a caster; skipped: no self-shadow)
};

#ifdef __cplusplus
}  // namespace penumbra::gpu
#endif

#endif  // PENUMBRA_SHADERS_LAYOUT_H
