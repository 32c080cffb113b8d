// What the glTF importer and saver share (internal to sdk/src/import).
#pragma once

#include <algorithm>
#include <string_view>

namespace penumbra::gltf_detail {

// The deepest nesting of JSON arrays and objects in `text` (string contents skipped), stopping once
// it passes `limit`: checked before any JSON parser sees the text, since tinygltf's and nlohmann's
// recursion overflow the stack on a few thousand levels.
inline int json_depth(std::string_view text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) break;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

// The nesting the glTF readers accept (a glTF needs fewer than 20 levels).
inline constexpr int kMaxJsonDepth = 128;

}  // namespace penumbra::gltf_detail
