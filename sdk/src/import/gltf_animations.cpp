// Animations delivered apart from their character, retargeted by node name (gltf.h,
// import_animations).
#include <algorithm>
#include <string>
#include <unordered_map>
#include <utility>

#include "penumbra/import/gltf.h"

namespace penumbra {

namespace {

Entity root_of(World& world, Entity e) {
  for (const Parent* p = world.try_get<Parent>(e); p != nullptr && p->entity && world.alive(p->entity);
       p = world.try_get<Parent>(e))
    e = p->entity;
  return e;
}

}  // namespace

Result<ImportedAnimations> import_animations(World& world, const std::filesystem::path& path) {
  const std::string file = path.filename().string();
  World source;
  ImportOptions options;
  options.load_textures = false;
  auto imported = import_gltf(source, path, options);
  if (!imported) return imported.error();
  const Animator* animator = source.try_get<Animator>(imported->root);
  if (animator == nullptr || !animator->clips || animator->clips->empty())
    return make_error(ErrorCode::InvalidInput, file + ": has no animations; give a glTF file whose 'animations' "
                                                      "hold the clips");

  // The nodes of `world` by name and by name without a prefix (the first in entity order wins).
  std::unordered_map<std::string, Entity> by_name, by_base;
  for (Entity e : world.view<Name>().sorted_entities()) {
    const std::string& n = world.get<Name>(e).value;
    by_name.emplace(n, e);
    by_base.emplace(std::string(name_without_namespace(n)), e);
  }
  const auto match = [&](Entity node) -> Entity {
    const Name* name = source.try_get<Name>(node);
    if (name == nullptr || name->value.empty()) return Entity::null();
    if (const auto it = by_name.find(name->value); it != by_name.end()) return it->second;
    if (const auto it = by_base.find(std::string(name_without_namespace(name->value))); it != by_base.end())
      return it->second;
    return Entity::null();
  };

  ImportedAnimations out;
  std::vector<AnimationClip> added;
  std::vector<std::string> unmatched;
  for (const AnimationClip& clip : *animator->clips) {
    AnimationClip c;
    c.name = clip.name;
    c.duration = clip.duration;
    std::unordered_map<std::uint32_t, std::uint32_t> target_of;  // source target -> new target
    for (const AnimationChannel& ch : clip.channels) {
      const Entity node = ch.target < clip.targets.size() ? clip.targets[ch.target] : Entity::null();
      const Entity to = node ? match(node) : Entity::null();
      if (!to) {
        ++out.unmatched_channels;
        const Name* name = node ? source.try_get<Name>(node) : nullptr;
        const std::string n = name ? "'" + name->value + "'" : "an unnamed node";
        if (std::find(unmatched.begin(), unmatched.end(), n) == unmatched.end()) unmatched.push_back(n);
        continue;
      }
      auto [it, fresh] = target_of.emplace(ch.target, static_cast<std::uint32_t>(c.targets.size()));
      if (fresh) c.targets.push_back(to);
      AnimationChannel copy = ch;
      copy.target = it->second;
      c.channels.push_back(std::move(copy));
      ++out.channels;
    }
    if (!c.channels.empty()) added.push_back(std::move(c));
  }
  std::string names;
  for (std::size_t i = 0; i < unmatched.size() && i < 4; ++i) names += (i ? ", " : "") + unmatched[i];
  if (unmatched.size() > 4) names += " and " + std::to_string(unmatched.size() - 4) + " more";
  if (added.empty())
    return make_error(ErrorCode::InvalidInput,
                      file + ": no animation channel drives a node of the scene by name (" + names +
                          " are not in it); export the animation from the character's own skeleton");
  if (!unmatched.empty())
    out.warnings.push_back(file + ": " + std::to_string(out.unmatched_channels) +
                           " channels drive nodes the scene lacks and were dropped (" + names + ")");

  // The Animator whose clips already drive these nodes, else a new one on their hierarchy's root.
  const Entity first = added.front().targets.front();
  for (Entity e : world.view<Animator>().sorted_entities()) {
    const Animator& a = world.get<Animator>(e);
    if (!a.clips) continue;
    for (const AnimationClip& clip : *a.clips)
      if (std::find(clip.targets.begin(), clip.targets.end(), first) != clip.targets.end()) out.animator = e;
    if (out.animator) break;
  }
  if (!out.animator) {
    out.animator = root_of(world, first);
    if (!world.has<Animator>(out.animator)) world.add<Animator>(out.animator, Animator{});
  }
  Animator& target = world.patch<Animator>(out.animator);
  auto clips = target.clips ? std::make_shared<std::vector<AnimationClip>>(*target.clips)
                            : std::make_shared<std::vector<AnimationClip>>();
  out.clips = added.size();
  for (AnimationClip& c : added) clips->push_back(std::move(c));
  target.clips = std::move(clips);
  return out;
}

}  // namespace penumbra
