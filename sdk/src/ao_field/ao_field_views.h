// What the editor's view of an AO-field caster computes, kept out of the app so that tests check
// it: the caster's bounds as world-space polylines and a slice of receivers coloured by the
// caster's AO (the CPU evaluation, ao_field.h). Plain functions over a World; main thread (they
// read components). Part of the editor (ao_field_editor.cpp draws them).
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra::editor {

// A caster's bounds in world space, each loop a closed polyline (the last point joins the first).
struct AOFieldBounds {
  glm::vec3 centre{0.0f};  // the field's origin
  float falloff_radius = 0.0f;  // r_far in world units: beyond it the caster casts nothing
  // Three great circles (XY, YZ, ZX planes of the caster's frame) at the falloff radius.
  std::vector<std::vector<glm::vec3>> falloff;
  // The hull r0(w) of a baked radial fit along the same three circles of directions (the surface
  // where the fit takes over from the inside blend); for a grid field the grid's cube (four loops
  // of its 12 edges); before a bake, the bounding sphere's three circles.
  std::vector<std::vector<glm::vec3>> hull;
  bool baked = false;
};

// The bounds of the AOFieldCaster on `caster` (with Mesh and WorldTransform), `segments` points
// per circle (>= 8). Before a bake they come from the settings and the mesh, as the baker derives
// them (centre of the mesh's bounds, bounding radius to the farthest vertex, falloff 6x that when
// not set). NotFound when the entity has no caster, mesh or world transform. Cost: O(segments)
// (plus O(vertices) before a bake).
Result<AOFieldBounds> ao_field_bounds(World& world, Entity caster, int segments = 64);

// A square of receivers in a horizontal plane (normal +Y: a floor) centred below the caster,
// coloured by the caster's occlusion alone.
struct AOFieldSliceRequest {
  int resolution = 32;       // points per side (2..512)
  float height = 0.0f;       // the plane's height above the caster's lowest point (world units)
  float extent = 1.1f;       // half-size of the square, in falloff radii
};
struct AOFieldSlice {
  int resolution = 0;
  std::vector<glm::vec3> points;  // resolution^2 world positions, row-major
  std::vector<float> occlusion;   // evaluate() of the caster's field there, in [0, 1]
  float max_occlusion = 0.0f;
};

// Evaluates the caster's baked field at the slice's receivers (evaluate(), the same CPU evaluation
// game code calls). NotFound without a caster, world transform or baked data; InvalidArgument for
// a resolution outside 2..512 or a non-finite height or extent. Cost: resolution^2 evaluations
// (~50 ns each: 32^2 in ~0.05 ms, so it can follow a dragged caster every frame).
Result<AOFieldSlice> ao_field_slice(World& world, Entity caster, const AOFieldSliceRequest& request);

}  // namespace penumbra::editor
