// For the bakers' tests: the built-in courtyard with every module registered and its default
// lighting components at `preset` (a probe grid, AO-field casters and receivers, pose-AO on the
// walker, the indirect transport), transforms up to date.
#pragma once

#include <gtest/gtest.h>

#include "penumbra/bakers.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::test_scenes {

inline World courtyard_with_defaults(Preset preset = Preset::Draft) {
  World world;
  register_lighting(world);
  register_bakers(world);
  EXPECT_TRUE(load_builtin(world, "courtyard").ok());
  world.update(0.0);
  EXPECT_TRUE(add_default_lighting(world, preset, false).ok());
  return world;
}

}  // namespace penumbra::test_scenes
