// Ambient-occlusion field bake (see ao_field_baker.h): Kontkanen & Laine 2005, "Ambient
// Occlusion Fields", section 3.1 (hull distance, sampled Omega and Upsilon, the fit of
// 1 / (a r^2 + b r + c) and of C0).
#include "penumbra/ao_field/ao_field_baker.h"

#include "penumbra/ao_field/ao_field_system.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <cstring>
#include <numbers>
#include <optional>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/hash.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/entity_key.h"
#include "ao_fit.h"

namespace penumbra {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr std::uint32_t kSupportDirections = 1024;
constexpr std::size_t kMaxNormalSupports = 65536;  // triangle normals used as extra support directions
constexpr std::uint32_t kRayBlock = 64;

// Step 1's support directions: a Fibonacci sphere plus the triangle normals.
std::vector<glm::dvec3> support_directions(const MeshData& mesh) {
  std::vector<glm::dvec3> dirs;
  dirs.reserve(kSupportDirections + std::min(mesh.triangle_count(), kMaxNormalSupports));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (std::uint32_t i = 0; i < kSupportDirections; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / kSupportDirections;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    dirs.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  for (std::size_t t = 0; t < std::min(mesh.triangle_count(), kMaxNormalSupports); ++t) {
    const glm::dvec3 p0(mesh.positions[mesh.indices[3 * t]]), p1(mesh.positions[mesh.indices[3 * t + 1]]),
        p2(mesh.positions[mesh.indices[3 * t + 2]]);
    const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
    const double len = glm::length(n);
    if (len > 0.0) dirs.push_back(n / len);
  }
  return dirs;
}

std::string caster_context(World& world, Entity e) {
  const Name* name = world.try_get<Name>(e);
  return "ao field " + (name ? "'" + name->value + "' " : std::string()) + "(entity " + std::to_string(e.index) + ")";
}

std::vector<Entity> caster_entities(World& world) {
  std::vector<Entity> out = world.view<AOFieldCaster, Mesh, WorldTransform>().sorted_entities();
  std::erase_if(out, [&](Entity e) { return !world.get<Mesh>(e).data; });
  return out;
}

// True when two casters' settings bake the same field from the same mesh.
bool same_settings(const AOFieldCaster& a, const AOFieldCaster& b) {
  return a.representation == b.representation && a.resolution == b.resolution &&
         a.radial_samples == b.radial_samples && a.rays_per_sample == b.rays_per_sample &&
         a.supersample == b.supersample && a.grid_size == b.grid_size && a.falloff_distance == b.falloff_distance &&
         a.fade_start == b.fade_start && a.inside_occlusion == b.inside_occlusion &&
         a.inside_exponent == b.inside_exponent;
}

void hash_field_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kAOFieldChunkVersion);
  for (Entity e : caster_entities(world)) {
    const AOFieldCaster& c = world.get<AOFieldCaster>(e);
    h.add(std::string_view(entity_key(world, e)));
    hash_fields(ao_field_caster_info(), &c, h);
    // The field is baked in the caster's frame; only the validation (uniform scale) reads its
    // transform, so the scale is hashed (rounded to 2^-16: a turning crate's float noise stays
    // out) and a moved crate stays baked.
    const glm::mat3 m(world.get<WorldTransform>(e).matrix);
    for (int axis = 0; axis < 3; ++axis)
      h.add(static_cast<std::int64_t>(std::llround(double(glm::length(m[axis])) * 65536.0)));
  }
}

// The ray directions of every sample: `rays` Owen-scrambled Sobol' points mapped to the sphere,
// made once per bake; each sample turns them by its own uniformly random rotation (an unbiased,
// still stratified estimate), which costs far less than scrambling every point anew.
std::vector<glm::vec3> sphere_directions(std::uint32_t rays) {
  std::vector<glm::vec3> dirs(rays);
  for (std::uint32_t j = 0; j < rays; ++j) dirs[j] = uniform_sphere(sobol_2d(j, 0x2545f491u));
  return dirs;
}

// A uniformly random rotation (Shoemake 1992, "Uniform random rotations": a unit quaternion from
// three uniform numbers).
glm::mat3 random_rotation(Rng& rng) {
  const float u1 = rng.next_float(), u2 = rng.next_float(), u3 = rng.next_float();
  constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;
  const float a = std::sqrt(1.0f - u1), b = std::sqrt(u1);
  return glm::mat3_cast(glm::quat(b * std::cos(kTwoPi * u3), a * std::sin(kTwoPi * u2), a * std::cos(kTwoPi * u2),
                                  b * std::sin(kTwoPi * u3)));
}

