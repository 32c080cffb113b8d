// The translate gizmo: the arrows keep their screen size, the pointer grabs the arrow it is on, and
// dragging along an axis keeps the axis point under the pointer (a drag from the origin's pixel to
// the pixel of origin + 1.5 x moves by 1.5 along x, whatever else the pointer does across it).
#include "gizmo.h"

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/camera.h"
#include "picking.h"

namespace penumbra::editor {
namespace {

const glm::vec2 kSize(1280.0f, 720.0f);

std::optional<glm::vec2> screen(const CameraView& camera, glm::vec3 p) { return project(camera, p, kSize); }

TEST(Gizmo, ArrowsKeepTheirScreenSizeAndThePointerGrabsTheOneItIsOn) {
  const glm::vec3 target(1.0f, 0.5f, -2.0f);
  const float aspect = kSize.x / kSize.y;
  const CameraView near = look_at_view(target + glm::vec3(3, 2, 4), target, 0.8f, aspect, 0.05f, 100.0f);
  const CameraView far = look_at_view(target + 10.0f * glm::vec3(3, 2, 4), target, 0.8f, aspect, 0.05f, 1000.0f);
  const auto a = gizmo_handles(near, target, kSize), b = gizmo_handles(far, target, kSize);
  ASSERT_TRUE(a && b);
  for (int axis = 0; axis < 3; ++axis) {
    ASSERT_TRUE(a->tips[axis] && b->tips[axis]);
    EXPECT_NEAR(glm::distance(a->origin, *a->tips[axis]), glm::distance(b->origin, *b->tips[axis]), 1.5f) << axis;
    EXPECT_GT(glm::distance(a->origin, *a->tips[axis]), 20.0f) << axis;
    // Two thirds along an arrow, and 3 pixels beside it, grabs that arrow.
    const glm::vec2 on = glm::mix(a->origin, *a->tips[axis], 0.66f);
    const glm::vec2 across = glm::normalize(*a->tips[axis] - a->origin);
    EXPECT_EQ(pick_gizmo_axis(*a, on + 3.0f * glm::vec2(-across.y, across.x)), axis);
  }
  EXPECT_EQ(pick_gizmo_axis(*a, a->origin + glm::vec2(200.0f, 200.0f)), -1);
  // Behind the camera: no handles.
  EXPECT_FALSE(gizmo_handles(near, target + 20.0f * glm::vec3(3, 2, 4), kSize));
}

TEST(Gizmo, DraggingAlongAnAxisKeepsItsPointUnderThePointer) {
  const glm::vec3 origin(0.5f, 1.0f, 0.0f);
  const CameraView camera = look_at_view(glm::vec3(4, 3, 6), origin, 0.8f, kSize.x / kSize.y, 0.05f, 100.0f);
  for (int a = 0; a < 3; ++a) {
    glm::vec3 axis(0.0f);
    axis[a] = 1.0f;
    const auto from = screen(camera, origin), to = screen(camera, origin + 1.5f * axis);
    ASSERT_TRUE(from && to);
    const glm::vec3 moved = drag_along_axis(camera, origin, axis, *from, *to, kSize);
    EXPECT_NEAR(moved[a], 1.5f, 0.01f) << a;
    EXPECT_EQ(moved[(a + 1) % 3], 0.0f);
    // A pointer that also moves across the arrow still moves only along it, by the same amount.
    const glm::vec2 off = *to + 30.0f * glm::normalize(glm::vec2(-(*to - *from).y, (*to - *from).x));
    EXPECT_NEAR(drag_along_axis(camera, origin, axis, *from, off, kSize)[a], 1.5f, 0.15f) << a;
  }
  // An axis pointing at the camera projects to a point: a drag across the screen barely moves along it.
  const glm::vec3 view_axis = glm::normalize(glm::vec3(4, 3, 6) - origin);
  EXPECT_LT(glm::length(drag_along_axis(camera, origin, view_axis, glm::vec2(600, 300), glm::vec2(700, 400), kSize)),
            0.01f);
}

// Rotate: a quarter turn counter-clockwise as seen around the origin turns +90 degrees about an
// axis pointing at the camera and -90 about one pointing away; the pointer grabs a ring. Scale: a
// drag to the arrow's tip doubles, one back past the origin shrinks, never below 0.01.
TEST(Gizmo, RingsTurnRightHandedAndArrowsScale) {
  const glm::vec3 origin(0.0f);
  const CameraView camera = look_at_view(glm::vec3(0.1f, 0.2f, 5.0f), origin, 0.8f, kSize.x / kSize.y, 0.05f, 100.0f);
  const auto o = screen(camera, origin);
  ASSERT_TRUE(o);
  const glm::vec2 right = *o + glm::vec2(100.0f, 0.0f), up = *o + glm::vec2(0.0f, -100.0f);  // y grows downwards
  EXPECT_NEAR(rotate_about_axis(camera, origin, glm::vec3(0, 0, 1), right, up, kSize), 1.5707963f, 1e-4f);
  EXPECT_NEAR(rotate_about_axis(camera, origin, glm::vec3(0, 0, -1), right, up, kSize), -1.5707963f, 1e-4f);
  const auto rings = gizmo_handles(camera, origin, kSize, GizmoMode::Rotate);
  ASSERT_TRUE(rings);
  ASSERT_EQ(rings->rings[2].size(), 48u);
  EXPECT_EQ(pick_gizmo_axis(*rings, rings->rings[2][5] + glm::vec2(2.0f, 0.0f)), 2);
  EXPECT_EQ(pick_gizmo_axis(*rings, *o), 0);  // the x ring, seen edge on, runs through the centre
  EXPECT_EQ(pick_gizmo_axis(*rings, *o + glm::vec2(300.0f, 250.0f)), -1);

  const auto arrows = gizmo_handles(camera, origin, kSize, GizmoMode::Scale);
  ASSERT_TRUE(arrows && arrows->tips[0]);
  EXPECT_NEAR(scale_along_axis(camera, origin, glm::vec3(1, 0, 0), arrows->length, *o, *arrows->tips[0], kSize), 2.0f,
              0.01f);
  const glm::vec2 back = *o - 3.0f * (*arrows->tips[0] - *o);
  EXPECT_EQ(scale_along_axis(camera, origin, glm::vec3(1, 0, 0), arrows->length, *o, back, kSize), 0.01f);
}

// Scale on a turned entity: its arrows run along its own axes, so a drag along the X arrow of an
// entity turned a quarter about Y (its X is world -Z) goes along world -Z and scales its X.
TEST(Gizmo, ScaleArrowsFollowTheEntitysOwnAxes) {
  World world;
  const Entity e = world.create();
  Transform t;
  t.rotation = glm::angleAxis(1.5707963f, glm::vec3(0, 1, 0));
  t.scale = glm::vec3(2.0f, 1.0f, 1.0f);
  world.add<Transform>(e, t);
  update_world_transforms(world);
  const glm::mat3 axes = gizmo_axes(world, e, GizmoMode::Scale);
  EXPECT_NEAR(glm::distance(axes[0], glm::vec3(0, 0, -1)), 0.0f, 1e-6f);  // unit, though scaled by 2
  EXPECT_NEAR(glm::distance(axes[2], glm::vec3(1, 0, 0)), 0.0f, 1e-6f);
  EXPECT_EQ(gizmo_axes(world, e, GizmoMode::Move), glm::mat3(1.0f));
  EXPECT_EQ(gizmo_axes(world, world.create(), GizmoMode::Scale), glm::mat3(1.0f));  // no WorldTransform

  const glm::vec3 origin(0.0f);
  const CameraView camera = look_at_view(glm::vec3(3.0f, 2.0f, 4.0f), origin, 0.8f, kSize.x / kSize.y, 0.05f, 100.0f);
  const auto arrows = gizmo_handles(camera, origin, kSize, GizmoMode::Scale, axes);
  ASSERT_TRUE(arrows && arrows->tips[0]);
  EXPECT_NEAR(glm::distance(*arrows->tips[0], *screen(camera, origin + arrows->length * glm::vec3(0, 0, -1))), 0.0f,
              1e-3f);
  EXPECT_NEAR(scale_along_axis(camera, origin, axes[0], arrows->length, arrows->origin, *arrows->tips[0], kSize), 2.0f,
              0.01f);
}

// The frame a drag edits a Transform in: the parent's world matrix, the identity for a root and
// for an entity whose parent is gone.
TEST(Gizmo, ParentWorldMatrixIsTheFrameOfTheLocalTransform) {
  World world;
  const Entity parent = world.create(), child = world.create();
  Transform t;
  t.translation = glm::vec3(1.0f, 2.0f, 3.0f);
  t.scale = glm::vec3(2.0f);
  world.add<Transform>(parent, t);
  world.add<Transform>(child, Transform{});
  ASSERT_TRUE(set_parent(world, child, parent));
  update_world_transforms(world);
  EXPECT_EQ(parent_world_matrix(world, child), world.get<WorldTransform>(parent).matrix);
  EXPECT_EQ(parent_world_matrix(world, parent), glm::mat4(1.0f));
  world.destroy(parent);
  EXPECT_EQ(parent_world_matrix(world, child), glm::mat4(1.0f));
}

}  // namespace
}  // namespace penumbra::editor
