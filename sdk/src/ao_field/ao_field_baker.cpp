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
#include <numbers>

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

Result<std::vector<BakeChunk>> bake_fields(BakeInputs& in) {
  std::vector<BakeChunk> chunks;
  // Casters that share a MeshData and settings (instances, e.g. the courtyard's crates) share the
  // field of the first of them in entity order.
  struct Baked {
    const MeshData* mesh;
    AOFieldCaster settings;
    std::shared_ptr<const AOFieldData> data;
  };
  std::vector<Baked> baked;
  for (Entity e : caster_entities(in.world)) {
    const AOFieldCaster caster = in.world.get<AOFieldCaster>(e);
    const std::string context = caster_context(in.world, e);
    PENUMBRA_TRY(validate_ao_field_caster(caster, in.world.get<WorldTransform>(e).matrix, context));
    const MeshData* mesh = in.world.get<Mesh>(e).data.get();
    const auto shared = std::find_if(baked.begin(), baked.end(), [&](const Baked& b) {
      return b.mesh == mesh && same_settings(b.settings, caster);
    });
    auto key = bake_key(in, e, context);
    if (!key) return key.error();
    AOFieldData data;
    if (shared != baked.end()) {
      data = *shared->data;
    } else {
      // The caster's random streams follow its key, not its index: the same scene built in another
      // order bakes the same field.
      Hasher seed;
      seed.add(in.settings.seed);
      seed.add(std::string_view(*key));
      auto fresh = bake_ao_field(caster, *mesh, seed.digest(), in.jobs, in.budget, context);
      if (!fresh) return fresh.error();
      data = std::move(*fresh);
    }
    data.key = std::move(*key);
    chunks.push_back(write_ao_field_chunk(data));
    auto ptr = std::make_shared<const AOFieldData>(std::move(data));
    if (shared == baked.end()) baked.push_back({mesh, caster, ptr});
    in.world.patch<AOFieldCaster>(e).data = std::move(ptr);
  }
  return chunks;
}

void hash_field_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kAOFieldChunkVersion);
  for (Entity e : caster_entities(world)) {
    const AOFieldCaster& c = world.get<AOFieldCaster>(e);
    h.add(std::string_view(entity_key(world, e)));
    hash_fields(ao_field_caster_info(), &c, h);
    h.add(world.get<WorldTransform>(e).matrix);  // validation (uniform scale) depends on it
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

// The grid representation (Malmer et al. 2007): Omega and Omega x Upsilon at every vertex that a
// point within r_far can interpolate from (the others stay 0), then the inside vertices filled
// from outside. Vertex v draws from Rng::stream(seed, v).
Status bake_grid(const AOFieldCaster& caster, const RayScene& scene, std::uint64_t seed, float tnear,
                 JobContext& jobs, AOFieldData& data) {
  const std::uint32_t size = caster.grid_size;
  const double far = data.r_far;
  std::vector<double> coord(size);  // the warped vertex coordinate g(u) r_far per index
  for (std::uint32_t i = 0; i < size; ++i) {
    const double u = 2.0 * i / double(size - 1) - 1.0;
    coord[i] = u * std::abs(u) * far;
  }
  // Per index, the distance from 0 to the span of the cells around the vertex (0 when it holds 0).
  std::vector<double> near_span(size);
  for (std::uint32_t i = 0; i < size; ++i) {
    const double lo = coord[i == 0 ? 0 : i - 1], hi = coord[std::min(i + 1, size - 1)];
    near_span[i] = lo <= 0.0 && hi >= 0.0 ? 0.0 : std::min(std::abs(lo), std::abs(hi));
  }
  const std::size_t count = std::size_t{size} * size * size;
  data.nodes.assign(count, AOFieldGridNode{});
  const std::vector<glm::vec3> dirs = sphere_directions(caster.rays_per_sample);
  const glm::dvec3 centre(data.centre);
  std::vector<std::uint8_t> known(count, 1);
  jobs.begin_stage("ao field", count);
  PENUMBRA_TRY(jobs.parallel_for(count, 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const std::size_t i = v % size, j = (v / size) % size, k = v / (std::size_t{size} * size);
      const glm::dvec3 span(near_span[i], near_span[j], near_span[k]);
      if (!(glm::length(span) < far)) continue;  // no point within r_far reads this vertex
      Rng rng = Rng::stream(seed, v);
      const glm::vec3 at(centre + glm::dvec3(coord[i], coord[j], coord[k]));
      const SphereSample smp =
          trace_sphere(scene, std::span<const glm::vec3>(&at, 1), dirs, random_rotation(rng), tnear);
      const double omega = 4.0 * kPi * smp.hits / caster.rays_per_sample;
      const double len = glm::length(smp.sum);
      AOFieldGridNode& node = data.nodes[v];
      node.omega = static_cast<float>(omega);
      node.weighted_direction = len > 0.0 ? glm::vec3(omega * smp.sum / len) : glm::vec3(0.0f);
      known[v] = smp.hits < caster.rays_per_sample ? 1 : 0;
    }
  }));
  fill_inside_vertices(size, coord, data.nodes, std::move(known));
  return {};
}

}  // namespace

