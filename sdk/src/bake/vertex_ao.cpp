// Baked per-vertex ambient occlusion of static meshes (see vertex_ao.h).
#include "penumbra/bake/vertex_ao.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/mat3x3.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kChunkType = fourcc("VXAO");

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

VertexAoSettings VertexAoSettings::preset(Preset preset) {
  VertexAoSettings s;
  s.rays = preset == Preset::Draft ? 64u : preset == Preset::Medium ? 256u : 1024u;
  return s;
}

std::uint64_t VertexAoData::bytes() const {
  std::uint64_t n = sizeof(*this);
  for (const Entry& e : entries) n += sizeof(Entry) + e.ao.capacity() * sizeof(float);
  return n;
}

BakeChunk write_vertex_ao_chunk(const VertexAoData& data) {
  ByteWriter w;
  w.write(data.max_distance);
  w.write(data.rays);
  w.write(static_cast<std::uint32_t>(data.entries.size()));
  for (const auto& e : data.entries) {
    w.write(e.entity_index);
    w.write_vector(e.ao);
  }
  return BakeChunk{kChunkType, kVertexAoChunkVersion, "vertex-ao", w.take()};
}

Result<VertexAoData> read_vertex_ao_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'VXAO'";
  PENUMBRA_TRY(check_chunk(chunk, kChunkType, kVertexAoChunkVersion, context));
  VertexAoData data;
  ByteReader r(chunk.payload, context);
  std::uint32_t count = 0;
  PENUMBRA_TRY(r.read(data.max_distance));
  PENUMBRA_TRY(r.read(data.rays));
  PENUMBRA_TRY(r.read(count));
  for (std::uint32_t i = 0; i < count; ++i) {
    VertexAoData::Entry e;
    PENUMBRA_TRY(r.read(e.entity_index));
    PENUMBRA_TRY(r.read_vector(e.ao));
    for (std::size_t v = 0; v < e.ao.size(); ++v)
      if (!(e.ao[v] >= 0.0f && e.ao[v] <= 1.0f))
        return make_error(ErrorCode::InvalidInput, context + ": entity " + std::to_string(e.entity_index) + " vertex " +
                                                       std::to_string(v) + ": AO outside [0, 1]; re-bake");
    data.entries.push_back(std::move(e));
  }
  PENUMBRA_TRY(r.finish());
  return data;
}

namespace {

Result<std::vector<BakeChunk>> bake_vertex_ao(BakeInputs& in) {
  const VertexAoSettings settings = VertexAoSettings::preset(in.settings.preset);
  const std::vector<Entity> entities = static_meshes(in.world);

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
  PENUMBRA_TRY(ambient_occlusion(in.rays, points, ao, estimates, in.jobs));

  VertexAoData data;
  data.max_distance = settings.max_distance;
  data.rays = settings.rays;
  std::size_t next = 0;
  for (Entity e : entities) {
    VertexAoData::Entry entry;
    entry.entity_index = e.index;
    entry.ao.resize(in.world.get<Mesh>(e).data->positions.size());
    for (float& a : entry.ao) a = estimates[next++].value;
    data.entries.push_back(std::move(entry));
  }
  in.budget.release(total * (sizeof(SurfacePoint) + sizeof(AoEstimate)));
  std::vector<BakeChunk> chunks;
  chunks.push_back(write_vertex_ao_chunk(data));
  return chunks;
}

std::vector<std::string> describe_vertex_ao(const BakeChunk& chunk) {
  if (chunk.type != kChunkType) return {};
  auto data = read_vertex_ao_chunk(chunk);
  if (!data) return {data.error().message};
  std::size_t vertices = 0;
  double sum = 0.0;
  float lo = 1.0f, hi = 0.0f;
  for (const auto& e : data->entries)
    for (float a : e.ao) {
      ++vertices;
      sum += a;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
  char line[200];
  std::snprintf(line, sizeof line, "%zu meshes, %zu vertices, %u rays/vertex, max distance %.3g m", data->entries.size(),
                vertices, data->rays, static_cast<double>(data->max_distance));
  std::vector<std::string> out{line};
  if (vertices > 0) {
    std::snprintf(line, sizeof line, "AO mean %.3f, min %.3f, max %.3f", sum / static_cast<double>(vertices),
                  static_cast<double>(lo), static_cast<double>(hi));
    out.emplace_back(line);
  }
  return out;
}

}  // namespace

void register_vertex_ao(World& world) {
  Baker b;
  b.name = "vertex-ao";
  b.description = "per-vertex ambient occlusion of static meshes";
  b.stages = 1;
  b.hash_inputs = [](World&, const BakeSettings& s, Hasher& h) {
    const VertexAoSettings v = VertexAoSettings::preset(s.preset);
    h.add(v.max_distance);
    h.add(v.rays);
    h.add(kVertexAoChunkVersion);
  };
  b.bake = bake_vertex_ao;
  b.describe = describe_vertex_ao;
  world.resource<BakerRegistry>().add(std::move(b));
}

Status attach_vertex_ao(World& world, const BakeFile& file) {
  for (const BakeChunk& chunk : file.chunks) {
    if (chunk.type != kChunkType) continue;
    auto data = read_vertex_ao_chunk(chunk);
    if (!data) return data.error();
    for (VertexAoData::Entry& entry : data->entries) {
      const Entity e = world.find_entity(entry.entity_index);
      const Mesh* mesh = e ? world.try_get<Mesh>(e) : nullptr;
      if (mesh == nullptr || !mesh->data || mesh->data->positions.size() != entry.ao.size())
        return make_error(ErrorCode::NotFound, "chunk 'VXAO' (" + chunk.label + "): entity " +
                                                   std::to_string(entry.entity_index) + " has no mesh of " +
                                                   std::to_string(entry.ao.size()) +
                                                   " vertices in this World; re-bake the scene");
      if (world.has<VertexAO>(e)) {
        world.patch<VertexAO>(e).ao = std::move(entry.ao);
      } else {
        world.add<VertexAO>(e, VertexAO{std::move(entry.ao)});
      }
    }
  }
  return {};
}

}  // namespace penumbra
