// MeshData invariants, normals, degenerate-triangle removal and primitive builders.
#include "penumbra/scene/mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>

#include <glm/geometric.hpp>

namespace penumbra {

namespace {

bool finite(glm::vec2 v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(glm::vec4 v) { return finite(glm::vec3(v)) && std::isfinite(v.w); }

template <class V>
Status check_attribute(std::string_view context, const char* name, const std::vector<V>& values,
                       std::size_t vertex_count) {
  if (!values.empty() && values.size() != vertex_count)
    return make_error(ErrorCode::InvalidInput,
                      std::string(context) + ": " + name + " has " + std::to_string(values.size()) +
                          " entries but there are " + std::to_string(vertex_count) +
                          " positions; every attribute needs one value per vertex");
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!finite(values[i]))
      return make_error(ErrorCode::InvalidInput,
                        std::string(context) + ": " + name + "[" + std::to_string(i) +
                            "] is not finite (NaN or Inf); fix the exporter or the source data");
  return {};
}

glm::vec3 triangle_cross(const MeshData& mesh, std::size_t t) {
  const glm::vec3 a = mesh.positions[mesh.indices[3 * t]];
  const glm::vec3 b = mesh.positions[mesh.indices[3 * t + 1]];
  const glm::vec3 c = mesh.positions[mesh.indices[3 * t + 2]];
  return glm::cross(b - a, c - a);
}

}  // namespace

std::size_t MeshData::bytes() const {
  return sizeof(MeshData) + name.capacity() + positions.capacity() * sizeof(glm::vec3) +
         normals.capacity() * sizeof(glm::vec3) + uvs.capacity() * sizeof(glm::vec2) +
         joints.capacity() * sizeof(glm::u16vec4) + weights.capacity() * sizeof(glm::vec4) +
         indices.capacity() * sizeof(std::uint32_t);
}

Status MeshData::validate(std::string_view context) const {
  const std::size_t n = positions.size();
  PENUMBRA_TRY(check_attribute(context, "POSITION", positions, n));
  PENUMBRA_TRY(check_attribute(context, "NORMAL", normals, n));
  PENUMBRA_TRY(check_attribute(context, "TEXCOORD_0", uvs, n));
  PENUMBRA_TRY(check_attribute(context, "WEIGHTS_0", weights, n));
  if (!joints.empty() && joints.size() != n)
    return make_error(ErrorCode::InvalidInput,
                      std::string(context) + ": JOINTS_0 has " + std::to_string(joints.size()) +
                          " entries but there are " + std::to_string(n) + " positions");
  if (joints.empty() != weights.empty())
    return make_error(ErrorCode::InvalidInput,
                      std::string(context) + ": JOINTS_0 and WEIGHTS_0 must come together");
  if (indices.size() % 3 != 0)
    return make_error(ErrorCode::InvalidInput,
                      std::string(context) + ": " + std::to_string(indices.size()) +
                          " indices is not a multiple of 3; only triangle lists are supported");
  for (std::size_t i = 0; i < indices.size(); ++i)
    if (indices[i] >= n)
      return make_error(ErrorCode::InvalidInput,
                        std::string(context) + ": index " + std::to_string(i) + " is " +
                            std::to_string(indices[i]) + " but there are only " +
                            std::to_string(n) + " vertices");
  for (std::size_t t = 0; t < triangle_count(); ++t)
    if (glm::dot(triangle_cross(*this, t), triangle_cross(*this, t)) == 0.0f)
      return make_error(ErrorCode::InvalidInput,
                        std::string(context) + ": triangle " + std::to_string(t) +
                            " has zero area; remove it (remove_degenerate_triangles)");
  return {};
}

void compute_bounds(MeshData& mesh) {
  mesh.bounds = Aabb{};
  for (const glm::vec3& p : mesh.positions) mesh.bounds.extend(p);
}

void compute_normals(MeshData& mesh) {
  // Sum the unnormalised face normals: their length is twice the area, so this is area weighting.
  mesh.normals.assign(mesh.positions.size(), glm::vec3(0.0f));
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const glm::vec3 n = triangle_cross(mesh, t);
    for (int k = 0; k < 3; ++k) mesh.normals[mesh.indices[3 * t + k]] += n;
  }
  for (glm::vec3& n : mesh.normals) {
    const float len = glm::length(n);
    n = len > 0.0f && std::isfinite(len) ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
  }
}

