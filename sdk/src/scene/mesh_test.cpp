#include "penumbra/scene/mesh.h"

#include <cmath>
#include <map>
#include <numbers>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

namespace penumbra {
namespace {

// Signed volume by the divergence theorem: sum over triangles of dot(a, cross(b, c)) / 6.
// Positive for a closed mesh with outward counter-clockwise winding.
double signed_volume(const MeshData& m) {
  double v = 0.0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const glm::dvec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                     c = m.positions[m.indices[3 * t + 2]];
    v += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  return v;
}

double area(const MeshData& m) {
  double s = 0.0;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const glm::dvec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                     c = m.positions[m.indices[3 * t + 2]];
    s += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  return s;
}

// Every directed edge appears once and its reverse once: the surface is closed and consistently wound.
void expect_closed_and_consistent(const MeshData& m) {
  std::map<std::tuple<float, float, float, float, float, float>, int> directed;
  for (std::size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 a = m.positions[m.indices[3 * t + k]], b = m.positions[m.indices[3 * t + (k + 1) % 3]];
      ++directed[{a.x, a.y, a.z, b.x, b.y, b.z}];
    }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    const auto [ax, ay, az, bx, by, bz] = edge;
    auto reverse = directed.find({bx, by, bz, ax, ay, az});
    ASSERT_NE(reverse, directed.end());
    EXPECT_EQ(reverse->second, 1);
  }
}

// Each vertex normal points the same way as the face normals of its triangles.
void expect_normals_match_winding(const MeshData& m) {
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    const glm::vec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                    c = m.positions[m.indices[3 * t + 2]];
    const glm::vec3 face = glm::cross(b - a, c - a);
    for (int k = 0; k < 3; ++k) EXPECT_GT(glm::dot(face, m.normals[m.indices[3 * t + k]]), 0.0f) << "triangle " << t;
  }
}

TEST(Mesh, BoxVolumeAreaAndWinding) {
  const MeshData box = make_box({0.5f, 1.0f, 2.0f});
  ASSERT_TRUE(box.validate("box").ok());
  EXPECT_EQ(box.triangle_count(), 12u);
  EXPECT_NEAR(signed_volume(box), 1.0 * 2.0 * 4.0, 1e-5);
  EXPECT_NEAR(area(box), 2.0 * (1 * 2 + 2 * 4 + 1 * 4), 1e-5);
  EXPECT_EQ(box.bounds.min, glm::vec3(-0.5f, -1.0f, -2.0f));
  EXPECT_EQ(box.bounds.max, glm::vec3(0.5f, 1.0f, 2.0f));
  expect_normals_match_winding(box);
  expect_closed_and_consistent(box);
}

TEST(Mesh, QuadFacesPlusZ) {
  const MeshData quad = make_quad(2.0f, 3.0f);
  ASSERT_TRUE(quad.validate("quad").ok());
  EXPECT_NEAR(area(quad), 6.0, 1e-6);
  expect_normals_match_winding(quad);
  EXPECT_EQ(quad.normals[0], glm::vec3(0, 0, 1));
}

TEST(Mesh, IcosphereCountsRadiusAndConvergingVolume) {
  double previous_error = 1.0;
  for (int s = 0; s <= 4; ++s) {
    const MeshData sphere = make_icosphere(2.0f, s);
    ASSERT_TRUE(sphere.validate("icosphere").ok());
    const auto four_s = static_cast<std::size_t>(std::pow(4, s));
    EXPECT_EQ(sphere.triangle_count(), 20 * four_s);
    EXPECT_EQ(sphere.positions.size(), 10 * four_s + 2);
    for (const glm::vec3& p : sphere.positions) EXPECT_NEAR(glm::length(p), 2.0f, 1e-5f);
    expect_normals_match_winding(sphere);
    expect_closed_and_consistent(sphere);
    // Inscribed polyhedra: the volume approaches 4/3 pi r^3 from below, monotonically.
    const double exact = 4.0 / 3.0 * std::numbers::pi * 8.0;
    const double error = (exact - signed_volume(sphere)) / exact;
    EXPECT_GT(error, 0.0);
    EXPECT_LT(error, previous_error);
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.005);
}

