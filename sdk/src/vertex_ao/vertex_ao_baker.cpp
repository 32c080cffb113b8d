// The vertex-AO bake (see vertex_ao_baker.h).
#include "penumbra/vertex_ao/vertex_ao_baker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/mat3x3.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/vertex_ao/vertex_ao.h"
#include "penumbra/vertex_ao/vertex_ao_system.h"

namespace penumbra {

namespace {

// The static meshes to bake, in entity-index order (deterministic whatever the pool order).
std::vector<Entity> static_meshes(World& world) {
  std::vector<Entity> out = world.view<Static, Mesh, WorldTransform>().sorted_entities();
  std::erase_if(out, [&](Entity e) {
    const Mesh& m = world.get<Mesh>(e);
    return !m.data || m.data->positions.empty();
  });
  return out;
}

}  // namespace

namespace {

Result<std::vector<BakeChunk>> bake_vertex_ao(BakeInputs& in) {
  const VertexAoSettings settings = VertexAoSettings::preset(in.settings.preset);
  const std::vector<Entity> entities = static_meshes(in.world);
  if (entities.empty()) return std::vector<BakeChunk>{};  // nothing to bake: no chunk
  auto keys = bake_keys(in, entities, "vertex-AO mesh");
  if (!keys) return keys.error();

  // Gather every vertex in world space; normals by the inverse transpose.
  std::size_t total = 0;
  for (Entity e : entities) total += in.world.get<Mesh>(e).data->positions.size();
  PENUMBRA_TRY(in.budget.reserve("vertex AO points", total * (sizeof(SurfacePoint) + sizeof(AoEstimate))));
  std::vector<SurfacePoint> points;
  points.reserve(total);
  for (Entity e : entities) {
    const MeshData& mesh = *in.world.get<Mesh>(e).data;
    const glm::mat4& m = in.world.get<WorldTransform>(e).matrix;
    const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(m)));
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      SurfacePoint p;
      p.position = glm::vec3(m * glm::vec4(mesh.positions[v], 1.0f));
      const glm::vec3 n = v < mesh.normals.size() ? normal_matrix * mesh.normals[v] : glm::vec3(0.0f, 1.0f, 0.0f);
      const float len = glm::length(n);
      p.normal = len > 0.0f && std::isfinite(len) ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
      points.push_back(p);
    }
  }

  // Trace: one random stream per vertex, results by index (deterministic at any thread count).
  std::vector<AoEstimate> estimates(points.size());
  AoSettings ao;
  ao.max_distance = settings.max_distance;
  ao.rays = settings.rays;
  ao.seed = in.settings.seed;
  const Status traced = ambient_occlusion(in.rays, points, ao, estimates, in.jobs);
  in.budget.release(total * (sizeof(SurfacePoint) + sizeof(AoEstimate)));
  PENUMBRA_TRY(traced);

  VertexAoData data;
  data.max_distance = settings.max_distance;
  data.rays = settings.rays;
  std::size_t next = 0;
  for (Entity e : entities) {
    VertexAoData::Entry entry;
    entry.key = std::move((*keys)[data.entries.size()]);
    entry.ao.resize(in.world.get<Mesh>(e).data->positions.size());
    for (float& a : entry.ao) a = estimates[next++].value;
    data.entries.push_back(std::move(entry));
  }
  std::vector<BakeChunk> chunks;
  chunks.push_back(write_vertex_ao_chunk(data));
  return chunks;
}

}  // namespace

void register_vertex_ao_baker(World& world) {
  Baker b = baker_for(vertex_ao_module());
  b.stages = 1;
  b.hash_inputs = [](World&, const BakeSettings& s, Hasher& h) {
    const VertexAoSettings v = VertexAoSettings::preset(s.preset);
    h.add(v.max_distance);
    h.add(v.rays);
    h.add(kVertexAoChunkVersion);
  };
  b.bake = bake_vertex_ao;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
