// The field lists of IrradianceProbeGrid and ProbeLit (fields.h).
#include "penumbra/lighting/field_list.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/probe_grid/probe_grid_system.h"

namespace penumbra {

namespace {

using fields::member;
using T = FieldType;

constexpr std::string_view kOrders[] = {"L1", "L2"};
constexpr std::string_view kSamplings[] = {"point", "supersampled", "fitted"};
constexpr std::string_view kLighting[] = {"all", "indirect"};

const IrradianceProbeGrid kGridDefaults{};

constexpr FieldInfo kGridFields[] = {
    // The box's corners are any finite numbers (the empty default box holds -+FLT_MAX); the layout
    // checks the box itself.
    {.name = "box_min", .type = T::Vec3, .min = -3.5e38, .max = 3.5e38, .unit = "m",
     .help = "world-space box corner; an empty box is the unit cube through the transform", .hashed = true,
     .speed = 0.02f,
     .get = [](const void* c) { return FieldValue(static_cast<const IrradianceProbeGrid*>(c)->box.min); },
     .set = [](void* c, const FieldValue& v) { static_cast<IrradianceProbeGrid*>(c)->box.min = std::get<glm::vec3>(v); }},
    {.name = "box_max", .type = T::Vec3, .min = -3.5e38, .max = 3.5e38, .unit = "m", .help = "world-space box corner",
     .hashed = true, .speed = 0.02f,
     .get = [](const void* c) { return FieldValue(static_cast<const IrradianceProbeGrid*>(c)->box.max); },
     .set = [](void* c, const FieldValue& v) { static_cast<IrradianceProbeGrid*>(c)->box.max = std::get<glm::vec3>(v); }},
    member<&IrradianceProbeGrid::resolution>({.name = "resolution", .type = T::Count3, .min = 0, .max = 4096,
                                              .unit = "nodes", .help = "nodes per axis (each >= 2); 0 0 0 derives them from spacing",
                                              .hashed = true, .speed = 0.1f}),
    member<&IrradianceProbeGrid::spacing>({.name = "spacing", .type = T::Float, .min = 0, .max = 1e6, .unit = "m",
                                           .help = "distance between nodes when resolution is 0; 0 follows the box (cells)",
                                           .preset = true, .hashed = true}),
    member<&IrradianceProbeGrid::cells>({.name = "cells", .type = T::Count, .min = 1, .max = kMaxDerivedCells,
                                         .unit = "cells", .help = "cells across the box's smallest side when spacing is 0",
                                         .preset = true, .hashed = true, .speed = 0.1f}),
    {.name = "sh_order", .type = T::Enum, .min = 0, .max = 1, .choices = kOrders,
     .help = "SH coefficients per channel: L1 4, L2 9", .hashed = true,
     .get = [](const void* c) {
       return FieldValue(std::int64_t{static_cast<const IrradianceProbeGrid*>(c)->sh_order == ProbeShOrder::L1 ? 0 : 1});
     },
     .set = [](void* c, const FieldValue& v) {
       static_cast<IrradianceProbeGrid*>(c)->sh_order = std::get<std::int64_t>(v) == 0 ? ProbeShOrder::L1 : ProbeShOrder::L2;
     }},
    member<&IrradianceProbeGrid::sampling>({.name = "sampling", .type = T::Enum, .min = 0, .max = 2, .choices = kSamplings,
                                            .help = "how the bake chooses node values", .preset = true, .hashed = true}),
    member<&IrradianceProbeGrid::samples_per_node>({.name = "samples_per_node", .type = T::Count, .min = 1, .max = 1e6,
                                                    .unit = "samples", .help = "points per node's tent (8 draft, 64 high)",
                                                    .preset = true, .hashed = true, .speed = 0.2f}),
    member<&IrradianceProbeGrid::rays_per_sample>({.name = "rays_per_sample", .type = T::Count, .min = 1, .max = 1e6,
                                                   .unit = "rays", .help = "rays per sample point", .preset = true,
                                                   .hashed = true, .speed = 0.2f}),
    member<&IrradianceProbeGrid::bounces>({.name = "bounces", .type = T::Count, .min = 0, .max = kProbeAllBounces,
                                           .help = "light bounces before a node when truncation is 0; 4294967295 for all",
                                           .preset = true, .hashed = true, .speed = 0.05f}),
    member<&IrradianceProbeGrid::truncation>({.name = "truncation", .type = T::Float, .min = 0, .max = 1,
                                              .help = "indirect light that stopping may leave out (bounces follow the "
                                                      "scene's albedo); 0 uses bounces",
                                              .preset = true, .hashed = true, .speed = 0.005f}),
    member<&IrradianceProbeGrid::noise>({.name = "noise", .type = T::Float, .min = 0, .max = 1,
                                         .help = "relative standard error a node's irradiance may keep; noisier nodes "
                                                 "trace up to 8x the rays (0: rays_per_sample everywhere)",
                                         .preset = true, .hashed = true, .speed = 0.002f}),
    member<&IrradianceProbeGrid::hit_samples>({.name = "hit_samples", .type = T::Count, .min = 2, .max = 1e6,
                                               .unit = "paths", .help = "irradiance paths at each ray hit",
                                               .hashed = true, .speed = 0.1f}),
    member<&IrradianceProbeGrid::lighting>({.name = "lighting", .type = T::Enum, .min = 0, .max = 1, .choices = kLighting,
                                            .help = "indirect for a renderer that draws direct light itself",
                                            .hashed = true}),
    member<&IrradianceProbeGrid::back_face_threshold>({.name = "back_face_threshold", .type = T::Float, .min = 0,
                                                       .max = 1, .help = "a sample is outside the domain when more of "
                                                                         "its rays hit back faces (0.1)",
                                                       .hashed = true, .speed = 0.005f}),
    member<&IrradianceProbeGrid::deringing_window>({.name = "deringing_window", .type = T::Float, .min = 0, .max = 100,
                                                    .help = "Lanczos window at bake; 0 for none", .hashed = true}),
    member<&IrradianceProbeGrid::leak_guard>({.name = "leak_guard", .type = T::Bool,
                                              .help = "store each node's reach and skip hidden corners", .hashed = true}),
    member<&IrradianceProbeGrid::priority>({.name = "priority", .type = T::Int, .min = -1e9, .max = 1e9,
                                            .help = "where grids overlap the higher priority wins", .speed = 0.1f}),
    member<&IrradianceProbeGrid::blend_distance>({.name = "blend_distance", .type = T::Float, .min = 0, .max = 1e6,
                                                  .unit = "m", .help = "fade inside the border; 0 for one spacing"}),
};

const ProbeLit kLitDefaults{};
constexpr FieldInfo kLitFields[] = {
    member<&ProbeLit::covered>({.name = "covered", .type = T::Bool, .help = "some grid covers the entity",
                                .read_only = true}),
};

}  // namespace

const ComponentInfo& irradiance_probe_grid_info() {
  static const ComponentInfo info{.name = "IrradianceProbeGrid",
                                  .fields = kGridFields,
                                  .defaults = &kGridDefaults,
                                  .find = fields::find_in<IrradianceProbeGrid>,
                                  .patch = fields::patch_in<IrradianceProbeGrid>,
                                  .copy = fields::copy_in<IrradianceProbeGrid>,
                                  .set_preset_fields = fields::preset_fields<IrradianceProbeGrid>,
                                  .emplace = fields::emplace_in<IrradianceProbeGrid>,
                                  .erase = fields::erase_in<IrradianceProbeGrid>,
                                  .fit = fit_probe_grid};
  return info;
}

const ComponentInfo& probe_lit_info() {
  static const ComponentInfo info{.name = "ProbeLit",
                                  .fields = kLitFields,
                                  .defaults = &kLitDefaults,
                                  .find = fields::find_in<ProbeLit>,
                                  .patch = fields::patch_in<ProbeLit>,
                                  .copy = fields::copy_in<ProbeLit>,
                                  .emplace = fields::emplace_in<ProbeLit>,
                                  .erase = fields::erase_in<ProbeLit>,
                                  .on_mesh = true};
  return info;
}

}  // namespace penumbra