std::size_t remove_degenerate_triangles(MeshData& mesh, float relative_epsilon) {
  compute_bounds(mesh);
  const glm::vec3 diagonal = mesh.bounds.empty() ? glm::vec3(0.0f) : mesh.bounds.extent();
  const float min_area = relative_epsilon * glm::dot(diagonal, diagonal);
  std::size_t kept = 0;
  const std::size_t count = mesh.triangle_count();
  for (std::size_t t = 0; t < count; ++t) {
    const std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    const float area = 0.5f * glm::length(triangle_cross(mesh, t));
    if (a == b || b == c || a == c || !(area > min_area)) continue;
    mesh.indices[3 * kept] = a;
    mesh.indices[3 * kept + 1] = b;
    mesh.indices[3 * kept + 2] = c;
    ++kept;
  }
  mesh.indices.resize(3 * kept);
  return count - kept;
}

MeshData make_box(glm::vec3 h, std::string name) {
  MeshData mesh;
  mesh.name = std::move(name);
  // One face per axis direction: normal n, tangent u, bitangent v = cross(n, u).
  const std::array<glm::vec3, 6> normals = {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                                            glm::vec3(0, -1, 0), glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)};
  for (const glm::vec3& n : normals) {
    const glm::vec3 u = std::abs(n.y) > 0.5f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
    const glm::vec3 v = glm::cross(n, u);
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    const std::array<glm::vec2, 4> corners = {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1),
                                              glm::vec2(-1, 1)};
    for (const glm::vec2& c : corners) {
      mesh.positions.push_back(h * (n + c.x * u + c.y * v));
      mesh.normals.push_back(n);
      mesh.uvs.push_back(0.5f * (c + 1.0f));
    }
    // cross(u, v) = n, so (u, v) order is counter-clockwise seen from outside.
    for (std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
  }
  compute_bounds(mesh);
  return mesh;
}

MeshData make_quad(float width, float height, std::string name) {
  MeshData mesh;
  mesh.name = std::move(name);
  const float x = 0.5f * width, y = 0.5f * height;
  mesh.positions = {{-x, -y, 0}, {x, -y, 0}, {x, y, 0}, {-x, y, 0}};
  mesh.normals.assign(4, glm::vec3(0, 0, 1));
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  compute_bounds(mesh);
  return mesh;
}

