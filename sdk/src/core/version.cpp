// The SDK version string (PENUMBRA_VERSION_STRING comes from sdk/src/core/CMakeLists.txt).
#include "penumbra/core/version.h"

namespace penumbra {

const char* sdk_version() { return PENUMBRA_VERSION_STRING; }

}  // namespace penumbra
