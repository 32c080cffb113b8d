// Lighting components authored in glTF (PENUMBRA_lighting): turning a file's declarations into
// components and components back into declarations (see penumbra/runtime.h).
#include <algorithm>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra {

namespace {

// The component type `name` of a linked module, or nullptr.
const ComponentInfo* find_component(std::string_view name) {
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components)
      if (c->name == name) return c;
  return nullptr;
}

Status apply_one(World& world, const AuthoredLighting& a, Entity node, const AuthoredComponent& c) {
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, a.source + ": " + c.type + ": " + what);
  };
  const ComponentInfo* info = find_component(c.type);
  if (info == nullptr || info->emplace == nullptr) {
    std::string known;
    for (const LightingModule* m : lighting_modules())
      for (const ComponentInfo* k : m->components)
        if (k->emplace) known += (known.empty() ? "" : ", ") + std::string(k->name);
    return bad("no lighting component of that name can be authored; use one of " + known);
  }
  std::optional<Preset> preset;
  if (!c.preset.empty()) {
    auto p = parse_preset(c.preset);
    if (!p) return bad("preset '" + c.preset + "' is unknown; use draft, medium or high");
    if (info->set_preset_fields == nullptr) return bad("has no presets; give its fields instead");
    preset = *p;
  }
  // Every field converted and checked before anything is added.
  std::vector<std::pair<const FieldInfo*, FieldValue>> values;
  for (const auto& [name, value] : c.fields) {
    const FieldInfo* f = info->field(name);
    if (f == nullptr) {
      std::string names;
      for (const FieldInfo& k : info->fields)
        if (!k.read_only) names += (names.empty() ? "" : ", ") + std::string(k.name);
      return bad("no field '" + name + "'; its fields: " + names);
    }
    if (f->read_only) return bad("field '" + name + "' is written by the runtime and cannot be authored");
    auto v = field_value_from(*f, value);
    if (!v) return bad(v.error().message);
    values.emplace_back(f, std::move(*v));
  }
  std::vector<Entity> targets = info->on_mesh ? a.meshes : std::vector<Entity>{node};
  if (targets.empty()) return bad("belongs on a mesh and the node has none; declare it on a node with a mesh");
  for (const Entity e : targets) {
    if (!world.alive(e)) continue;
    info->emplace(world, e);
    void* component = info->patch(world, e);
    if (preset) info->set_preset_fields(*info, component, *preset);
    for (const auto& [f, v] : values) f->set(component, v);
    if (Status s = check_fields(*info, component, a.source + ": " + c.type); !s) return s.error();
  }
  return {};
}

}  // namespace

Status apply_authored_lighting(World& world) {
  std::vector<Entity> nodes;
  world.view<AuthoredLighting>().each([&](Entity e, AuthoredLighting&) { nodes.push_back(e); });
  std::sort(nodes.begin(), nodes.end(), [](Entity x, Entity y) { return x.index < y.index; });
  for (const Entity e : nodes) {
    const AuthoredLighting a = world.get<AuthoredLighting>(e);
    world.remove<AuthoredLighting>(e);
    for (const AuthoredComponent& c : a.components) PENUMBRA_TRY(apply_one(world, a, e, c));
  }
  return {};
}

std::vector<AuthoredComponent> authored_components(const World& world, Entity node, std::span<const Entity> meshes) {
  std::vector<AuthoredComponent> out;
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* info : m->components) {
      if (info->emplace == nullptr) continue;
      const void* component = nullptr;
      if (info->on_mesh) {
        for (const Entity e : meshes)
          if (world.alive(e) && (component = info->find(world, e)) != nullptr) break;
      } else if (world.alive(node)) {
        component = info->find(world, node);
      }
      if (component == nullptr) continue;
      AuthoredComponent c;
      c.type = std::string(info->name);
      // The base the fields are written against: the defaults or a preset (then named), whichever
      // leaves the fewest fields to write, so a file says only what differs.
      const auto differing = [&](const void* base) {
        std::vector<std::pair<std::string, AuthoredValue>> fields;
        for (const FieldInfo& f : info->fields)
          if (!f.read_only && f.get && f.get(component) != f.get(base))
            fields.emplace_back(std::string(f.name), authored_value(f, f.get(component)));
        return fields;
      };
      World scratch;
      const Entity base = scratch.create();
      info->emplace(scratch, base);
      c.fields = differing(info->find(scratch, base));
      if (info->set_preset_fields) {
        for (const Preset p : {Preset::Draft, Preset::Medium, Preset::High}) {
          info->emplace(scratch, base);
          info->set_preset_fields(*info, info->patch(scratch, base), p);
          auto fields = differing(info->find(scratch, base));
          if (fields.size() < c.fields.size()) {
            c.preset = to_string(p);
            c.fields = std::move(fields);
          }
        }
      }
      out.push_back(std::move(c));
    }
  return out;
}

