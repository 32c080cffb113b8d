// RayScene over Embree 3 (Wald et al. 2014, "Embree: A Kernel Framework for Efficient CPU Ray
// Tracing"): one static triangle geometry in world space, instanced sub-scenes for movable meshes,
// refitted triangle geometries for skinned meshes, and a ray validator in front of every query.
#include "penumbra/bake/ray_scene.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "penumbra/core/log.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

// Embree treats coordinates beyond this as invalid (its FLT_LARGE); stay well inside.
constexpr float kMaxCoordinate = 1e18f;
constexpr unsigned kInvalidId = RTC_INVALID_GEOMETRY_ID;

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

SurfaceMaterial flatten(const Material* m) {
  SurfaceMaterial s;
  if (m == nullptr) return s;
  s.albedo = glm::vec3(m->base_color);
  if (m->base_color_texture) s.albedo *= m->base_color_texture->average_linear;
  s.emissive = m->emissive;
  s.double_sided = m->double_sided;
  return s;
}

// Triangles of `indices` over `positions` that Embree may be given: indices in range (else an
// error), finite vertices and non-zero area (else dropped). Returns the kept source triangles.
Result<std::vector<std::uint32_t>> valid_triangles(const std::vector<glm::vec3>& positions,
                                                   const std::vector<std::uint32_t>& indices,
                                                   std::string_view what, std::size_t& dropped) {
  std::vector<std::uint32_t> kept;
  kept.reserve(indices.size() / 3);
  const std::size_t n = positions.size();
  for (std::size_t t = 0; t < indices.size() / 3; ++t) {
    const std::uint32_t a = indices[3 * t], b = indices[3 * t + 1], c = indices[3 * t + 2];
    if (a >= n || b >= n || c >= n) {
      return make_error(ErrorCode::InvalidInput,
                        std::string(what) + ": triangle " + std::to_string(t) + " indexes vertex " +
                            std::to_string(std::max({a, b, c})) + " of " + std::to_string(n) +
                            "; run MeshData::validate() on the mesh or re-export it");
    }
    const glm::vec3 p0 = positions[a], p1 = positions[b], p2 = positions[c];
    const float area2 = glm::length(glm::cross(p1 - p0, p2 - p0));
    if (!finite3(p0) || !finite3(p1) || !finite3(p2) || !(area2 > 0.0f) || !std::isfinite(area2)) {
      ++dropped;
      continue;
    }
    kept.push_back(static_cast<std::uint32_t>(t));
  }
  return kept;
}

// Skinned: a Skin and SkinPose, and a mesh with joints and weights for every vertex.
bool is_skinned(World& world, Entity e) {
  const MeshData* mesh = world.get<Mesh>(e).data.get();
  return world.has<Skin>(e) && world.has<SkinPose>(e) && mesh != nullptr && !mesh->positions.empty() &&
         mesh->joints.size() == mesh->positions.size() && mesh->weights.size() == mesh->positions.size();
}

// The largest joint index a vertex of `mesh` uses with a non-zero weight (-1 when none).
int max_used_joint(const MeshData& mesh) {
  int used = -1;
  for (std::size_t i = 0; i < mesh.joints.size(); ++i) {
    for (int k = 0; k < 4; ++k) {
      if (mesh.weights[i][k] != 0.0f) used = std::max(used, int(mesh.joints[i][k]));
    }
  }
  return used;
}

std::string entity_name(const World& world, Entity e) {
  std::string s = "entity " + std::to_string(e.index);
  if (const Name* name = world.try_get<Name>(e)) s += " '" + name->value + "'";
  return s;
}

}  // namespace

bool ray_is_valid(const Ray& r) {
  const auto ok_coord = [](float v) { return std::fabs(v) <= kMaxCoordinate; };  // false for NaN
  if (!ok_coord(r.origin.x) || !ok_coord(r.origin.y) || !ok_coord(r.origin.z)) return false;
  if (!finite3(r.direction) || glm::dot(r.direction, r.direction) <= 0.0f) return false;
  return r.tnear >= 0.0f && r.tnear <= r.tfar;  // false for NaN; tfar may be +inf
}

// One geometry of the top-level scene.
struct GeometryRecord {
  enum class Kind : std::uint8_t { Static, Instance, Skinned };
  Kind kind = Kind::Static;
  Entity entity;
  SurfaceMaterial material;
  glm::mat3 normal_matrix{1.0f};            // Instance: object -> world normals
  const std::vector<std::uint32_t>* source = nullptr;  // Embree primitive -> mesh triangle
  // Skinned: what update() needs to re-pose the geometry.
  std::shared_ptr<const MeshData> mesh;
  std::vector<std::uint32_t> kept;
  int max_joint = -1;
  RTCGeometry geometry = nullptr;
};

