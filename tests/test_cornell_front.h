// For the lighting modules' tests (tests/ is on every test's include path): the built-in Cornell
// box's short block front (builtin_scenes.cpp), the face that looks out of the box's open side and
// takes only bounced light, and the path tracer's settings that judge a technique's indirect
// irradiance there.
#pragma once

#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "penumbra/bake/integrators.h"

namespace penumbra::test_scenes {

struct CornellFront {
  std::vector<glm::vec3> points;  // 5 x 4 over the face inset 10 %, 0.1 mm in front of it
  glm::vec3 normal{0.0f};         // unit, out of the block
};

// The front quad (mm): x 130 -> 290, z 65 -> 114, y 0 -> 165. Points in row order of (u, v).
inline CornellFront cornell_short_block_front() {
  const glm::vec3 a(0.130f, 0.0f, 0.065f), b(0.290f, 0.0f, 0.114f);
  CornellFront front;
  front.normal = glm::normalize(glm::vec3(0.049f, 0.0f, -0.160f));
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 4; ++j) {
      const float u = 0.1f + 0.8f * float(i) / 4.0f, v = 0.1f + 0.8f * float(j) / 3.0f;
      front.points.push_back(glm::mix(a, b, u) + glm::vec3(0.0f, 0.165f * v, 0.0f) + 1e-4f * front.normal);
    }
  return front;
}

// Unbiased indirect irradiance, 16384 paths a point: about 0.5 % relative standard error over the
// front's 20 points.
inline IrradianceSettings cornell_front_reference() {
  IrradianceSettings reference;
  reference.reference = true;
  reference.samples = 16384;
  reference.content = LightingContent::Indirect;
  return reference;
}

}  // namespace penumbra::test_scenes