// Omega and the (unnormalised) sum of occluded directions at the points `from[j % from.size()]`
// for rays j along rotation x dirs[j]: one point, or a texel's supersample points whose samples
// are averaged (the filter down).
struct SphereSample {
  std::uint32_t hits = 0;
  glm::dvec3 sum{0.0};
};
SphereSample trace_sphere(const RayScene& scene, std::span<const glm::vec3> from, std::span<const glm::vec3> dirs,
                          const glm::mat3& rotation, float tnear) {
  std::array<Ray, kRayBlock> block;
  std::array<std::uint8_t, kRayBlock> hit{};
  SphereSample out;
  const auto rays = static_cast<std::uint32_t>(dirs.size());
  for (std::uint32_t first = 0; first < rays; first += kRayBlock) {
    const std::uint32_t count = std::min(kRayBlock, rays - first);
    for (std::uint32_t j = 0; j < count; ++j)
      block[j] = Ray{from[(first + j) % from.size()], tnear, rotation * dirs[first + j],
                     std::numeric_limits<float>::infinity()};
    scene.occluded(std::span<const Ray>(block.data(), count), std::span<std::uint8_t>(hit.data(), count));
    for (std::uint32_t j = 0; j < count; ++j)
      if (hit[j]) {
        ++out.hits;
        out.sum += glm::dvec3(block[j].direction);
      }
  }
  return out;
}

// Step 1: r0(w) = min over the support directions u with u.w > 0 of h(u) / (u.w), at most the
// bounding radius.
double hull_distance_of(const std::vector<glm::dvec3>& dirs, const std::vector<double>& support, glm::dvec3 w,
                        double radius) {
  double r0 = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const double c = glm::dot(dirs[k], w);
    if (c > 1e-9) r0 = std::min(r0, support[k] / c);
  }
  return std::min(r0, radius);
}

// Vertices inside the caster's solid (every ray hits: Omega = 4 pi, no direction) would drag the
// trilinear values of points just outside the surface towards full occlusion in a meaningless
// direction; but the field is only evaluated outside the solid. So such vertices are filled
// layer by layer inwards from the surface (a deterministic dilation): each takes the average,
// over the axis directions with two known vertices in a row, of the linear extrapolation of
// those two to its position (the field's slope carried across the surface), or without any, the
// average of its known 6-neighbours; Omega is kept in [0, 4 pi] and |Omega Upsilon| <= Omega.
void fill_inside_vertices(std::uint32_t size, const std::vector<double>& coord, std::vector<AOFieldGridNode>& nodes,
                          std::vector<std::uint8_t> known) {
  const std::size_t sz = std::size_t{size} * size;
  const std::size_t stride[3] = {1, size, sz};
  constexpr float kFourPi = 4.0f * std::numbers::pi_v<float>;
  std::vector<std::pair<std::size_t, AOFieldGridNode>> layer;
  for (std::uint32_t pass = 0; pass < size; ++pass) {
    layer.clear();
    for (std::size_t v = 0; v < nodes.size(); ++v) {
      if (known[v]) continue;
      const std::size_t idx[3] = {v % size, (v / size) % size, v / sz};
      AOFieldGridNode linear{}, constant{};
      int linear_count = 0, constant_count = 0;
      for (int axis = 0; axis < 3; ++axis)
        for (int dir = -1; dir <= 1; dir += 2) {
          const std::size_t i = idx[axis];
          if ((dir < 0 && i < 1) || (dir > 0 && i + 1 >= size)) continue;
          const std::size_t n1 = dir < 0 ? v - stride[axis] : v + stride[axis];
          if (!known[n1]) continue;
          constant.omega += nodes[n1].omega;
          constant.weighted_direction += nodes[n1].weighted_direction;
          ++constant_count;
          if ((dir < 0 && i < 2) || (dir > 0 && i + 2 >= size)) continue;
          const std::size_t n2 = dir < 0 ? n1 - stride[axis] : n1 + stride[axis];
          if (!known[n2]) continue;
          const std::size_t i1 = dir < 0 ? i - 1 : i + 1, i2 = dir < 0 ? i - 2 : i + 2;
          const float t = static_cast<float>((coord[i] - coord[i1]) / (coord[i1] - coord[i2]));
          linear.omega += nodes[n1].omega + (nodes[n1].omega - nodes[n2].omega) * t;
          linear.weighted_direction +=
              nodes[n1].weighted_direction + (nodes[n1].weighted_direction - nodes[n2].weighted_direction) * t;
          ++linear_count;
        }
      if (constant_count == 0) continue;
      const AOFieldGridNode& sum = linear_count > 0 ? linear : constant;
      const float inv = 1.0f / static_cast<float>(linear_count > 0 ? linear_count : constant_count);
      AOFieldGridNode node{std::clamp(sum.omega * inv, 0.0f, kFourPi), sum.weighted_direction * inv};
      const float len = glm::length(node.weighted_direction);
      if (len > node.omega) node.weighted_direction *= node.omega / len;
      layer.push_back({v, node});
    }
    if (layer.empty()) return;
    for (const auto& [v, node] : layer) {
      nodes[v] = node;
      known[v] = 1;
    }
  }
}