TEST(Mesh, InwardIcosphereFacesItsCentre) {
  const MeshData sphere = make_icosphere(1.0f, 2, /*inward=*/true);
  ASSERT_TRUE(sphere.validate("inward").ok());
  EXPECT_LT(signed_volume(sphere), 0.0);
  expect_normals_match_winding(sphere);
  for (std::size_t i = 0; i < sphere.positions.size(); ++i)
    EXPECT_NEAR(glm::dot(sphere.normals[i], sphere.positions[i]), -1.0f, 1e-5f);
}

TEST(Mesh, CylinderVolumeIsThePrismClosedForm) {
  const int n = 24;
  const MeshData cyl = make_cylinder(0.5f, 2.0f, n);
  ASSERT_TRUE(cyl.validate("cylinder").ok());
  // A prism over a regular n-gon: (n/2) r^2 sin(2 pi / n) * h.
  const double exact = 0.5 * n * 0.25 * std::sin(2.0 * std::numbers::pi / n) * 2.0;
  EXPECT_NEAR(signed_volume(cyl), exact, 1e-5);
  expect_normals_match_winding(cyl);
}

TEST(Mesh, ComputedNormalsMatchAnalyticOnes) {
  MeshData sphere = make_icosphere(1.0f, 3);
  const std::vector<glm::vec3> analytic = sphere.normals;
  compute_normals(sphere);
  for (std::size_t i = 0; i < analytic.size(); ++i) {
    EXPECT_NEAR(glm::length(sphere.normals[i]), 1.0f, 1e-5f);
    EXPECT_GT(glm::dot(sphere.normals[i], analytic[i]), 0.999f);
  }
  MeshData box = make_box(glm::vec3(1.0f));
  const std::vector<glm::vec3> flat = box.normals;
  compute_normals(box);
  for (std::size_t i = 0; i < flat.size(); ++i) EXPECT_NEAR(glm::dot(box.normals[i], flat[i]), 1.0f, 1e-6f);
}

TEST(Mesh, DegenerateTrianglesAreRemovedAndCounted) {
  MeshData m = make_quad(1.0f, 1.0f);
  m.positions.push_back({2, 0, 0});
  m.positions.push_back({3, 0, 0});
  m.positions.push_back({4, 0, 0});
  m.normals.resize(m.positions.size(), glm::vec3(0, 0, 1));
  m.uvs.resize(m.positions.size());
  for (std::uint32_t i : {4u, 5u, 6u, 0u, 0u, 1u, 0u, 1u, 1u}) m.indices.push_back(i);  // collinear, two repeats
  EXPECT_FALSE(m.validate("m").ok());
  EXPECT_EQ(remove_degenerate_triangles(m), 3u);
  EXPECT_EQ(m.triangle_count(), 2u);
  EXPECT_TRUE(m.validate("m").ok());
  EXPECT_EQ(remove_degenerate_triangles(m), 0u);
}

TEST(Mesh, ValidateNamesTheContextAndTheProblem) {
  MeshData m = make_quad(1.0f, 1.0f);
  m.indices[4] = 9;
  Status s = m.validate("scene.gltf: meshes[2]");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(s.error().message.find("scene.gltf: meshes[2]"), std::string::npos);
  EXPECT_NE(s.error().message.find("index 4"), std::string::npos);

  m = make_quad(1.0f, 1.0f);
  m.normals[1].y = std::nanf("");
  s = m.validate("q");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("NORMAL[1]"), std::string::npos);

  m = make_quad(1.0f, 1.0f);
  m.uvs.pop_back();
  EXPECT_FALSE(m.validate("q").ok());
}

TEST(Mesh, BytesCountsTheArrays) {
  const MeshData small = make_icosphere(1.0f, 1), large = make_icosphere(1.0f, 3);
  EXPECT_GE(small.bytes(), small.positions.size() * (2 * sizeof(glm::vec3) + sizeof(glm::vec2)) +
                                small.indices.size() * sizeof(std::uint32_t));
  EXPECT_GT(large.bytes(), 10 * small.bytes());
}

}  // namespace
}  // namespace penumbra
