// Mesh utilities: normals, degenerate-triangle removal, bounds, and the primitive builders that
// the built-in scenes (and tests needing closed-form geometry) use.
//
// All functions are pure over their arguments: thread-safe on distinct meshes, no allocation
// beyond the returned or modified mesh.
#pragma once

#include <cstddef>
#include <string>

#include <glm/vec3.hpp>

#include "penumbra/scene/components.h"

namespace penumbra {

// Recomputes MeshData::bounds from the positions. O(vertices).
void compute_bounds(MeshData& mesh);

// Area-weighted vertex normals (each triangle adds its unnormalised cross product to its three
// vertices), normalised; a vertex touched only by zero-area triangles gets +Y. O(triangles).
void compute_normals(MeshData& mesh);

// Removes triangles whose area is below `relative_epsilon` times the squared diagonal of the
// mesh's bounding box (so the test is scale-free), and triangles that repeat an index.
// Returns how many were removed. Vertices are kept (unreferenced ones are harmless). O(triangles).
std::size_t remove_degenerate_triangles(MeshData& mesh, float relative_epsilon = 1e-9f);

// Primitive builders. Each returns a valid mesh (positions, unit normals, uvs, indices, bounds)
// centred at the origin, with outward-facing counter-clockwise triangles unless stated.

// Axis-aligned box with the given half extents; 24 vertices (flat normals), 12 triangles.
MeshData make_box(glm::vec3 half_extents, std::string name = "box");

// Rectangle in the XY plane, width along X, height along Y, facing +Z; 4 vertices, 2 triangles.
MeshData make_quad(float width, float height, std::string name = "quad");

// Icosphere: an icosahedron subdivided `subdivisions` times (each step splits every triangle in
// four and projects onto the sphere): 20 * 4^subdivisions triangles, 10 * 4^subdivisions + 2
// vertices. Precondition: subdivisions <= 7 (327,680 triangles). `inward` flips the winding and the
// normals so that the sphere faces its centre (for enclosures such as the furnace).
MeshData make_icosphere(float radius, int subdivisions, bool inward = false,
                        std::string name = "icosphere");

// Closed cylinder along +Y from y = 0 to y = height with `segments` >= 3 sides and flat caps.
MeshData make_cylinder(float radius, float height, int segments, std::string name = "cylinder");

}  // namespace penumbra