MeshData make_icosphere(float radius, int subdivisions, bool inward, std::string name) {
  MeshData mesh;
  mesh.name = std::move(name);
  // Step 1: the regular icosahedron, vertices on the unit sphere (golden-ratio rectangles).
  const float phi = (1.0f + std::sqrt(5.0f)) * 0.5f;
  std::vector<glm::vec3> dirs = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                                 {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                                 {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  for (glm::vec3& d : dirs) d = glm::normalize(d);
  std::vector<std::uint32_t> tris = {0, 11, 5, 0, 5,  1,  0,  1,  7,  0,  7, 10, 0, 10, 11,
                                     1, 5,  9, 5, 11, 4,  11, 10, 2,  10, 7, 6,  7, 1,  8,
                                     3, 9,  4, 3, 4,  2,  3,  2,  6,  3,  6, 8,  3, 8,  9,
                                     4, 9,  5, 2, 4,  11, 6,  2,  10, 8,  6, 7,  9, 8,  1};
  // Step 2: split each triangle in four, sharing edge midpoints, projected onto the sphere.
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, inserted] = midpoints.try_emplace(key, static_cast<std::uint32_t>(dirs.size()));
      if (inserted) dirs.push_back(glm::normalize(dirs[a] + dirs[b]));
      return it->second;
    };
    std::vector<std::uint32_t> next;
    next.reserve(tris.size() * 4);
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      const std::uint32_t a = tris[t], b = tris[t + 1], c = tris[t + 2];
      const std::uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      for (std::uint32_t i : {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca}) next.push_back(i);
    }
    tris = std::move(next);
  }
  // Step 3: scale, orient and attach normals and equirectangular uvs.
  for (const glm::vec3& d : dirs) {
    mesh.positions.push_back(radius * d);
    mesh.normals.push_back(inward ? -d : d);
    mesh.uvs.push_back({0.5f + std::atan2(d.z, d.x) * 0.5f * std::numbers::inv_pi_v<float>,
                        std::acos(std::clamp(d.y, -1.0f, 1.0f)) * std::numbers::inv_pi_v<float>});
  }
  if (inward)
    for (std::size_t t = 0; t < tris.size(); t += 3) std::swap(tris[t + 1], tris[t + 2]);
  mesh.indices = std::move(tris);
  compute_bounds(mesh);
  return mesh;
}

MeshData make_cylinder(float radius, float height, int segments, std::string name) {
  MeshData mesh;
  mesh.name = std::move(name);
  const auto n = static_cast<std::uint32_t>(std::max(segments, 3));
  auto ring = [&](std::uint32_t i) {
    const float a = 2.0f * std::numbers::pi_v<float> * static_cast<float>(i) / static_cast<float>(n);
    return glm::vec2(std::cos(a), std::sin(a));
  };
  // Side: two vertices per segment edge, smooth radial normals.
  for (std::uint32_t i = 0; i <= n; ++i) {
    const glm::vec2 c = ring(i % n);
    const float u = static_cast<float>(i) / static_cast<float>(n);
    mesh.positions.push_back({radius * c.x, 0.0f, radius * c.y});
    mesh.positions.push_back({radius * c.x, height, radius * c.y});
    mesh.normals.push_back({c.x, 0.0f, c.y});
    mesh.normals.push_back({c.x, 0.0f, c.y});
    mesh.uvs.push_back({u, 0.0f});
    mesh.uvs.push_back({u, 1.0f});
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t b0 = 2 * i, t0 = 2 * i + 1, b1 = 2 * i + 2, t1 = 2 * i + 3;
    // Angle increases from +X towards +Z, so (b0, t0, b1) faces outward.
    for (std::uint32_t k : {b0, t0, b1, b1, t0, t1}) mesh.indices.push_back(k);
  }
  // Caps: a centre vertex and a fan, normals -Y (bottom) and +Y (top).
  for (int cap = 0; cap < 2; ++cap) {
    const float y = cap == 0 ? 0.0f : height;
    const glm::vec3 normal(0.0f, cap == 0 ? -1.0f : 1.0f, 0.0f);
    const auto centre = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.push_back({0.0f, y, 0.0f});
    mesh.normals.push_back(normal);
    mesh.uvs.push_back({0.5f, 0.5f});
    for (std::uint32_t i = 0; i < n; ++i) {
      const glm::vec2 c = ring(i);
      mesh.positions.push_back({radius * c.x, y, radius * c.y});
      mesh.normals.push_back(normal);
      mesh.uvs.push_back(0.5f * (c + 1.0f));
    }
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t a = centre + 1 + i, b = centre + 1 + (i + 1) % n;
      if (cap == 0) {
        for (std::uint32_t k : {centre, a, b}) mesh.indices.push_back(k);
      } else {
        for (std::uint32_t k : {centre, b, a}) mesh.indices.push_back(k);
      }
    }
  }
  compute_bounds(mesh);
  return mesh;
}

}  // namespace penumbra
