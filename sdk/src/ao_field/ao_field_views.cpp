// The editor's AO-field caster views (see ao_field_views.h).
#include "ao_field_views.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

namespace {

constexpr float kTwoPi = 6.28318530718f;

// Direction k of `segments` around the circle in the plane of local axes a and b (0: XY, 1: YZ, 2: ZX).
glm::vec3 circle_direction(int plane, int k, int segments) {
  const float t = kTwoPi * static_cast<float>(k) / static_cast<float>(segments);
  glm::vec3 d(0.0f);
  d[plane] = std::cos(t);
  d[(plane + 1) % 3] = std::sin(t);
  return d;
}

glm::vec3 transform_point(const glm::mat4& m, glm::vec3 p) { return glm::vec3(m * glm::vec4(p, 1.0f)); }

std::string caster_context(World& world, Entity e) {
  const Name* n = world.try_get<Name>(e);
  return "ao field on " + (n ? "'" + n->value + "'" : std::string("entity")) + " (#" + std::to_string(e.index) + ")";
}

}  // namespace

Result<AOFieldBounds> ao_field_bounds(World& world, Entity e, int segments) {
  const AOFieldCaster* caster = world.alive(e) ? world.try_get<AOFieldCaster>(e) : nullptr;
  const Mesh* mesh = world.alive(e) ? world.try_get<Mesh>(e) : nullptr;
  const WorldTransform* wt = world.alive(e) ? world.try_get<WorldTransform>(e) : nullptr;
  if (!caster || !mesh || !mesh->data || !wt)
    return make_error(ErrorCode::NotFound, "ao field bounds: entity #" + std::to_string(e.index) +
                                               " has no AOFieldCaster with a mesh and a world transform; select a "
                                               "caster");
  segments = std::max(segments, 8);
  const glm::mat4& m = wt->matrix;
  const float scale = glm::length(glm::vec3(m[0]));  // uniform (validate_ao_field_caster)
  const AOFieldData* data = caster->data && caster->data->valid() ? caster->data.get() : nullptr;

  AOFieldBounds b;
  glm::vec3 centre(0.0f);
  float radius = 0.0f, r_far = 0.0f;
  if (data) {
    centre = data->centre;
    radius = data->bounding_radius;
    r_far = data->r_far;
    b.baked = true;
  } else {
    glm::dvec3 origin(0.0);
    double bounding = 0.0;
    ao_field_origin(*mesh->data, origin, bounding);  // as the bake will derive them
    centre = glm::vec3(origin);
    radius = static_cast<float>(bounding);
    r_far = caster->falloff_distance > 0.0f ? caster->falloff_distance : 6.0f * radius;
  }
  b.centre = transform_point(m, centre);
  b.falloff_radius = r_far * scale;
  for (int plane = 0; plane < 3; ++plane) {
    std::vector<glm::vec3> outer, inner;
    for (int k = 0; k < segments; ++k) {
      const glm::vec3 w = circle_direction(plane, k, segments);
      outer.push_back(transform_point(m, centre + r_far * w));
      if (data && data->representation == AOFieldRepresentation::RadialFit)
        inner.push_back(transform_point(m, centre + hull_distance(*data, w) * w));
      else if (!data)
        inner.push_back(transform_point(m, centre + radius * w));
    }
    b.falloff.push_back(std::move(outer));
    if (!inner.empty()) b.hull.push_back(std::move(inner));
  }
  if (data && data->representation == AOFieldRepresentation::Grid) {
    // The grid's cube of half-size r_far: bottom, top and two loops over the vertical edges.
    const auto corner = [&](int c) {
      const glm::vec3 s((c & 1) ? 1.0f : -1.0f, (c & 2) ? 1.0f : -1.0f, (c & 4) ? 1.0f : -1.0f);
      return transform_point(m, centre + r_far * s);
    };
    for (const auto& loop : {std::array{0, 1, 3, 2}, std::array{4, 5, 7, 6}, std::array{0, 4, 5, 1},
                             std::array{2, 6, 7, 3}}) {
      std::vector<glm::vec3> l;
      for (int c : loop) l.push_back(corner(c));
      b.hull.push_back(std::move(l));
    }
  }
  return b;
}

Result<AOFieldSlice> ao_field_slice(World& world, Entity e, const AOFieldSliceRequest& request) {
  const AOFieldCaster* caster = world.alive(e) ? world.try_get<AOFieldCaster>(e) : nullptr;
  const WorldTransform* wt = world.alive(e) ? world.try_get<WorldTransform>(e) : nullptr;
  const std::string context = world.alive(e) ? caster_context(world, e) : "ao field slice";
  if (!caster || !wt)
    return make_error(ErrorCode::NotFound, context + ": no AOFieldCaster with a world transform; select a caster");
  if (!caster->data || !caster->data->valid())
    return make_error(ErrorCode::NotFound, context + ": not baked; bake it (Bake selection) to see its field");
  if (request.resolution < 2 || request.resolution > 512)
    return make_error(ErrorCode::InvalidArgument,
                      context + ": slice resolution " + std::to_string(request.resolution) + " is outside 2..512");
  if (!std::isfinite(request.height) || !(std::isfinite(request.extent) && request.extent > 0.0f))
    return make_error(ErrorCode::InvalidArgument,
                      context + ": slice height and extent must be finite (and the extent positive)");
  const AOFieldData& data = *caster->data;
  const glm::mat4& m = wt->matrix;
  const float scale = glm::length(glm::vec3(m[0]));
  const glm::vec3 centre = transform_point(m, data.centre);
  // The caster's lowest world point: its mesh bounds' corners through the world matrix.
  float lowest = centre.y - data.bounding_radius * scale;
  if (const Mesh* mesh = world.try_get<Mesh>(e); mesh && mesh->data && !mesh->data->bounds.empty()) {
    const Aabb& bb = mesh->data->bounds;
    lowest = std::numeric_limits<float>::max();
    for (int c = 0; c < 8; ++c)
      lowest = std::min(lowest, transform_point(m, glm::vec3((c & 1) ? bb.max.x : bb.min.x, (c & 2) ? bb.max.y : bb.min.y,
                                                             (c & 4) ? bb.max.z : bb.min.z)).y);
  }
  const float half = request.extent * data.r_far * scale;
  const float y = lowest + request.height;
  const int n = request.resolution;
  AOFieldSlice slice;
  slice.resolution = n;
  slice.points.reserve(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  slice.occlusion.reserve(slice.points.capacity());
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float u = -1.0f + 2.0f * static_cast<float>(i) / static_cast<float>(n - 1);
      const float v = -1.0f + 2.0f * static_cast<float>(j) / static_cast<float>(n - 1);
      const glm::vec3 x(centre.x + half * u, y, centre.z + half * v);
      // A floor receiver: normal +Y (ao_field.h's evaluate, the CPU evaluation game code calls).
      const float a = evaluate(data, m, x, glm::vec3(0.0f, 1.0f, 0.0f));
      slice.points.push_back(x);
      slice.occlusion.push_back(a);
      slice.max_occlusion = std::max(slice.max_occlusion, a);
    }
  return slice;
}

}  // namespace penumbra::editor