// A movable mesh's own BVH, shared by every entity instancing the same MeshData.
struct SubScene {
  RTCScene scene = nullptr;
  std::vector<std::uint32_t> source;
};

struct RayScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<GeometryRecord> geometries;  // indexed by top-level geometry ID
  // Static geometry: per Embree primitive, its part (entity + material) and source triangle.
  struct Part { Entity entity; SurfaceMaterial material; };
  std::vector<Part> static_parts;
  std::vector<std::uint32_t> static_part_of;
  std::vector<std::uint32_t> static_source;
  std::unordered_map<const MeshData*, SubScene> sub_scenes;
  std::size_t triangles = 0;
  std::size_t dropped = 0;
  glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
  Environment sky;
  mutable std::atomic<std::uint64_t> invalid_rays{0};
  std::atomic<std::int64_t> bytes{0};
  std::mutex error_mutex;
  std::string error;  // first Embree error since the last check

  ~Impl() {
    for (auto& [mesh, sub] : sub_scenes) rtcReleaseScene(sub.scene);
    if (scene != nullptr) rtcReleaseScene(scene);
    if (device != nullptr) rtcReleaseDevice(device);
  }

  static void on_error(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard lock(self->error_mutex);
    if (self->error.empty()) {
      self->error = "Embree error " + std::to_string(static_cast<int>(code)) + ": " +
                    (message != nullptr ? message : "(no message)");
    }
  }
  static bool on_memory(void* user, ssize_t bytes, bool /*post*/) {
    static_cast<Impl*>(user)->bytes.fetch_add(static_cast<std::int64_t>(bytes), std::memory_order_relaxed);
    return true;
  }

  // The Embree error recorded since the last call, as an Error (Status ok when none).
  Status take_error(std::string_view during) {
    std::lock_guard lock(error_mutex);
    if (error.empty()) return {};
    std::string message = "RayScene: " + std::string(during) + ": " + error +
                          "; check the scene's geometry and the memory available";
    error.clear();
    return make_error(ErrorCode::Internal, std::move(message));
  }

  void extend(glm::vec3 p) { lo = glm::min(lo, p); hi = glm::max(hi, p); }

  // A triangle geometry over `positions` restricted to the source triangles in `kept`.
  RTCGeometry new_triangles(const std::vector<glm::vec3>& positions, const std::vector<std::uint32_t>& indices,
                            const std::vector<std::uint32_t>& kept) const {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree may read 16 bytes at the last vertex: one float of padding.
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), positions.size() + 1));
    auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), kept.size()));
    if (v == nullptr || ix == nullptr) return g;  // the error callback has the reason
    for (std::size_t i = 0; i < positions.size(); ++i) {
      v[3 * i] = positions[i].x; v[3 * i + 1] = positions[i].y; v[3 * i + 2] = positions[i].z;
    }
    v[3 * positions.size()] = v[3 * positions.size() + 1] = v[3 * positions.size() + 2] = 0.0f;
    for (std::size_t k = 0; k < kept.size(); ++k) {
      for (int j = 0; j < 3; ++j) ix[3 * k + j] = indices[3 * kept[k] + j];
    }
    return g;
  }

  unsigned attach(RTCGeometry g, GeometryRecord record) {
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(scene, g);
    if (id >= geometries.size()) geometries.resize(id + 1);
    record.geometry = g;
    geometries[id] = std::move(record);
    return id;
  }

  Hit resolve(unsigned geom_id, unsigned inst_id, unsigned prim, glm::vec3 ng, float u, float v, float t,
              glm::vec3 dir) const {
    Hit h;
    h.t = t;
    h.barycentrics = {u, v};
    const GeometryRecord& rec = geometries[inst_id != kInvalidId ? inst_id : geom_id];
    if (rec.kind == GeometryRecord::Kind::Static) {
      const Part& part = static_parts[static_part_of[prim]];
      h.entity = part.entity;
      h.material = part.material;
      h.primitive = static_source[prim];
    } else {
      h.entity = rec.entity;
      h.material = rec.material;
      h.primitive = (*rec.source)[prim];
      if (rec.kind == GeometryRecord::Kind::Instance) ng = rec.normal_matrix * ng;
    }
    // Embree's Ng is (p1 - p0) x (p2 - p0): the counter-clockwise front side.
    h.normal = glm::normalize(ng);
    h.back_face = glm::dot(h.normal, dir) > 0.0f;
    return h;
  }
};