// The warped vertex coordinate g(u) r_far of each grid index.
std::vector<double> grid_coordinates(std::uint32_t size, double far) {
  std::vector<double> coord(size);
  for (std::uint32_t i = 0; i < size; ++i) {
    const double u = 2.0 * i / double(size - 1) - 1.0;
    coord[i] = u * std::abs(u) * far;
  }
  return coord;
}

// What one element's results hold: a texel and whether its fit was clamped, or a grid vertex and
// whether any of its rays escaped (known; the others are filled from outside).
constexpr std::size_t kTexelResultBytes = sizeof(AOFieldTexel) + 1;
constexpr std::size_t kNodeResultBytes = sizeof(AOFieldGridNode) + 1;

// One caster's field as a group of elements (cube-map texels or grid vertices), element i drawing
// from Rng::stream(seed, i): prepare() from the mesh, run() over ranges, finish_field() from the
// results alone.
class FieldBake {
 public:
  static Result<std::shared_ptr<FieldBake>> prepare(const AOFieldCaster& caster, const MeshData& mesh,
                                                    std::uint64_t seed, JobContext& jobs, MemoryBudget& budget,
                                                    std::string_view context);
  const AOFieldData& header() const { return header_; }
  std::uint64_t elements() const {
    return grid_ ? std::uint64_t{caster_.grid_size} * caster_.grid_size * caster_.grid_size
                 : 6 * std::uint64_t{header_.resolution} * header_.resolution;
  }
  // Rays per element.
  double element_cost() const {
    return grid_ ? double(caster_.rays_per_sample) : double(caster_.radial_samples) * caster_.rays_per_sample;
  }
  Result<std::vector<std::byte>> run(std::uint64_t begin, std::uint64_t end, JobContext& jobs) const;

 private:
  AOFieldCaster caster_;
  AOFieldData header_;  // every field but the arrays
  bool grid_ = false;
  std::uint64_t seed_ = 0;
  float tnear_ = 0.0f;
  std::optional<RayScene> scene_;  // the caster alone, in its mesh frame
  std::vector<glm::vec3> sphere_dirs_;
  // Radial fit: step 1's support directions and function.
  std::vector<glm::dvec3> dirs_;
  std::vector<double> support_;
  // Grid: the vertex coordinates and, per index, the distance from 0 to the span of the cells
  // around the vertex (0 when it holds 0).
  std::vector<double> coord_, near_span_;
};

