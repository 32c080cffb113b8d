// Click-to-select: the crate in the middle of the view, the lamp under its marker, nothing in the sky.
#include "picking.h"

#include <gtest/gtest.h>

#include "load_world.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

Entity named(World& w, const std::string& name, bool light) {
  Entity found;
  w.view<const Name>().each([&](Entity e, const Name& n) {
    if (n.value == name && (!light || w.has<Light>(e)) && !found) found = e;
  });
  return found;
}

TEST(Picking, SelectsTheMeshUnderThePointerAndLightsByTheirMarker) {
  World w;
  ASSERT_TRUE(cli::load_world(w, "builtin:courtyard", Preset::Draft).ok());
  const glm::vec2 size(640.0f, 360.0f);
  // Looking at the lone crate at (-3, 0.4, -6) from the south, level with it.
  const CameraView camera = look_at_view(glm::vec3(-3.0f, 0.6f, -2.0f), glm::vec3(-3.0f, 0.4f, -6.0f), 1.0f,
                                         size.x / size.y, 0.05f, 100.0f);
  auto centre = pick(w, camera, size * 0.5f, size);
  ASSERT_TRUE(centre.ok()) << centre.error().message;
  ASSERT_TRUE(*centre);
  EXPECT_EQ(w.get<Name>(*centre).value, "crate");
  EXPECT_EQ(w.get<Transform>(*centre).translation, glm::vec3(-3.0f, 0.4f, -6.0f));
  // The sky above the north wall: nothing.
  auto sky = pick(w, camera, glm::vec2(size.x * 0.5f, 2.0f), size);
  ASSERT_TRUE(sky.ok());
  EXPECT_FALSE(*sky);
  // The lamp at (-2, 2.5, 3), seen from the south-east: its marker picks it, 5 px off.
  const CameraView back = look_at_view(glm::vec3(2.0f, 2.0f, 8.0f), glm::vec3(-2.0f, 2.5f, 3.0f), 1.0f,
                                       size.x / size.y, 0.05f, 100.0f);
  auto lamp = pick(w, back, size * 0.5f + glm::vec2(3.0f, 4.0f), size);
  ASSERT_TRUE(lamp.ok());
  EXPECT_EQ(*lamp, named(w, "lamp", true));
}

}  // namespace
}  // namespace penumbra::editor