RayScene::RayScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;
RayScene::~RayScene() = default;

Result<RayScene> RayScene::build(World& world, const RaySceneOptions& options) {
  auto impl = std::make_unique<Impl>();
  Impl& s = *impl;
  const std::string config = options.build_threads > 0 ? "threads=" + std::to_string(options.build_threads) : "";
  s.device = rtcNewDevice(config.c_str());
  if (s.device == nullptr) {
    return make_error(ErrorCode::Internal, "RayScene: rtcNewDevice(\"" + config +
                                               "\") failed; check that Embree supports this CPU");
  }
  rtcSetDeviceErrorFunction(s.device, &Impl::on_error, &s);
  rtcSetDeviceMemoryMonitorFunction(s.device, &Impl::on_memory, &s);
  s.sky = world_environment(world);
  const RTCBuildQuality quality = options.quality == RaySceneOptions::Quality::Low    ? RTC_BUILD_QUALITY_LOW
                                  : options.quality == RaySceneOptions::Quality::High ? RTC_BUILD_QUALITY_HIGH
                                                                                      : RTC_BUILD_QUALITY_MEDIUM;

  // Sort the entities with geometry into static, movable and skinned.
  std::vector<Entity> statics, movables, skinned;
  world.view<Mesh, WorldTransform>().each([&](Entity e, Mesh&, WorldTransform&) {
    if (world.has<Static>(e)) statics.push_back(e);
    else if (!options.include_dynamic) return;
    else if (is_skinned(world, e)) skinned.push_back(e);
    else movables.push_back(e);
  });
  // Entity order from the ECS is not guaranteed to be stable across Worlds built the same way;
  // sort by handle so that primitive IDs are reproducible.
  const auto by_index = [](Entity a, Entity b) { return a.index < b.index; };
  std::sort(statics.begin(), statics.end(), by_index);
  std::sort(movables.begin(), movables.end(), by_index);
  std::sort(skinned.begin(), skinned.end(), by_index);

  s.scene = rtcNewScene(s.device);
  const bool dynamic = !movables.empty() || !skinned.empty();
  rtcSetSceneFlags(s.scene, dynamic ? RTC_SCENE_FLAG_DYNAMIC : RTC_SCENE_FLAG_NONE);
  rtcSetSceneBuildQuality(s.scene, dynamic ? RTC_BUILD_QUALITY_LOW : quality);

  // Static entities: transform to world space and concatenate into one geometry.
  if (!statics.empty()) {
    std::vector<glm::vec3> positions;
    std::vector<std::uint32_t> indices, kept;
    for (Entity e : statics) {
      const MeshData* mesh = world.get<Mesh>(e).data.get();
      if (mesh == nullptr) continue;
      const glm::mat4 m = world.get<WorldTransform>(e).matrix;
      const auto base = static_cast<std::uint32_t>(positions.size());
      for (glm::vec3 p : mesh->positions) positions.push_back(glm::vec3(m * glm::vec4(p, 1.0f)));
      std::vector<glm::vec3> world_positions(positions.begin() + base, positions.end());
      std::size_t dropped = 0;
      auto valid = valid_triangles(world_positions, mesh->indices, entity_name(world, e), dropped);
      if (!valid) return valid.error();
      if (dropped > 0) {
        log(LogLevel::Warning, "RayScene: " + entity_name(world, e) + ": dropped " + std::to_string(dropped) +
                                   " triangles with a non-finite vertex or zero area (in world space)");
      }
      s.dropped += dropped;
      const auto part = static_cast<std::uint32_t>(s.static_parts.size());
      s.static_parts.push_back({e, flatten(world.try_get<Material>(e))});
      for (std::uint32_t t : *valid) {
        for (int j = 0; j < 3; ++j) indices.push_back(base + mesh->indices[3 * t + j]);
        kept.push_back(static_cast<std::uint32_t>(kept.size()));
        s.static_part_of.push_back(part);
        s.static_source.push_back(t);
      }
      for (std::uint32_t t : *valid) {
        for (int j = 0; j < 3; ++j) s.extend(world_positions[mesh->indices[3 * t + j]]);
      }
    }
    s.triangles += kept.size();
    if (!kept.empty()) {
      RTCGeometry g = s.new_triangles(positions, indices, kept);
      rtcSetGeometryBuildQuality(g, quality);
      s.attach(g, GeometryRecord{});
      rtcReleaseGeometry(g);
    }
  }

  // Movable entities: one instanced sub-scene per distinct mesh.
  for (Entity e : movables) {
    const std::shared_ptr<const MeshData>& mesh = world.get<Mesh>(e).data;
    if (!mesh) continue;
    auto [it, inserted] = s.sub_scenes.try_emplace(mesh.get());
    SubScene& sub = it->second;
    if (inserted) {
      std::size_t dropped = 0;
      auto valid = valid_triangles(mesh->positions, mesh->indices, entity_name(world, e), dropped);
      if (!valid) return valid.error();
      if (dropped > 0) {
        log(LogLevel::Warning, "RayScene: " + entity_name(world, e) + ": dropped " + std::to_string(dropped) +
                                   " triangles with a non-finite vertex or zero area");
      }
      s.dropped += dropped;
      sub.source = std::move(*valid);
      sub.scene = rtcNewScene(s.device);
      rtcSetSceneBuildQuality(sub.scene, quality);
      RTCGeometry g = s.new_triangles(mesh->positions, mesh->indices, sub.source);
      rtcCommitGeometry(g);
      rtcAttachGeometry(sub.scene, g);
      rtcReleaseGeometry(g);
      rtcCommitScene(sub.scene);
    }
    s.triangles += sub.source.size();
    RTCGeometry inst = rtcNewGeometry(s.device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(inst, sub.scene);
    const glm::mat4 m = world.get<WorldTransform>(e).matrix;
    rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &m[0][0]);
    GeometryRecord rec;
    rec.kind = GeometryRecord::Kind::Instance;
    rec.entity = e;
    rec.material = flatten(world.try_get<Material>(e));
    rec.normal_matrix = glm::transpose(glm::inverse(glm::mat3(m)));
    rec.source = &sub.source;
    s.attach(inst, std::move(rec));
    rtcReleaseGeometry(inst);
    for (int corner = 0; corner < 8; ++corner) {
      const glm::vec3 p((corner & 1) ? mesh->bounds.max.x : mesh->bounds.min.x,
                        (corner & 2) ? mesh->bounds.max.y : mesh->bounds.min.y,
                        (corner & 4) ? mesh->bounds.max.z : mesh->bounds.min.z);
      if (!mesh->bounds.empty()) s.extend(glm::vec3(m * glm::vec4(p, 1.0f)));
    }
  }

  // Skinned entities: their own world-space triangle geometry, refitted by update().
  for (Entity e : skinned) {
    const std::shared_ptr<const MeshData>& mesh = world.get<Mesh>(e).data;
    std::size_t dropped = 0;
    auto valid = valid_triangles(mesh->positions, mesh->indices, entity_name(world, e), dropped);
    if (!valid) return valid.error();
    s.dropped += dropped;
    GeometryRecord rec;
    rec.kind = GeometryRecord::Kind::Skinned;
    rec.entity = e;
    rec.material = flatten(world.try_get<Material>(e));
    rec.mesh = mesh;
    rec.max_joint = max_used_joint(*mesh);
    rec.kept = std::move(*valid);
    RTCGeometry g = s.new_triangles(mesh->positions, mesh->indices, rec.kept);
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
    s.triangles += rec.kept.size();
    s.attach(g, std::move(rec));
    rtcReleaseGeometry(g);
  }
  // Sources of skinned records point into the records themselves: fix them after the vector settled.
  for (GeometryRecord& rec : s.geometries) {
    if (rec.kind == GeometryRecord::Kind::Skinned) rec.source = &rec.kept;
  }

  rtcCommitScene(s.scene);
  PENUMBRA_TRY(s.take_error("building the BVH"));
  RayScene result(std::move(impl));
  if (!skinned.empty()) PENUMBRA_TRY(result.update(world));
  return result;
}

