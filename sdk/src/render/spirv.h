// The SPIR-V of the renderer's shaders in shaders/, compiled and embedded at build time
// (penumbra_shaders in sdk/CMakeLists.txt).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace penumbra::shaders {

// The words of the shader compiled from shaders/<name> (e.g. "forward.frag"); empty if unknown.
std::span<const std::uint32_t> renderer(std::string_view name);

}  // namespace penumbra::shaders
