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
// The screen images of the ambient image's passes and the features' views (placeholders where
// they do not run), all read with texelFetch: the pre-pass depth and G-buffer, the ambient image
// and its key (at 1 / RenderSettings::ambient_step of the target's size).
#define PENUMBRA_BINDING_SCENE_DEPTH 5    // sampler2D: the camera's depth (pre-pass)
#define PENUMBRA_BINDING_GBUFFER 6        // sampler2D: xyz shading normal, w the draw's receiver code and
                                          // whether it is static geometry (common.glsl gbuffer_receiver)
                                          // (DrawPush::feature.x: a render feature's tag, 0 none)
#define PENUMBRA_BINDING_AMBIENT 7        // sampler2D: rgb the sources' irradiance x open x ambient_scale.x,
                                          // a the open fraction (the occluders' product)
#define PENUMBRA_BINDING_AMBIENT_KEY 8    // sampler2D: per sample its surface, xyz the normal, w 1 / clip w
                                          // (linear in screen space on a plane): what the upsampling compares
#define PENUMBRA_BINDING_SKY 9           // sampler2D: the environment map x its scale (equirectangular, +Y up:
                                          // scene/components.h EnvironmentMap); a placeholder without one
#define PENUMBRA_BINDING_SHADOW_DEPTH 10  // sampler2DArray: the shadow map's depths (nearest, no comparison),
                                          // for the rect lights' blocker search
// Descriptor set 1 (per material): the base colour texture (sRGB; white when the material has none).
#define PENUMBRA_BINDING_BASE_COLOR 0
// Descriptor set 2: the render feature's own (its pipelines' layout, render/feature.h).

// Scenes with up to this many lights get a forward pipeline specialised on their count (the
// shader's kLightCount); more lights loop over frame.params.y.
#define PENUMBRA_UNROLLED_LIGHTS 8

// Light types (GpuLight.position_type.w).
#define PENUMBRA_LIGHT_DIRECTIONAL 0
#define PENUMBRA_LIGHT_POINT 1
#define PENUMBRA_LIGHT_SPOT 2
#define PENUMBRA_LIGHT_RECT 3

// FrameUniforms.flags bits.
#define PENUMBRA_FLAG_INDIRECT 1u     // the ambient image's rgb holds a source's irradiance
#define PENUMBRA_FLAG_LINEAR 4u       // write linear scene-referred values (no exposure, no tone map)
#define PENUMBRA_FLAG_ENCODE_SRGB 8u  // the target is UNORM: apply the sRGB transfer in the shader

// The renderer's own debug views (forward.frag's kView), in the order of its views() list.
#define PENUMBRA_VIEW_LIT 0
#define PENUMBRA_VIEW_DIRECT 1
#define PENUMBRA_VIEW_INDIRECT 2
#define PENUMBRA_VIEW_AO 3
#define PENUMBRA_VIEW_ALBEDO 4
#define PENUMBRA_VIEW_POSITION 5
#define PENUMBRA_VIEW_NORMAL 6
#define PENUMBRA_VIEW_COUNT 7

struct FrameUniforms {
  mat4 view_proj;          // world -> clip
  vec4 camera_exposure;    // xyz eye position (world), w exposure
  uvec4 params;            // x view (the renderer's own), y light count, z flags, w unused
  vec4 shadow_params;      // x texel size of the shadow map (1 / size), y depth bias (light clip units), z normal offset (m)
  mat4 clip_to_world;      // inverse of view_proj: a screen pass's pixel -> world point
  vec4 target_size;        // xy pixels of the target, zw their inverses
  uvec4 ambient_params;    // x the ambient passes' pixel step (RenderSettings::ambient_step)
  vec4 ambient_scale;      // x: the ambient image holds irradiance times x (fits half floats)
};

// A light in world space. Radiometric units as penumbra::Light (components.h); color = colour x
// intensity.
struct GpuLight {
  vec4 position_type;   // xyz position (point, spot, rect centre), w type
  vec4 direction_range; // xyz unit direction light travels (directional, spot, rect normal), w range (0: infinite)
  vec4 color;           // rgb colour x intensity, w unused
  vec4 cone_shadow;     // x cos outer, y cos inner (spot), z first shadow layer (-1: none), w layer count (1 or 6)
  vec4 half_x;          // rect: xyz half-size vector along its local X (world space), w its shadow cube's near plane
  vec4 half_y;          // rect: xyz half-size vector along its local Y, w its shadow cube's far plane
};

// Push constants of every draw (forward, pre-pass, shadow; a feature's passes use them as they
// document): 128 bytes, Vulkan's guaranteed minimum.
struct DrawPush {
  mat4 model;           // object -> world
  vec4 base_color;      // linear albedo, alpha
  vec4 emissive;        // rgb emitted radiance W/(m^2 sr)
  uvec4 draw;           // x first joint (skinned), y 1 when skinned, z shadow layer (shadow pass), w 1 when
                        // the vertex AO is the static geometry's (VertexAO::static_occluders)
  vec4 feature;         // the render features' DrawFeatureValues: x receiver code (G-buffer w), y the
                        // entity-wide open fraction (1: unoccluded); z 1 on the level's static geometry
                        // (the Static tag), else 0; w unused
};

#ifdef __cplusplus
}  // namespace penumbra::gpu
#endif

#endif  // PENUMBRA_SHADERS_LAYOUT_H