Status RayScene::update(World& world) {
  Impl& s = *impl_;
  std::vector<glm::vec3> posed;
  for (GeometryRecord& rec : s.geometries) {
    if (rec.kind == GeometryRecord::Kind::Static || rec.geometry == nullptr) continue;
    const WorldTransform* wt = world.alive(rec.entity) ? world.try_get<WorldTransform>(rec.entity) : nullptr;
    if (wt == nullptr) {
      rtcDisableGeometry(rec.geometry);
      continue;
    }
    const glm::mat4 m = wt->matrix;
    if (rec.kind == GeometryRecord::Kind::Instance) {
      rtcSetGeometryTransform(rec.geometry, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &m[0][0]);
      rec.normal_matrix = glm::transpose(glm::inverse(glm::mat3(m)));
    } else {
      const SkinPose* pose = world.try_get<SkinPose>(rec.entity);
      if (pose == nullptr) {
        rtcDisableGeometry(rec.geometry);
        continue;
      }
      if (rec.max_joint >= 0 && std::size_t(rec.max_joint) >= pose->joint_matrices.size()) {
        return make_error(ErrorCode::InvalidInput,
                          "RayScene::update: " + entity_name(world, rec.entity) + ": the mesh uses joint " +
                              std::to_string(rec.max_joint) + " but SkinPose has " +
                              std::to_string(pose->joint_matrices.size()) +
                              " joint matrices; run the skinning system (update_skin_poses) first");
      }
      // Re-pose on the CPU (linear blend skinning), then to world space.
      skin_positions(*rec.mesh, *pose, posed);
      for (glm::vec3& p : posed) {
        p = glm::vec3(m * glm::vec4(p, 1.0f));
        if (!finite3(p)) {
          return make_error(ErrorCode::InvalidInput,
                            "RayScene::update: " + entity_name(world, rec.entity) +
                                ": skinning produced a non-finite vertex; check SkinPose::joint_matrices "
                                "and the mesh's weights");
        }
      }
      auto* v = static_cast<float*>(rtcGetGeometryBufferData(rec.geometry, RTC_BUFFER_TYPE_VERTEX, 0));
      for (std::size_t i = 0; i < posed.size(); ++i) {
        v[3 * i] = posed[i].x; v[3 * i + 1] = posed[i].y; v[3 * i + 2] = posed[i].z;
      }
      rtcUpdateGeometryBuffer(rec.geometry, RTC_BUFFER_TYPE_VERTEX, 0);
    }
    rtcEnableGeometry(rec.geometry);
    rtcCommitGeometry(rec.geometry);
  }
  rtcCommitScene(s.scene);
  return s.take_error("updating the BVH");
}