Result<GltfEdits> gltf_edits(World& world) {
  std::set<std::uint32_t> animated;  // entity indices some clip targets
  world.each<Animator>([&](Entity, Animator& a) {
    if (a.clips)
      for (const AnimationClip& c : *a.clips)
        for (Entity t : c.targets) animated.insert(t.index);
  });
  // A node's mesh primitives: its children with a Mesh that are not nodes themselves.
  const auto is_primitive = [&](Entity e) {
    return world.has<Mesh>(e) && !world.has<GltfNode>(e) && !world.has<GltfNodeCopy>(e);
  };
  const auto primitives = [&](Entity e) -> Result<std::vector<Entity>> {
    std::vector<Entity> meshes;
    if (const Children* kids = world.try_get<Children>(e))
      for (Entity k : kids->entities)
        if (is_primitive(k)) {
          for (Entity m : meshes)
            if (world.get<Mesh>(m).data == world.get<Mesh>(k).data)
              return make_error(ErrorCode::InvalidArgument,
                                entity_key(world, k) + ": a second copy of a mesh primitive of its node, which a glTF "
                                                       "node cannot hold; delete it and duplicate the node instead");
          meshes.push_back(k);
        }
    return meshes;
  };
  // A glTF skin names every joint by node: one deleted leaves the file's skin without it.
  Status broken;
  world.each<Skin>([&](Entity mesh, Skin& skin) {
    for (Entity joint : skin.joints)
      if (broken.ok() && !world.alive(joint))
        broken = make_error(ErrorCode::InvalidArgument,
                            entity_key(world, mesh) + ": a joint of its skin was deleted, and a glTF skin needs "
                                                      "every joint; bring the joint back or delete the mesh too");
  });
  PENUMBRA_TRY(broken);
  GltfEdits edits;
  std::set<std::uint32_t> present;
  Status failed;
  world.each<GltfNode, Transform>([&](Entity e, GltfNode& n, Transform& t) {
    present.insert(n.index);
    auto meshes = primitives(e);
    if (!meshes) {
      if (failed.ok()) failed = meshes.error();
      return;
    }
    GltfNodeEdit edit;
    edit.node = n.index;
    if (!animated.contains(e.index)) edit.transform = t;
    if (const Light* l = world.try_get<Light>(e)) edit.light = *l;
    edit.lighting = authored_components(world, e, *meshes);
    if (const Environment* sky = world.try_get<Environment>(e)) edit.environment = *sky;
    edits.nodes.push_back(std::move(edit));
  });
  PENUMBRA_TRY(failed);
  std::sort(edits.nodes.begin(), edits.nodes.end(), [](const GltfNodeEdit& a, const GltfNodeEdit& b) { return a.node < b.node; });

  // The file's root entities: what they imported and is gone; what is below them and new.
  std::vector<Entity> roots;
  world.each<GltfScene>([&](Entity e, GltfScene& scene) {
    roots.push_back(e);
    for (std::uint32_t n : scene.nodes)
      if (!present.contains(n)) edits.removed.push_back(n);
  });
  for (Entity root : roots) {
    // Breadth-first below the root: each entity with the node or the added node it is under.
    struct Pending {
      Entity entity;
      std::optional<std::uint32_t> parent, added_parent;
    };
    std::vector<Pending> pending;
    const auto below = [&](Entity e, std::optional<std::uint32_t> parent, std::optional<std::uint32_t> added_parent) {
      if (const Children* kids = world.try_get<Children>(e))
        for (Entity k : kids->entities)
          if (world.alive(k)) pending.push_back({k, parent, added_parent});
    };
    below(root, std::nullopt, std::nullopt);
    for (std::size_t i = 0; i < pending.size(); ++i) {
      const Pending p = pending[i];
      if (const GltfNode* n = world.try_get<GltfNode>(p.entity)) {
        below(p.entity, n->index, std::nullopt);
        continue;
      }
      if (is_primitive(p.entity) || !world.has<Transform>(p.entity)) continue;
      auto meshes = primitives(p.entity);
      if (!meshes) return meshes.error();
      GltfNewNode a;
      if (const Name* name = world.try_get<Name>(p.entity)) a.name = name->value;
      a.parent = p.parent;
      a.added_parent = p.added_parent;
      if (const GltfNodeCopy* c = world.try_get<GltfNodeCopy>(p.entity)) a.copy_of = c->node;
      a.transform = world.get<Transform>(p.entity);
      if (const Light* l = world.try_get<Light>(p.entity)) a.light = *l;
      a.lighting = authored_components(world, p.entity, *meshes);
      if (const Environment* sky = world.try_get<Environment>(p.entity)) a.environment = *sky;
      edits.added.push_back(std::move(a));
      below(p.entity, std::nullopt, static_cast<std::uint32_t>(edits.added.size() - 1));
    }
  }
  return edits;
}

}  // namespace penumbra