Result<std::shared_ptr<FieldBake>> FieldBake::prepare(const AOFieldCaster& caster, const MeshData& mesh,
                                                      std::uint64_t seed, JobContext& jobs, MemoryBudget& budget,
                                                      std::string_view context) {
  PENUMBRA_TRY(validate_ao_field_caster(caster, glm::mat4(1.0f), context));
  PENUMBRA_TRY(mesh.validate(context));
  // Field origin: the area-weighted centroid of the surface (inside the convex hull).
  glm::dvec3 centroid(0.0);
  double radius = 0.0;
  if (!ao_field_origin(mesh, centroid, radius))
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": mesh '" + mesh.name +
                                                   "' has no triangle of non-zero area; give the caster geometry");
  const double r_far = caster.falloff_distance > 0.0f ? double(caster.falloff_distance) : 6.0 * radius;
  if (!(r_far > radius))
    return make_error(ErrorCode::InvalidArgument,
                      std::string(context) + ": falloff_distance " + std::to_string(r_far) +
                          " does not reach beyond the caster (bounding radius " + std::to_string(radius) +
                          "); use at least 2x the bounding radius, or 0 for 6x");

  auto bake = std::make_shared<FieldBake>();
  bake->caster_ = caster;
  bake->grid_ = caster.representation == AOFieldRepresentation::Grid;
  bake->seed_ = seed;
  const std::uint32_t res = bake->grid_ ? 0 : caster.resolution;
  // The arrays must fit the budget before any ray is traced.
  const std::uint64_t need = bake->grid_ ? std::uint64_t{caster.grid_size} * caster.grid_size * caster.grid_size *
                                               (sizeof(AOFieldGridNode) + kNodeResultBytes)
                                         : 6 * std::uint64_t{res} * res * (sizeof(AOFieldTexel) + kTexelResultBytes);
  if (auto st = budget.reserve(std::string(context) + " texels", need); !st)
    return make_error(ErrorCode::OutOfBudget, st.error().message + (bake->grid_ ? "; use a smaller grid_size"
                                                                                  : "; use a lower resolution"));
  budget.release(need);

  World alone;
  {
    const Entity e = alone.create();
    alone.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(mesh)});
    alone.add<WorldTransform>(e);
    alone.add<Static>(e);
  }
  RaySceneOptions options;
  options.build_threads = jobs.concurrency();
  auto scene = RayScene::build(alone, options);
  if (!scene) return scene.error();
  bake->scene_.emplace(std::move(*scene));

  AOFieldData& data = bake->header_;
  data.representation = caster.representation;
  data.resolution = res;
  data.grid_size = bake->grid_ ? caster.grid_size : 0;
  data.centre = glm::vec3(centroid);
  data.bounding_radius = static_cast<float>(radius);
  data.r_far = static_cast<float>(r_far);
  data.fade_start = caster.fade_start;
  data.inside_occlusion = caster.inside_occlusion;
  data.inside_exponent = caster.inside_exponent;
  bake->tnear_ = static_cast<float>(1e-6 * radius);
  bake->sphere_dirs_ = sphere_directions(caster.rays_per_sample);
  if (bake->grid_) {
    const std::uint32_t size = caster.grid_size;
    bake->coord_ = grid_coordinates(size, r_far);
    bake->near_span_.resize(size);
    for (std::uint32_t i = 0; i < size; ++i) {
      const double lo = bake->coord_[i == 0 ? 0 : i - 1], hi = bake->coord_[std::min(i + 1, size - 1)];
      bake->near_span_[i] = lo <= 0.0 && hi >= 0.0 ? 0.0 : std::min(std::abs(lo), std::abs(hi));
    }
    return bake;
  }
  // Step 1's support function h(u) = max_v (v - centre) . u.
  bake->dirs_ = support_directions(mesh);
  bake->support_.assign(bake->dirs_.size(), 0.0);
  for (std::size_t i = 0; i < bake->dirs_.size(); ++i) {
    double h = -std::numeric_limits<double>::infinity();
    for (const glm::vec3& v : mesh.positions) h = std::max(h, glm::dot(glm::dvec3(v) - centroid, bake->dirs_[i]));
    bake->support_[i] = std::max(h, 0.0);
  }
  return bake;
}

