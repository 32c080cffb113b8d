// For the lighting modules' tests (tests/ is on every test's include path): the built-in Cornell
// box's short block front (builtin_scenes.cpp), the face that looks out of the box's open side and
// takes only bounced light, and the path tracer's settings that judge a technique's indirect
// irradiance there.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "penumbra/bake/integrators.h"

namespace penumbra::test_scenes {

struct CornellFront {
  std::vector<glm::vec3> points;  // 0.1 mm in front of the face
  glm::vec3 normal{0.0f};         // unit, out of the block
};

// The front quad (mm): x 130 -> 290, z 65 -> 114, y 0 -> 165. A columns x rows lattice from
// `inset` to 1 - inset of the face along each side (inset 0.5 / n: the cells' centres, whose mean
// is the face's mean), in row order of (u, v). Preconditions: columns, rows >= 2.
inline CornellFront cornell_short_block_front(int columns = 5, int rows = 4, float inset = 0.1f) {
  const glm::vec3 a(0.130f, 0.0f, 0.065f), b(0.290f, 0.0f, 0.114f);
  CornellFront front;
  front.normal = glm::normalize(glm::vec3(0.049f, 0.0f, -0.160f));
  for (int i = 0; i < columns; ++i)
    for (int j = 0; j < rows; ++j) {
      const float u = inset + (1.0f - 2.0f * inset) * float(i) / float(columns - 1),
                  v = inset + (1.0f - 2.0f * inset) * float(j) / float(rows - 1);
      front.points.push_back(glm::mix(a, b, u) + glm::vec3(0.0f, 0.165f * v, 0.0f) + 1e-4f * front.normal);
    }
  return front;
}

// Unbiased indirect irradiance, `paths` a point (16384 at 20 points: a mean within 0.54 %).
inline IrradianceSettings cornell_front_reference(std::uint32_t paths = 16384) {
  IrradianceSettings reference;
  reference.reference = true;
  reference.samples = paths;
  reference.content = LightingContent::Indirect;
  return reference;
}

}  // namespace penumbra::test_scenes
