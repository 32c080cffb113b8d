// The SPIR-V of every shader in shaders/, compiled and embedded at build time (embed_spirv.cmake).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace penumbra::render_detail {

// The words of the shader compiled from shaders/<name> (e.g. "forward.frag"); empty if unknown.
std::span<const std::uint32_t> spirv(std::string_view name);

}  // namespace penumbra::render_detail