Result<std::vector<std::byte>> FieldBake::run(std::uint64_t first, std::uint64_t last, JobContext& jobs) const {
  const std::size_t count = static_cast<std::size_t>(last - first);
  std::vector<std::byte> out(count * (grid_ ? kNodeResultBytes : kTexelResultBytes));
  jobs.begin_stage("ao field", count);
  const RayScene& scene = *scene_;
  const glm::dvec3 centre(header_.centre);
  if (grid_) {
    // The grid representation (Malmer et al. 2007): Omega and Omega x Upsilon at every vertex that
    // a point within r_far can interpolate from (the others stay 0).
    const std::uint32_t size = caster_.grid_size;
    const double far = header_.r_far;
    PENUMBRA_TRY(jobs.parallel_for(count, 256, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const std::size_t v = static_cast<std::size_t>(first) + i;
        const std::size_t x = v % size, y = (v / size) % size, z = v / (std::size_t{size} * size);
        AOFieldGridNode node;
        std::uint8_t known = 1;
        const glm::dvec3 span(near_span_[x], near_span_[y], near_span_[z]);
        if (glm::length(span) < far) {
          Rng rng = Rng::stream(seed_, v);
          const glm::vec3 at(centre + glm::dvec3(coord_[x], coord_[y], coord_[z]));
          const SphereSample smp =
              trace_sphere(scene, std::span<const glm::vec3>(&at, 1), sphere_dirs_, random_rotation(rng), tnear_);
          const double omega = 4.0 * kPi * smp.hits / caster_.rays_per_sample;
          const double len = glm::length(smp.sum);
          node.omega = static_cast<float>(omega);
          node.weighted_direction = len > 0.0 ? glm::vec3(omega * smp.sum / len) : glm::vec3(0.0f);
          known = smp.hits < caster_.rays_per_sample ? 1 : 0;
        }
        std::byte* o = out.data() + i * kNodeResultBytes;
        std::memcpy(o, &node, sizeof node);
        std::memcpy(o + sizeof node, &known, 1);
      }
    }));
    return out;
  }

  const std::uint32_t res = header_.resolution, radii = caster_.radial_samples, rays = caster_.rays_per_sample,
                      sub = caster_.supersample;
  const double radius = header_.bounding_radius, r_far = header_.r_far;
  const glm::vec3 origin_centre(header_.centre);
  PENUMBRA_TRY(jobs.parallel_for(count, 4, [&](std::size_t begin, std::size_t end) {
    std::vector<AORadialSample> samples(radii);
    std::vector<glm::vec3> sub_dirs(std::size_t{sub} * sub), from(sub_dirs.size());
    for (std::size_t n = begin; n < end; ++n) {
      const std::size_t i = static_cast<std::size_t>(first) + n;
      Rng rng = Rng::stream(seed_, i);
      const auto face = static_cast<std::uint32_t>(i / (std::size_t{res} * res));
      const auto row = static_cast<std::uint32_t>((i / res) % res), col = static_cast<std::uint32_t>(i % res);
      const float texel = 2.0f / static_cast<float>(res);
      const float s = (static_cast<float>(col) + 0.5f) * texel - 1.0f;
      const float t = (static_cast<float>(row) + 0.5f) * texel - 1.0f;
      const glm::vec3 w = cube_direction(face, s, t);
      const glm::dvec3 wd(w);
      // Step 1: the hull distance along w.
      const double r0 = hull_distance_of(dirs_, support_, wd, radius);
      // The supersample directions: the centres of the sub x sub texels of the cube map built at
      // sub x the resolution that cover this texel; the sampled radii start outside the hull
      // along all of them.
      double r0_max = r0;
      for (std::uint32_t b = 0; b < sub; ++b)
        for (std::uint32_t a = 0; a < sub; ++a) {
          const float ds = (static_cast<float>(a) + 0.5f) / static_cast<float>(sub) - 0.5f;
          const float dt = (static_cast<float>(b) + 0.5f) / static_cast<float>(sub) - 0.5f;
          const glm::vec3 d = sub == 1 ? w : cube_direction(face, s + ds * texel, t + dt * texel);
          sub_dirs[b * sub + a] = d;
          if (sub > 1) r0_max = std::max(r0_max, hull_distance_of(dirs_, support_, glm::dvec3(d), radius));
        }
      // Step 2: Omega and Upsilon at log-spaced radii from just outside the hull to r_far, each
      // averaged over the supersample directions (rays spread over them in turn).
      const double r_lo = std::min(std::max(r0_max * (1.0 + 1e-3), 1e-2 * radius), 0.5 * r_far);
      for (std::uint32_t k = 0; k < radii; ++k) {
        const double r = r_lo * std::pow(r_far / r_lo, double(k) / double(radii - 1));
        for (std::size_t d = 0; d < sub_dirs.size(); ++d) from[d] = origin_centre + static_cast<float>(r) * sub_dirs[d];
        const SphereSample smp = trace_sphere(scene, from, sphere_dirs_, random_rotation(rng), tnear_);
        AORadialSample& rs = samples[k];
        rs.rho = r / radius;
        rs.omega = 4.0 * kPi * smp.hits / rays;
        const double len = glm::length(smp.sum);
        rs.upsilon = len > 0.0 ? smp.sum / len : -wd;
      }
      // Steps 3 and 4: the fits, in units of the bounding radius, then back to mesh units.
      AOOmegaFit p{};
      const std::uint8_t clamped = fit_ao_omega(samples, r0 / radius, r_far / radius, p) ? 1 : 0;
      const glm::dvec3 c0 = fit_ao_c0(samples, wd, r0 / radius) * radius;
      AOFieldTexel tx;
      tx.a = static_cast<float>(p[0] / (radius * radius));
      tx.b = static_cast<float>(p[1] / radius);
      tx.c = static_cast<float>(p[2]);
      tx.r0 = static_cast<float>(r0);
      tx.c0 = glm::vec3(c0);
      std::byte* o = out.data() + n * kTexelResultBytes;
      std::memcpy(o, &tx, sizeof tx);
      std::memcpy(o + sizeof tx, &clamped, 1);
    }
  }));
  return out;
}

