// The SDK's version, from the top-level CMake project() (one source of truth).
#pragma once

namespace penumbra {

// "MAJOR.MINOR.PATCH", e.g. "0.1.0". Written into every .pbake file. Thread-safe, free.
const char* sdk_version();

}  // namespace penumbra
