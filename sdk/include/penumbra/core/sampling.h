// Quasi-Monte Carlo point sets and the mappings from the unit square to directions.
//
// Point sets: Owen-scrambled Sobol' (Burley 2020, "Practical Hash-based Owen Scrambling"), first
// four dimensions, and the Halton sequence in its first 32 dimensions. The first 2^k points of a
// scrambled Sobol' sequence form a (0,k,2)-net in dimensions (0, 1): every elementary interval
// [a 2^-i, (a+1) 2^-i) x [b 2^-j, (b+1) 2^-j) with i + j = k holds exactly one point.
// All functions are pure (thread-safe) and cost tens of nanoseconds.
#pragma once

#include <cstdint>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace penumbra {

// Sobol' point `index` in dimension `dim` (0..3), Owen-scrambled by `seed`; in [0, 1).
float sobol(std::uint32_t index, std::uint32_t dim, std::uint32_t seed);
// The first two dimensions together.
glm::vec2 sobol_2d(std::uint32_t index, std::uint32_t seed);
// sobol_2d of one seed with its scrambles derived once: Sobol2D(seed)(i) == sobol_2d(i, seed), at
// about a third of the cost per point (for the many points of one scramble).
class Sobol2D {
 public:
  explicit Sobol2D(std::uint32_t seed);
  glm::vec2 operator()(std::uint32_t index) const;

 private:
  std::uint32_t shuffle_ = 0, scramble_[2] = {0, 0};
};

// Halton point `index` in dimension `dim` (base = dim-th prime, dim < 32), Cranley-Patterson
// rotated by `rotation` in [0, 1) when non-zero; in [0, 1).
float halton(std::uint32_t index, std::uint32_t dim, float rotation = 0.0f);

// Directions in the local frame whose +Z is the normal. pdf functions give the density per unit
// solid angle of the matching mapping.
glm::vec3 uniform_sphere(glm::vec2 u);
constexpr float uniform_sphere_pdf() { return 0.07957747154594767f; }  // 1 / (4 pi)
glm::vec3 uniform_hemisphere(glm::vec2 u);
constexpr float uniform_hemisphere_pdf() { return 0.15915494309189535f; }  // 1 / (2 pi)
// Cosine-weighted (Malley's method over the concentric disk mapping of Shirley & Chiu 1997).
glm::vec3 cosine_hemisphere(glm::vec2 u);
inline float cosine_hemisphere_pdf(float cos_theta) { return cos_theta * 0.3183098861837907f; }
glm::vec2 concentric_disk(glm::vec2 u);

// An orthonormal basis around unit vector n (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"); returns the world-space direction of local direction d (d.z along n).
glm::vec3 to_world(glm::vec3 n, glm::vec3 d);
void orthonormal_basis(glm::vec3 n, glm::vec3& tangent, glm::vec3& bitangent);

}  // namespace penumbra