// The field from its header and every element's results: the texels and the count of clamped
// fits, or the grid vertices with those inside the caster's solid filled from outside (the one
// step that needs every vertex).
Result<AOFieldData> finish_field(AOFieldData data, std::span<const std::byte> results, std::string_view context) {
  const bool grid = data.representation == AOFieldRepresentation::Grid;
  const std::size_t count = grid ? std::size_t{data.grid_size} * data.grid_size * data.grid_size
                                 : 6 * std::size_t{data.resolution} * data.resolution;
  const std::size_t each = grid ? kNodeResultBytes : kTexelResultBytes;
  if (count == 0 || results.size() != count * each || (grid && data.grid_size < 2))
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": " + std::to_string(results.size()) +
                                                   " bytes of results for " + std::to_string(count) +
                                                   " elements; the part is corrupt, re-bake it");
  if (!grid) {
    data.texels.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      std::memcpy(&data.texels[i], results.data() + i * each, sizeof(AOFieldTexel));
      if (results[i * each + sizeof(AOFieldTexel)] != std::byte{0}) ++data.clamped_fits;
    }
    return data;
  }
  data.nodes.resize(count);
  std::vector<std::uint8_t> known(count);
  for (std::size_t i = 0; i < count; ++i) {
    std::memcpy(&data.nodes[i], results.data() + i * each, sizeof(AOFieldGridNode));
    known[i] = results[i * each + sizeof(AOFieldGridNode)] != std::byte{0} ? 1 : 0;
  }
  fill_inside_vertices(data.grid_size, grid_coordinates(data.grid_size, data.r_far), data.nodes, std::move(known));
  return data;
}

// A group's header: the field's description (as its chunk lays it out), then the casters that take
// this field (their keys and their places in entity order; instances of one mesh and settings share
// one bake).
Status read_field_header(ByteReader& r, AOFieldData& d) {
  PENUMBRA_TRY(read_ao_field_description(r, d));
  const bool grid = d.representation == AOFieldRepresentation::Grid;
  if ((!grid && d.representation != AOFieldRepresentation::RadialFit) || (grid ? d.grid_size : d.resolution) > 1024)
    return make_error(ErrorCode::InvalidInput, r.context() + ": representation " +
                                                   std::to_string(static_cast<std::uint32_t>(d.representation)) +
                                                   " of size " + std::to_string(grid ? d.grid_size : d.resolution) +
                                                   " is out of range; the part is corrupt");
  return {};
}

constexpr std::uint64_t kTexelBlock = 16;   // cube-map texels per work item
constexpr std::uint64_t kNodeBlock = 4096;  // grid vertices per work item

