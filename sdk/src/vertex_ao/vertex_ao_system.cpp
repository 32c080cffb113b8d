// Vertex AO's module descriptor: attaching VXAO chunks and describing them (see vertex_ao_system.h).
#include "penumbra/vertex_ao/vertex_ao_system.h"

#include <algorithm>
#include <cstdio>

#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

Status attach_vertex_ao(World& world, const BakeChunk& chunk, const EntityKeys& keys) {
  auto data = read_vertex_ao_chunk(chunk);
  if (!data) return data.error();
  for (VertexAoData::Entry& entry : data->entries) {
    auto e = keys.find(entry.key, "chunk 'VXAO'");
    if (!e) return e.error();
    const Mesh* mesh = world.try_get<Mesh>(*e);
    if (mesh == nullptr || !mesh->data || mesh->data->positions.size() != entry.ao.size())
      return make_error(ErrorCode::NotFound, "chunk 'VXAO': entity '" + entry.key + "' has no mesh of " +
                                                 std::to_string(entry.ao.size()) +
                                                 " vertices in this World; re-bake the scene");
    VertexAO& out = world.has<VertexAO>(*e) ? world.patch<VertexAO>(*e) : world.add<VertexAO>(*e);
    out.ao = std::move(entry.ao);
    // A static mesh's occluders are the static geometry the probe grid saw; a skinned mesh's are
    // its own character's, which no baked source saw.
    out.static_occluders = !world.has<Skin>(*e);
  }
  return {};
}

std::vector<std::string> describe_vertex_ao(const BakeChunk& chunk) {
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
  std::snprintf(line, sizeof line, "%zu meshes, %zu vertices, %u rays/vertex, max distance %.3g m (a skinned mesh's: none)", data->entries.size(),
                vertices, data->rays, static_cast<double>(data->max_distance));
  std::vector<std::string> out{line};
  if (vertices > 0) {
    std::snprintf(line, sizeof line, "AO mean %.3f, min %.3f, max %.3f", sum / static_cast<double>(vertices),
                  static_cast<double>(lo), static_cast<double>(hi));
    out.emplace_back(line);
  }
  return out;
}

constexpr std::uint32_t kChunkTypes[] = {kVertexAoChunkType};

std::string explain_empty(World& world) {
  std::size_t movable = 0;
  world.view<const Mesh>().each([&](Entity e, const Mesh&) { movable += !world.has<Skin>(e) && !world.has<Static>(e); });
  return "vertex-ao bakes Static meshes and skinned meshes (in their bind pose) and this scene has neither (" +
         std::to_string(movable) + " movable meshes, which ao-field casters shade)";
}

}  // namespace

const LightingModule& vertex_ao_module() {
  static const LightingModule module{
      .name = "vertex-ao",
      .description = "per-vertex ambient occlusion of static meshes",
      .chunk_types = kChunkTypes,
      .register_runtime = nullptr,
      .chunk_key = [](const BakeChunk&) { return std::string(); },  // one chunk for every mesh
      .attach = attach_vertex_ao,
      .check = check_with<read_vertex_ao_chunk>,
      .describe = describe_vertex_ao,
      .add_defaults = nullptr,  // it bakes every Static mesh
      .explain_empty = explain_empty,
  };
  return module;
}

}  // namespace penumbra
