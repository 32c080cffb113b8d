// The inspector's figures for the indirect transport (indirect_transport_views.h).
#include "indirect_transport_views.h"

#include "gizmo.h"

#include <algorithm>
#include <cmath>
#include <span>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {
namespace {

IrradianceStats stats(std::span<const glm::vec3> leaves) {
  IrradianceStats s;
  double sum = 0.0;
  for (const glm::vec3& e : leaves) {
    const float v = (e.r + e.g + e.b) / 3.0f;
    sum += v;
    s.max = std::max(s.max, v);
  }
  s.leaves = leaves.size();
  s.mean = leaves.empty() ? 0.0f : static_cast<float>(sum / static_cast<double>(leaves.size()));
  return s;
}

// The transport entity with baked data (the first in entity order), or null.
Entity baked_transport(World& world) {
  Entity found;
  for (Entity e : world.view<const IndirectTransport>().sorted_entities())
    if (!found && world.get<IndirectTransport>(e).data) found = e;
  return found;
}

}  // namespace

Result<TransportSummary> transport_summary(World& world, Entity e) {
  const IndirectTransport* t = world.try_get<IndirectTransport>(e);
  if (!t) return make_error(ErrorCode::NotFound, "the entity has no IndirectTransport");
  TransportSummary s;
  s.receivers = world.view<const IndirectReceiver>().count();
  world.view<const DynamicLight, const Light>().each([&](const DynamicLight& d, const Light&) {
    s.dynamic_lights += d.enabled ? 1 : 0;
    s.fixed_lights += d.enabled && !d.moves ? 1 : 0;
  });
  if (!t->data) return s;
  const TransportData& d = *t->data;
  s.baked = true;
  s.moving_lights = d.moving_lights;
  s.patches = static_cast<std::uint32_t>(d.patches.size());
  s.leaves = d.leaf_count();
  s.finest_level = d.finest_level;
  s.refinement_threshold = d.refinement_threshold;
  s.links = d.links;
  s.direct_coefficients = d.direct_nonzeros;
  s.global_coefficients = d.global.nonzeros();
  s.terms = d.terms;
  s.last_term_ratio = d.last_term_ratio;
  s.converged = d.converged;
  s.bytes = d.bytes();
  if (const IndirectLightmap* map = world.try_get<IndirectLightmap>(e); map && map->irradiance.size() == s.leaves) {
    s.has_lightmap = true;
    s.kept_coefficients = map->kept_coefficients;
    s.indirect = stats(map->irradiance);
    if (map->direct.size() == s.leaves) s.direct = stats(map->direct);
  }
  return s;
}

Result<ReceiverSummary> receiver_summary(World& world, Entity e) {
  if (!world.has<IndirectReceiver>(e)) return make_error(ErrorCode::NotFound, "the entity has no IndirectReceiver");
  ReceiverSummary s;
  const Entity owner = baked_transport(world);
  if (!owner) return s;
  s.baked = true;
  const TransportData& d = *world.get<IndirectTransport>(owner).data;
  const IndirectLightmap* map = world.try_get<IndirectLightmap>(owner);
  const bool lit = map && map->irradiance.size() == d.leaf_count() && map->direct.size() == d.leaf_count();
  const std::string key = entity_key(world, e);
  std::vector<glm::vec3> direct, indirect;
  for (const TransportPatch& p : d.patches) {
    if (p.key != key) continue;
    ++s.patches;
    s.leaves += p.leaves();
    s.area += p.area();
    if (!lit) continue;
    direct.insert(direct.end(), map->direct.begin() + p.first, map->direct.begin() + p.first + p.leaves());
    indirect.insert(indirect.end(), map->irradiance.begin() + p.first, map->irradiance.begin() + p.first + p.leaves());
  }
  s.direct = stats(direct);
  s.indirect = stats(indirect);
  return s;
}

glm::vec3 drag_in_view_plane(const CameraView& camera, glm::vec3 point, glm::vec2 from, glm::vec2 to, glm::vec2 size) {
  const glm::mat4 clip_to_world = glm::inverse(camera.projection * camera.view);
  const glm::vec3 forward = -glm::vec3(glm::inverse(camera.view)[2]);
  const auto w = static_cast<std::uint32_t>(std::max(size.x, 1.0f)), h = static_cast<std::uint32_t>(std::max(size.y, 1.0f));
  const auto hit = [&](glm::vec2 pixel, glm::vec3& out) {
    const CameraRay ray = camera_ray(clip_to_world, pixel, w, h);
    const float along = glm::dot(ray.direction, forward);
    if (std::abs(along) < 1e-6f) return false;
    const float t = glm::dot(point - ray.origin, forward) / along;
    if (!(t > 0.0f) || !std::isfinite(t)) return false;
    out = ray.origin + t * ray.direction;
    return true;
  };
  glm::vec3 a, b;
  if (!hit(from, a) || !hit(to, b)) return point;
  return point + (b - a);
}

void move_to(World& world, Entity e, glm::vec3 position) {
  world.patch<Transform>(e).translation =
      glm::vec3(glm::inverse(parent_world_matrix(world, e)) * glm::vec4(position, 1.0f));
}

}  // namespace penumbra::editor
