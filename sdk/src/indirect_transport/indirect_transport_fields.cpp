// The field lists of IndirectReceiver, IndirectTransport and DynamicLight (fields.h).
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/lighting/field_list.h"

namespace penumbra {

namespace {

using fields::member;
using T = FieldType;

const IndirectReceiver kReceiverDefaults{};
constexpr FieldInfo kReceiverFields[] = {
    member<&IndirectReceiver::patch_size>({.name = "patch_size", .type = T::Float, .min = 0, .max = 1e6,
                                           .unit = "m",
                                           .help = "largest patch edge; 0 follows the scene (12% of its diagonal)",
                                           .hashed = true}),
};

const IndirectTransport kTransportDefaults{};
constexpr FieldInfo kTransportFields[] = {
    member<&IndirectTransport::refinement_threshold>(
        {.name = "refinement_threshold", .type = T::Float, .min = 1e-6, .max = 1,
         .help = "form-factor error a link may keep; 0.002 is a good start, lower is finer", .preset = true,
         .hashed = true, .speed = 1e-3f}),
    member<&IndirectTransport::finest_level>({.name = "finest_level", .type = T::Count, .min = 0, .max = 6,
                                              .unit = "levels",
                                              .help = "quadtree depth per patch: 2^L x 2^L texels; use 2 to 4",
                                              .preset = true, .hashed = true, .speed = 0.05f}),
    member<&IndirectTransport::bounce_tolerance>({.name = "bounce_tolerance", .type = T::Float, .min = 1e-9,
                                                  .max = 1, .help = "Neumann series stops below this; 1e-3",
                                                  .hashed = true, .speed = 1e-4f}),
    member<&IndirectTransport::max_bounces>({.name = "max_bounces", .type = T::Count, .min = 1, .max = 10000,
                                             .unit = "bounces", .help = "Neumann terms at most; 64",
                                             .hashed = true, .speed = 0.1f}),
    member<&IndirectTransport::drop_threshold>({.name = "drop_threshold", .type = T::Float, .min = 0, .max = 1,
                                                .help = "relative size of coefficients dropped from T and after each product; 3e-4",
                                                .hashed = true, .speed = 1e-6f}),
    member<&IndirectTransport::glossy>({.name = "glossy", .type = T::Bool, .min = 0, .max = 1,
                                        .help = "directional transport (not implemented: the bake refuses it)",
                                        .hashed = true}),
    member<&IndirectTransport::probe_spacing>(
        {.name = "probe_spacing", .type = T::Float, .min = 0, .max = 1e6, .unit = "m",
         .help = "metres between the bounce probes that light moving objects; 0 follows the scene (4% of its "
                 "diagonal)",
         .hashed = true, .speed = 0.01f}),
};

const DynamicLight kLightDefaults{};
constexpr FieldInfo kLightFields[] = {
    member<&DynamicLight::enabled>({.name = "enabled", .type = T::Bool, .min = 0, .max = 1,
                                    .help = "its bounce light comes from the indirect transport, not the probe grid",
                                    .hashed = true}),
    member<&DynamicLight::moves>({.name = "moves", .type = T::Bool, .min = 0, .max = 1,
                                  .help = "followed at runtime; off: its bounce is baked into the lightmap (moving it "
                                          "needs a re-bake)",
                                  .hashed = true}),
};

}  // namespace

const ComponentInfo& indirect_receiver_info() {
  static const ComponentInfo info{.name = "IndirectReceiver",
                                  .fields = kReceiverFields,
                                  .defaults = &kReceiverDefaults,
                                  .find = fields::find_in<IndirectReceiver>,
                                  .patch = fields::patch_in<IndirectReceiver>,
                                  .copy = fields::copy_in<IndirectReceiver>,
                                  .emplace = fields::emplace_in<IndirectReceiver>,
                                  .erase = fields::erase_in<IndirectReceiver>,
                                  .on_mesh = true};
  return info;
}

const ComponentInfo& indirect_transport_info() {
  static const ComponentInfo info{.name = "IndirectTransport",
                                  .fields = kTransportFields,
                                  .defaults = &kTransportDefaults,
                                  .find = fields::find_in<IndirectTransport>,
                                  .patch = fields::patch_in<IndirectTransport>,
                                  .copy = fields::copy_in<IndirectTransport>,
                                  .set_preset_fields = fields::preset_fields<IndirectTransport>,
                                  .emplace = fields::emplace_in<IndirectTransport>,
                                  .erase = fields::erase_in<IndirectTransport>};
  return info;
}

const ComponentInfo& dynamic_light_info() {
  static const ComponentInfo info{.name = "DynamicLight",
                                  .fields = kLightFields,
                                  .defaults = &kLightDefaults,
                                  .find = fields::find_in<DynamicLight>,
                                  .patch = fields::patch_in<DynamicLight>,
                                  .copy = fields::copy_in<DynamicLight>,
                                  .emplace = fields::emplace_in<DynamicLight>,
                                  .erase = fields::erase_in<DynamicLight>};
  return info;
}

}  // namespace penumbra
