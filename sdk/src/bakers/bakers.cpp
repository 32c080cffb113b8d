// Every module's baker, from the SDK's module list (see penumbra/bakers.h).
#include "penumbra/bakers.h"

namespace penumbra {

#define PENUMBRA_MODULE(id) void register_##id##_baker(World& world);
#include "modules.inc"
#undef PENUMBRA_MODULE

void register_bakers(World& world) {
#define PENUMBRA_MODULE(id) register_##id##_baker(world);
#include "modules.inc"
#undef PENUMBRA_MODULE
}

}  // namespace penumbra
