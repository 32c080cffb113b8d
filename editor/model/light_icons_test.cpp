// Light icons: a spot's cone opens at its outer angle along local -Z, a directional light's arrow
// points where it shines, a rect's outline has its size, a point light is a marker alone, and a
// singular matrix draws nothing.
#include "light_icons.h"

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

namespace penumbra::editor {
namespace {

TEST(LightIcons, SpotConeOpensAtTheOuterAngleAlongItsDirection) {
  Light spot;
  spot.type = Light::Type::Spot;
  spot.outer_cone_angle = 0.5f;
  // At (1, 2, 3), turned to shine along +X (local -Z turned by -90 degrees about Y).
  const glm::mat4 world = glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3)), -1.5707963f,
                                      glm::vec3(0, 1, 0));
  const LightIcon icon = light_icon(spot, world, 2.0f);
  EXPECT_LT(glm::distance(icon.position, glm::vec3(1, 2, 3)), 1e-6f);
  ASSERT_EQ(icon.lines.size(), 20u);
  for (int i = 0; i < 16; ++i) {  // the circle: 2 m along +X, 2 tan(0.5) from the axis
    const glm::vec3 q = icon.lines[i][0];
    EXPECT_NEAR(q.x, 3.0f, 1e-5f);
    EXPECT_NEAR(glm::length(glm::vec2(q.y - 2.0f, q.z - 3.0f)), 2.0f * std::tan(0.5f), 1e-5f);
  }
  for (int i = 16; i < 20; ++i) EXPECT_EQ(icon.lines[i][0], icon.position);
}

TEST(LightIcons, DirectionalArrowRectOutlineAndPointMarker) {
  Light sun;
  sun.type = Light::Type::Directional;
  const LightIcon arrow = light_icon(sun, glm::mat4(1.0f), 1.5f);  // shines along -Z
  ASSERT_EQ(arrow.lines.size(), 5u);
  EXPECT_LT(glm::distance(arrow.lines[0][1], glm::vec3(0, 0, -1.5f)), 1e-6f);

  Light rect;
  rect.type = Light::Type::Rect;
  rect.size = glm::vec2(2.0f, 1.0f);
  const LightIcon outline = light_icon(rect, glm::translate(glm::mat4(1.0f), glm::vec3(0, 3, 0)), 0.5f);
  ASSERT_EQ(outline.lines.size(), 5u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(std::abs(outline.lines[i][0].x), 1.0f, 1e-6f);
    EXPECT_NEAR(std::abs(outline.lines[i][0].y - 3.0f), 0.5f, 1e-6f);
  }
  EXPECT_LT(glm::distance(outline.lines[4][1], glm::vec3(0, 3, -0.5f)), 1e-6f);

  Light point;
  EXPECT_TRUE(light_icon(point, glm::mat4(1.0f), 1.0f).lines.empty());
  EXPECT_TRUE(light_icon(rect, glm::mat4(0.0f), 1.0f).lines.empty());  // singular: nothing to draw
}

}  // namespace
}  // namespace penumbra::editor