Result<AOFieldData> bake_ao_field(const AOFieldCaster& caster, const MeshData& mesh, std::uint64_t seed,
                                  JobContext& jobs, MemoryBudget& budget, std::string_view context) {
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

  const bool grid = caster.representation == AOFieldRepresentation::Grid;
  const std::uint32_t res = grid ? 0 : caster.resolution;
  const std::size_t texel_count = 6 * std::size_t{res} * res;
  const std::uint64_t need = grid ? std::uint64_t{caster.grid_size} * caster.grid_size * caster.grid_size *
                                        sizeof(AOFieldGridNode)
                                  : texel_count * (sizeof(AOFieldTexel) + 1);
  if (auto st = budget.reserve(std::string(context) + " texels", need); !st)
    return make_error(ErrorCode::OutOfBudget, st.error().message + (grid ? "; use a smaller grid_size"
                                                                              : "; use a lower resolution"));
  struct Release {
    MemoryBudget& b;
    std::uint64_t n;
    ~Release() { b.release(n); }
  } release{budget, need};

  // The caster alone, in its mesh frame.
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

  AOFieldData data;
  data.representation = caster.representation;
  data.resolution = res;
  data.grid_size = grid ? caster.grid_size : 0;
  data.centre = glm::vec3(centroid);
  data.bounding_radius = static_cast<float>(radius);
  data.r_far = static_cast<float>(r_far);
  data.fade_start = caster.fade_start;
  data.inside_occlusion = caster.inside_occlusion;
  data.inside_exponent = caster.inside_exponent;
  const float tnear = static_cast<float>(1e-6 * radius);
  if (grid) {
    PENUMBRA_TRY(bake_grid(caster, *scene, seed, tnear, jobs, data));
    return data;
  }

  // Step 1's support function h(u) = max_v (v - centre) . u.
  const std::vector<glm::dvec3> dirs = support_directions(mesh);
  std::vector<double> support(dirs.size(), 0.0);
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    double h = -std::numeric_limits<double>::infinity();
    for (const glm::vec3& v : mesh.positions) h = std::max(h, glm::dot(glm::dvec3(v) - centroid, dirs[i]));
    support[i] = std::max(h, 0.0);
  }

  data.texels.resize(texel_count);
  std::vector<std::uint8_t> clamped(texel_count, 0);
  const std::uint32_t radii = caster.radial_samples;
  const std::uint32_t rays = caster.rays_per_sample;
  const std::uint32_t sub = caster.supersample;
  const std::vector<glm::vec3> sphere_dirs = sphere_directions(rays);
  const glm::vec3 origin_centre(centroid);
  jobs.begin_stage("ao field", texel_count);
  Status st = jobs.parallel_for(texel_count, 4, [&](std::size_t begin, std::size_t end) {
    std::vector<AORadialSample> samples(radii);
    std::vector<glm::vec3> sub_dirs(std::size_t{sub} * sub), from(sub_dirs.size());
    for (std::size_t i = begin; i < end; ++i) {
      Rng rng = Rng::stream(seed, i);
      const auto face = static_cast<std::uint32_t>(i / (std::size_t{res} * res));
      const auto row = static_cast<std::uint32_t>((i / res) % res), col = static_cast<std::uint32_t>(i % res);
      const float texel = 2.0f / static_cast<float>(res);
      const float s = (static_cast<float>(col) + 0.5f) * texel - 1.0f;
      const float t = (static_cast<float>(row) + 0.5f) * texel - 1.0f;
      const glm::vec3 w = cube_direction(face, s, t);
      const glm::dvec3 wd(w);
      // Step 1: the hull distance along w.
      const double r0 = hull_distance_of(dirs, support, wd, radius);
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
          if (sub > 1) r0_max = std::max(r0_max, hull_distance_of(dirs, support, glm::dvec3(d), radius));
        }
      // Step 2: Omega and Upsilon at log-spaced radii from just outside the hull to r_far, each
      // averaged over the supersample directions (rays spread over them in turn).
      const double r_lo = std::min(std::max(r0_max * (1.0 + 1e-3), 1e-2 * radius), 0.5 * r_far);
      for (std::uint32_t k = 0; k < radii; ++k) {
        const double r = r_lo * std::pow(r_far / r_lo, double(k) / double(radii - 1));
        for (std::size_t d = 0; d < sub_dirs.size(); ++d) from[d] = origin_centre + static_cast<float>(r) * sub_dirs[d];
        const SphereSample smp = trace_sphere(*scene, from, sphere_dirs, random_rotation(rng), tnear);
        AORadialSample& rs = samples[k];
        rs.rho = r / radius;
        rs.omega = 4.0 * kPi * smp.hits / rays;
        const double len = glm::length(smp.sum);
        rs.upsilon = len > 0.0 ? smp.sum / len : -wd;
      }
      // Steps 3 and 4: the fits, in units of the bounding radius, then back to mesh units.
      AOOmegaFit p{};
      clamped[i] = fit_ao_omega(samples, r0 / radius, r_far / radius, p) ? 1 : 0;
      const glm::dvec3 c0 = fit_ao_c0(samples, wd, r0 / radius) * radius;
      AOFieldTexel& tx = data.texels[i];
      tx.a = static_cast<float>(p[0] / (radius * radius));
      tx.b = static_cast<float>(p[1] / radius);
      tx.c = static_cast<float>(p[2]);
      tx.r0 = static_cast<float>(r0);
      tx.c0 = glm::vec3(c0);
    }
  });
  if (!st) return st.error();
  data.clamped_fits = static_cast<std::uint32_t>(std::count(clamped.begin(), clamped.end(), std::uint8_t{1}));
  return data;
}

void register_ao_field_baker(World& world) {
  Baker b = baker_for(ao_field_module());
  b.stages = 1;
  b.hash_inputs = hash_field_inputs;
  b.bake = bake_fields;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
