// The field lists of AOFieldCaster and AOFieldReceiver (fields.h).
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/lighting/field_list.h"

namespace penumbra {

namespace {

using fields::member;
using T = FieldType;

constexpr std::string_view kRepresentations[] = {"radial-fit", "grid"};
constexpr std::string_view kModes[] = {"entity", "surface"};

const AOFieldCaster kCasterDefaults{};
constexpr FieldInfo kCasterFields[] = {
    member<&AOFieldCaster::representation>({.name = "representation", .type = T::Enum, .min = 0, .max = 1,
                                            .choices = kRepresentations,
                                            .help = "radial fit (small, convex casters) or a 3D grid (any shape)",
                                            .hashed = true}),
    member<&AOFieldCaster::resolution>({.name = "resolution", .type = T::Count, .min = 1, .max = 256,
                                        .unit = "texels", .help = "cube-map texels per face edge; use 8, 16 or 32",
                                        .preset = true, .hashed = true, .speed = 0.1f}),
    member<&AOFieldCaster::supersample>({.name = "supersample", .type = T::Count, .min = 1, .max = 4,
                                         .help = "directions per texel edge; use 2", .hashed = true, .speed = 0.02f}),
    member<&AOFieldCaster::grid_size>({.name = "grid_size", .type = T::Count, .min = 4, .max = 128,
                                       .unit = "vertices", .help = "grid vertices per axis; use 16, 32 or 48",
                                       .preset = true, .hashed = true, .speed = 0.1f}),
    member<&AOFieldCaster::radial_samples>({.name = "radial_samples", .type = T::Count, .min = 3, .max = 1024,
                                            .unit = "radii",
                                            .help = "radii per texel; the fit of three coefficients needs at least 3",
                                            .preset = true, .hashed = true, .speed = 0.2f}),
    member<&AOFieldCaster::rays_per_sample>({.name = "rays_per_sample", .type = T::Count, .min = 16, .max = 1e6,
                                             .unit = "rays", .help = "rays per radius; use 64 or more", .preset = true,
                                             .hashed = true, .speed = 1.0f}),
    member<&AOFieldCaster::falloff_distance>({.name = "falloff_distance", .type = T::Float, .min = 0, .max = 1e6,
                                              .unit = "m", .help = "0 derives 6 x the bounding radius",
                                              .hashed = true}),
    member<&AOFieldCaster::fade_start>({.name = "fade_start", .type = T::Float, .min = 1e-3, .max = 0.999,
                                        .help = "fraction of the falloff where the fade begins, e.g. 0.8",
                                        .hashed = true, .speed = 0.005f}),
    member<&AOFieldCaster::inside_occlusion>({.name = "inside_occlusion", .type = T::Float, .min = 0, .max = 1,
                                              .help = "occlusion at the field's centre", .hashed = true,
                                              .speed = 0.005f}),
    member<&AOFieldCaster::inside_exponent>({.name = "inside_exponent", .type = T::Float, .min = 1e-3, .max = 100,
                                             .help = "blend exponent inside the hull, e.g. 2", .hashed = true}),
};

const AOFieldReceiver kReceiverDefaults{};
constexpr FieldInfo kReceiverFields[] = {
    member<&AOFieldReceiver::mode>({.name = "mode", .type = T::Enum, .min = 0, .max = 1, .choices = kModes,
                                    .help = "entity: one value at the origin; surface: per pixel in the renderer"}),
    member<&AOFieldReceiver::normal>({.name = "normal", .type = T::Vec3, .min = -1, .max = 1,
                                      .help = "local normal of the receiving point (entity mode)"}),
    member<&AOFieldReceiver::occlusion>({.name = "occlusion", .type = T::Float, .min = 0, .max = 1,
                                         .help = "combined occlusion, written by the ao-field system",
                                         .read_only = true}),
};

}  // namespace

const ComponentInfo& ao_field_caster_info() {
  static const ComponentInfo info{.name = "AOFieldCaster",
                                  .fields = kCasterFields,
                                  .defaults = &kCasterDefaults,
                                  .find = fields::find_in<AOFieldCaster>,
                                  .patch = fields::patch_in<AOFieldCaster>,
                                  .copy = fields::copy_in<AOFieldCaster>,
                                  .set_preset_fields = fields::preset_fields<AOFieldCaster>,
                                  .emplace = fields::emplace_in<AOFieldCaster>,
                                  .erase = fields::erase_in<AOFieldCaster>,
                                  .on_mesh = true};
  return info;
}

const ComponentInfo& ao_field_receiver_info() {
  static const ComponentInfo info{.name = "AOFieldReceiver",
                                  .fields = kReceiverFields,
                                  .defaults = &kReceiverDefaults,
                                  .find = fields::find_in<AOFieldReceiver>,
                                  .patch = fields::patch_in<AOFieldReceiver>,
                                  .copy = fields::copy_in<AOFieldReceiver>,
                                  .emplace = fields::emplace_in<AOFieldReceiver>,
                                  .erase = fields::erase_in<AOFieldReceiver>,
                                  .on_mesh = true};
  return info;
}

}  // namespace penumbra
