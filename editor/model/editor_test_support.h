// What the editor model's tests share (test code only).
#pragma once

#include <gtest/gtest.h>

#include "editor_model.h"

namespace penumbra::editor {

// Selects `e` and bakes its components through the Bake-selection path, waiting for the result.
inline void bake_selected(EditorModel& model, Entity e) {
  model.document()->select(e);
  ASSERT_TRUE(model.bake_selection().ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
}

}  // namespace penumbra::editor