// A group per distinct field (casters sharing a MeshData and settings share the first one's, in
// entity order), named by the first caster's key.
Result<BakeWork> plan_fields(BakeInputs& in) {
  struct Distinct {
    const MeshData* mesh;
    AOFieldCaster settings;
    std::vector<std::pair<std::uint32_t, std::string>> casters;  // place in entity order, key
    std::shared_ptr<FieldBake> bake;
  };
  std::vector<Distinct> distinct;
  const std::vector<Entity> casters = caster_entities(in.world);
  for (std::size_t i = 0; i < casters.size(); ++i) {
    const Entity e = casters[i];
    const AOFieldCaster caster = in.world.get<AOFieldCaster>(e);
    const std::string context = caster_context(in.world, e);
    PENUMBRA_TRY(validate_ao_field_caster(caster, in.world.get<WorldTransform>(e).matrix, context));
    const MeshData* mesh = in.world.get<Mesh>(e).data.get();
    auto key = bake_key(in, e, context);
    if (!key) return key.error();
    const auto shared = std::find_if(distinct.begin(), distinct.end(), [&](const Distinct& d) {
      return d.mesh == mesh && same_settings(d.settings, caster);
    });
    if (shared != distinct.end()) {
      shared->casters.push_back({static_cast<std::uint32_t>(i), std::move(*key)});
      continue;
    }
    // The caster's random streams follow its key, not its index: the same scene built in another
    // order bakes the same field.
    Hasher seed;
    seed.add(in.settings.seed);
    seed.add(std::string_view(*key));
    auto bake = FieldBake::prepare(caster, *mesh, seed.digest(), in.jobs, in.budget, context);
    if (!bake) return bake.error();
    distinct.push_back({mesh, caster, {{static_cast<std::uint32_t>(i), std::move(*key)}}, std::move(*bake)});
  }
  BakeWork work;
  auto bakes = std::make_shared<std::vector<std::shared_ptr<FieldBake>>>();
  for (Distinct& d : distinct) {
    ByteWriter header;
    write_ao_field_description(header, d.bake->header());
    header.write(static_cast<std::uint32_t>(d.casters.size()));
    for (const auto& [place, key] : d.casters) {
      header.write(place);
      header.write_string(key);
    }
    const bool grid = d.settings.representation == AOFieldRepresentation::Grid;
    work.groups.push_back(BakeGroup{d.casters.front().second, d.bake->elements(), grid ? kNodeBlock : kTexelBlock,
                                    d.bake->element_cost(), header.take()});
    bakes->push_back(d.bake);
  }
  work.run = [bakes](std::size_t g, std::uint64_t begin, std::uint64_t end, JobContext& jobs) {
    return (*bakes)[g]->run(begin, end, jobs);
  };
  return work;
}

// One AOFC chunk per caster, in entity order.
Result<std::vector<BakeChunk>> finish_fields(std::span<const BakedGroup> groups, JobContext&) {
  std::vector<std::pair<std::uint32_t, BakeChunk>> placed;
  for (const BakedGroup& g : groups) {
    const std::string context = "ao field '" + g.group->name + "'";
    ByteReader header(g.group->header, context + " header");
    AOFieldData data;
    PENUMBRA_TRY(read_field_header(header, data));
    std::uint32_t count = 0;
    PENUMBRA_TRY(header.read(count));
    if (count == 0 || count > header.remaining())
      return make_error(ErrorCode::InvalidInput, context + ": " + std::to_string(count) + " casters; the part is corrupt");
    std::vector<std::pair<std::uint32_t, std::string>> casters(count);
    for (auto& [place, key] : casters) {
      PENUMBRA_TRY(header.read(place));
      PENUMBRA_TRY(header.read_string(key));
    }
    PENUMBRA_TRY(header.finish());
    auto field = finish_field(std::move(data), g.results, context);
    if (!field) return field.error();
    for (auto& [place, key] : casters) {
      field->key = std::move(key);
      placed.push_back({place, write_ao_field_chunk(*field)});
    }
  }
  std::stable_sort(placed.begin(), placed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<BakeChunk> chunks;
  for (auto& [place, chunk] : placed) chunks.push_back(std::move(chunk));
  return chunks;
}

}  // namespace

Result<AOFieldData> bake_ao_field(const AOFieldCaster& caster, const MeshData& mesh, std::uint64_t seed,
                                  JobContext& jobs, MemoryBudget& budget, std::string_view context) {
  auto bake = FieldBake::prepare(caster, mesh, seed, jobs, budget, context);
  if (!bake) return bake.error();
  auto results = (*bake)->run(0, (*bake)->elements(), jobs);
  if (!results) return results.error();
  return finish_field((*bake)->header(), *results, context);
}

void register_ao_field_baker(World& world) {
  Baker b = baker_for(ao_field_module());
  b.reads_lights = false;
  b.stages = 1;
  b.hash_inputs = hash_field_inputs;
  b.plan = plan_fields;
  b.finish = finish_fields;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