namespace {

// A validated Ray as Embree's single ray (every mask bit set: Debian's Embree has masks compiled in).
RTCRay to_rtc(const Ray& ray) {
  RTCRay r{};
  r.org_x = ray.origin.x; r.org_y = ray.origin.y; r.org_z = ray.origin.z;
  r.dir_x = ray.direction.x; r.dir_y = ray.direction.y; r.dir_z = ray.direction.z;
  r.tnear = ray.tnear;
  r.tfar = ray.tfar;
  r.mask = 0xFFFFFFFFu;
  return r;
}

}  // namespace

bool RayScene::intersect(const Ray& ray, Hit& hit) const {
  if (!ray_is_valid(ray)) {
    impl_->invalid_rays.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray = to_rtc(ray);
  rh.hit.geomID = kInvalidId;
  rh.hit.instID[0] = kInvalidId;
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == kInvalidId) return false;
  hit = impl_->resolve(rh.hit.geomID, rh.hit.instID[0], rh.hit.primID, {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z},
                       rh.hit.u, rh.hit.v, rh.ray.tfar, ray.direction);
  return true;
}

bool RayScene::occluded(const Ray& ray) const {
  if (!ray_is_valid(ray)) {
    impl_->invalid_rays.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r = to_rtc(ray);
  rtcOccluded1(impl_->scene, &context, &r);
  return r.tfar == -std::numeric_limits<float>::infinity();
}

namespace {

// Loads up to 16 rays into a packet; invalid rays get an inactive lane holding a harmless ray
// (Embree's assertions check every lane). Returns how many rays were invalid.
template <class Packet>
std::uint64_t load_packet(std::span<const Ray> rays, Packet& p, int (&valid)[16]) {
  std::uint64_t invalid = 0;
  for (std::size_t i = 0; i < 16; ++i) {
    const bool in = i < rays.size();
    const bool ok = in && ray_is_valid(rays[i]);
    invalid += (in && !ok) ? 1u : 0u;
    const Ray r = ok ? rays[i] : Ray{};
    valid[i] = ok ? -1 : 0;
    p.org_x[i] = r.origin.x; p.org_y[i] = r.origin.y; p.org_z[i] = r.origin.z;
    p.dir_x[i] = r.direction.x; p.dir_y[i] = r.direction.y; p.dir_z[i] = r.direction.z;
    p.tnear[i] = r.tnear;
    p.tfar[i] = ok ? r.tfar : 0.0f;
    p.time[i] = 0.0f;
    p.mask[i] = 0xFFFFFFFFu;
    p.id[i] = static_cast<unsigned>(i);
    p.flags[i] = 0;
  }
  return invalid;
}

}  // namespace

void RayScene::occluded(std::span<const Ray> rays, std::span<std::uint8_t> out) const {
  assert(out.size() == rays.size());
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  std::uint64_t invalid = 0;
  for (std::size_t first = 0; first < rays.size(); first += 16) {
    const std::size_t count = std::min<std::size_t>(16, rays.size() - first);
    alignas(64) RTCRay16 packet;
    alignas(64) int valid[16];
    invalid += load_packet(rays.subspan(first, count), packet, valid);
    rtcOccluded16(valid, impl_->scene, &context, &packet);
    for (std::size_t i = 0; i < count; ++i) {
      out[first + i] = (valid[i] != 0 && packet.tfar[i] == -std::numeric_limits<float>::infinity()) ? 1 : 0;
    }
  }
  if (invalid > 0) impl_->invalid_rays.fetch_add(invalid, std::memory_order_relaxed);
}

void RayScene::intersect(std::span<const Ray> rays, std::span<Hit> hits, std::span<std::uint8_t> hit_mask) const {
  assert(hits.size() == rays.size() && hit_mask.size() == rays.size());
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  std::uint64_t invalid = 0;
  for (std::size_t first = 0; first < rays.size(); first += 16) {
    const std::size_t count = std::min<std::size_t>(16, rays.size() - first);
    alignas(64) RTCRayHit16 packet;
    alignas(64) int valid[16];
    invalid += load_packet(rays.subspan(first, count), packet.ray, valid);
    for (std::size_t i = 0; i < 16; ++i) {
      packet.hit.geomID[i] = kInvalidId;
      packet.hit.instID[0][i] = kInvalidId;
    }
    rtcIntersect16(valid, impl_->scene, &context, &packet);
    for (std::size_t i = 0; i < count; ++i) {
      const bool hit = valid[i] != 0 && packet.hit.geomID[i] != kInvalidId;
      hit_mask[first + i] = hit ? 1 : 0;
      if (!hit) continue;
      hits[first + i] = impl_->resolve(packet.hit.geomID[i], packet.hit.instID[0][i], packet.hit.primID[i],
                                       {packet.hit.Ng_x[i], packet.hit.Ng_y[i], packet.hit.Ng_z[i]},
                                       packet.hit.u[i], packet.hit.v[i], packet.ray.tfar[i],
                                       rays[first + i].direction);
    }
  }
  if (invalid > 0) impl_->invalid_rays.fetch_add(invalid, std::memory_order_relaxed);
}

float RayScene::ray_epsilon(glm::vec3 p) const {
  const float magnitude = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  // Embree's hit points carry an error of a few ulps of the coordinates; 2e-5 relative is ~170
  // ulps, and the 1e-5 floor covers points near the origin (scenes are in metres).
  return 2e-5f * magnitude + 1e-5f;
}

std::size_t RayScene::triangle_count() const { return impl_->triangles; }
std::size_t RayScene::dropped_triangle_count() const { return impl_->dropped; }
std::uint64_t RayScene::invalid_ray_count() const { return impl_->invalid_rays.load(std::memory_order_relaxed); }
std::uint64_t RayScene::bvh_bytes() const {
  return static_cast<std::uint64_t>(std::max<std::int64_t>(0, impl_->bytes.load(std::memory_order_relaxed)));
}
glm::vec3 RayScene::bounds_min() const { return impl_->lo; }
glm::vec3 RayScene::bounds_max() const { return impl_->hi; }

glm::vec3 RayScene::sky(glm::vec3 direction) const { return impl_->sky.toward(direction); }

float RayScene::max_albedo() const {
  float m = 0.0f;
  for (const auto& part : impl_->static_parts) m = std::max({m, part.material.albedo.r, part.material.albedo.g, part.material.albedo.b});
  for (const GeometryRecord& g : impl_->geometries)
    if (g.kind != GeometryRecord::Kind::Static) m = std::max({m, g.material.albedo.r, g.material.albedo.g, g.material.albedo.b});
  return m;
}

}  // namespace penumbra
