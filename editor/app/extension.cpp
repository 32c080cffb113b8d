// The editor extensions' registry (see extension.h).
#include "extension.h"

#include <algorithm>
#include <vector>

#include "penumbra/runtime.h"

namespace penumbra::editor {

namespace {

std::vector<EditorExtension>& registry() {
  static std::vector<EditorExtension> extensions;
  return extensions;
}

// The position of a module in the SDK's list (registration order is link order).
std::size_t module_order(const std::string& name) {
  const auto modules = lighting_modules();
  for (std::size_t i = 0; i < modules.size(); ++i)
    if (modules[i]->name == name) return i;
  return modules.size();
}

}  // namespace

std::span<const EditorExtension> editor_extensions() {
  static const bool sorted = [] {
    std::stable_sort(registry().begin(), registry().end(), [](const EditorExtension& a, const EditorExtension& b) {
      return module_order(a.module) < module_order(b.module);
    });
    return true;
  }();
  (void)sorted;
  return registry();
}

bool register_editor_extension(EditorExtension extension) {
  registry().push_back(std::move(extension));
  return true;
}

}  // namespace penumbra::editor
