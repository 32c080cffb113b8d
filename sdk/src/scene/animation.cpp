// Keyframe sampling (glTF 2.0 specification, Appendix C "Interpolation"), the animation and
// skinning systems, and CPU linear blend skinning (Magnenat-Thalmann et al. 1988; the glTF
// skinning equation).
#include "penumbra/scene/animation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string_view>
#include <unordered_set>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include "penumbra/ecs/transform.h"

namespace penumbra {

namespace {

glm::quat to_quat(glm::vec4 v) { return glm::quat(v.w, v.x, v.y, v.z); }
glm::vec4 to_vec4(glm::quat q) { return glm::vec4(q.x, q.y, q.z, q.w); }

glm::vec4 normalised_rotation(glm::vec4 v) {
  const float len = glm::length(v);
  return len > 0.0f ? v / len : glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
}

glm::mat4 blended_matrix(const MeshData& mesh, const SkinPose& pose, std::size_t i) {
  glm::mat4 m(0.0f);
  for (int k = 0; k < 4; ++k) {
    const float w = mesh.weights[i][k];
    if (w != 0.0f) m += w * pose.joint_matrices[mesh.joints[i][k]];
  }
  return m;
}

}  // namespace

glm::vec4 sample_channel(const AnimationChannel& channel, float t) {
  const std::vector<float>& times = channel.times;
  const bool cubic = channel.interpolation == AnimationChannel::Interpolation::CubicSpline;
  const bool rotation = channel.path == AnimationChannel::Path::Rotation;
  auto value = [&](std::size_t key) { return channel.values[cubic ? 3 * key + 1 : key]; };
  auto finish = [&](glm::vec4 v) { return rotation ? normalised_rotation(v) : v; };

  // Outside the keyed range the end values hold.
  if (t <= times.front()) return finish(value(0));
  if (t >= times.back()) return finish(value(times.size() - 1));

  // Key interval [t_k, t_k+1) containing t.
  const auto upper = std::upper_bound(times.begin(), times.end(), t);
  const auto k = static_cast<std::size_t>(upper - times.begin()) - 1;
  const float td = times[k + 1] - times[k];
  const float s = (t - times[k]) / td;

  switch (channel.interpolation) {
    case AnimationChannel::Interpolation::Step:
      return finish(value(k));
    case AnimationChannel::Interpolation::Linear:
      if (rotation)
        return normalised_rotation(to_vec4(glm::slerp(to_quat(value(k)), to_quat(value(k + 1)), s)));
      return glm::mix(value(k), value(k + 1), s);
    case AnimationChannel::Interpolation::CubicSpline: {
      // Hermite basis; tangents are per second, so scale them by the key interval.
      const glm::vec4 p0 = value(k), p1 = value(k + 1);
      const glm::vec4 m0 = td * channel.values[3 * k + 2];  // out-tangent of key k
      const glm::vec4 m1 = td * channel.values[3 * k + 3];  // in-tangent of key k+1
      const float s2 = s * s, s3 = s2 * s;
      return finish((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 +
                    (s3 - s2) * m1);
    }
  }
  return finish(value(k));
}

float clip_time(float t, float duration, bool loop) {
  if (!(duration > 0.0f)) return 0.0f;
  if (!loop) return std::clamp(t, 0.0f, duration);
  const float wrapped = std::fmod(t, duration);
  return wrapped < 0.0f ? wrapped + duration : wrapped;
}

void apply_clip(World& world, const AnimationClip& clip, float t) {
  for (const AnimationChannel& channel : clip.channels) {
    if (channel.target >= clip.targets.size() || channel.times.empty()) continue;
    const Entity target = clip.targets[channel.target];
    if (!world.alive(target) || !world.has<Transform>(target)) continue;
    const glm::vec4 v = sample_channel(channel, t);
    Transform& transform = world.patch<Transform>(target);
    switch (channel.path) {
      case AnimationChannel::Path::Translation: transform.translation = glm::vec3(v); break;
      case AnimationChannel::Path::Rotation: transform.rotation = to_quat(v); break;
      case AnimationChannel::Path::Scale: transform.scale = glm::vec3(v); break;
    }
  }
}

void update_animators(World& world, float dt) {
  // Collect first: applying a clip patches Transforms while we iterate Animators.
  std::vector<Entity> animated;
  world.each<Animator>([&](Entity e, Animator&) { animated.push_back(e); });
  for (Entity e : animated) {
    Animator& animator = world.get<Animator>(e);
    if (!animator.clips || animator.clip >= animator.clips->size()) continue;
    const AnimationClip& clip = (*animator.clips)[animator.clip];
    if (animator.playing) {
      const float advanced = animator.time + dt * animator.speed;
      animator.time = clip_time(advanced, clip.duration, animator.loop);
      if (!animator.loop && (advanced >= clip.duration || advanced <= 0.0f)) animator.playing = false;
    }
    apply_clip(world, clip, animator.time);
  }
}

void update_skin_poses(World& world) {
  std::vector<Entity> skinned;
  world.each<Skin, WorldTransform>([&](Entity e, Skin&, WorldTransform&) { skinned.push_back(e); });
  for (Entity e : skinned) {
    const Skin& skin = world.get<Skin>(e);
    const glm::mat4 inverse_mesh = glm::inverse(world.get<WorldTransform>(e).matrix);
    // Reuse the previous pose's storage; patch() marks it changed for the systems that follow.
    SkinPose& pose = world.has<SkinPose>(e) ? world.patch<SkinPose>(e) : world.add<SkinPose>(e);
    pose.joint_matrices.resize(skin.joints.size());
    for (std::size_t j = 0; j < skin.joints.size(); ++j) {
      const WorldTransform* joint = world.try_get<WorldTransform>(skin.joints[j]);  // null when stale
      const glm::mat4 joint_world = joint ? joint->matrix : glm::mat4(1.0f);
      pose.joint_matrices[j] = inverse_mesh * joint_world * skin.inverse_bind[j];
    }
  }
}

void skin_positions(const MeshData& mesh, const SkinPose& pose, std::vector<glm::vec3>& out) {
  out.resize(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    out[i] = glm::vec3(blended_matrix(mesh, pose, i) * glm::vec4(mesh.positions[i], 1.0f));
}

void skin_normals(const MeshData& mesh, const SkinPose& pose, std::vector<glm::vec3>& out) {
  out.resize(mesh.normals.size());
  for (std::size_t i = 0; i < mesh.normals.size(); ++i) {
    const glm::mat3 normal_matrix = glm::inverseTranspose(glm::mat3(blended_matrix(mesh, pose, i)));
    const glm::vec3 n = normal_matrix * mesh.normals[i];
    const float len = glm::length(n);
    out[i] = len > 0.0f && std::isfinite(len) ? n / len : mesh.normals[i];
  }
}

namespace {

// The level of detail a name gives ("body_LOD1" 1, "Hair_lod0" 0), -1 for none.
int lod_level(std::string_view name) {
  for (std::size_t i = 0; i + 3 < name.size(); ++i) {
    const auto lower = [&](std::size_t k) { return std::tolower(static_cast<unsigned char>(name[k])); };
    if (lower(i) == 'l' && lower(i + 1) == 'o' && lower(i + 2) == 'd' &&
        std::isdigit(static_cast<unsigned char>(name[i + 3])))
      return name[i + 3] - '0';
  }
  return -1;
}

// An entity's level of detail: by its Name, else by its mesh's name.
int lod_level(World& world, Entity e) {
  const Name* n = world.try_get<Name>(e);
  const int level = n ? lod_level(n->value) : -1;
  const Mesh* m = world.try_get<Mesh>(e);
  return level >= 0 || m == nullptr || !m->data ? level : lod_level(m->data->name);
}

}  // namespace

std::vector<Entity> character_meshes(World& world, Entity mesh) {
  std::vector<Entity> out{mesh};
  const Skin* skin = world.alive(mesh) ? world.try_get<Skin>(mesh) : nullptr;
  if (skin == nullptr) return out;
  const Mesh* own = world.try_get<Mesh>(mesh);
  const int own_lod = lod_level(world, mesh);
  const auto bits = [](Entity j) { return (std::uint64_t{j.generation} << 32) | j.index; };
  std::unordered_set<std::uint64_t> joints;
  for (Entity j : skin->joints) joints.insert(bits(j));
  for (Entity e : world.view<Skin, Mesh>().sorted_entities()) {
    if (e == mesh || (own != nullptr && world.get<Mesh>(e).data == own->data)) continue;
    if (const int lod = lod_level(world, e); lod >= 0 && lod != own_lod) continue;
    const Skin& other = world.get<Skin>(e);
    if (std::any_of(other.joints.begin(), other.joints.end(), [&](Entity j) { return joints.contains(bits(j)); }))
      out.push_back(e);
  }
  return out;
}

Aabb posed_bounds(World& world, Entity root) {
  Aabb bounds;
  std::vector<glm::vec3> skinned;
  const auto below_root = [&world, root](Entity e) {
    for (Entity up = e; up; up = world.has<Parent>(up) ? world.get<Parent>(up).entity : Entity::null())
      if (up == root) return true;
    return false;
  };
  world.view<const Mesh, const WorldTransform>().each([&](Entity e, const Mesh& mesh, const WorldTransform& wt) {
    if (!mesh.data || mesh.data->bounds.empty() || (root && !below_root(e))) return;
    const MeshData& m = *mesh.data;
    const SkinPose* pose = world.try_get<SkinPose>(e);
    const bool skinned_now = pose && !m.joints.empty() && m.joints.size() == m.positions.size() &&
                             m.weights.size() == m.positions.size() &&
                             std::all_of(m.joints.begin(), m.joints.end(), [&](const glm::u16vec4& j) {
                               return std::size_t{std::max({j.x, j.y, j.z, j.w})} < pose->joint_matrices.size();
                             });
    if (skinned_now) {
      skin_positions(m, *pose, skinned);
      for (const glm::vec3& p : skinned) bounds.extend(glm::vec3(wt.matrix * glm::vec4(p, 1.0f)));
      return;
    }
    const Aabb& b = m.bounds;
    for (int i = 0; i < 8; ++i) {
      const glm::vec3 corner((i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y, (i & 4) ? b.max.z : b.min.z);
      bounds.extend(glm::vec3(wt.matrix * glm::vec4(corner, 1.0f)));
    }
  });
  return bounds;
}

void register_scene_systems(World& world) {
  world.add_system({"animation", Phase::Animation, {component_id<Animator>()},
                    {component_id<Animator>(), component_id<Transform>()},
                    [](World& w, const SystemContext& context) { update_animators(w, static_cast<float>(context.dt)); }});
  register_transform_systems(world);
  world.add_system({"skinning", Phase::Transform, {component_id<Skin>(), component_id<WorldTransform>()},
                    {component_id<SkinPose>()}, [](World& w, const SystemContext&) { update_skin_poses(w); }});
}

}  // namespace penumbra
