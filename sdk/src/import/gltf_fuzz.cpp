// Fuzz target "gltf": the glTF importer (import_gltf) on any bytes, as .gltf or .glb (the first
// byte of the input chooses, the rest is the file), then the lighting components its
// PENUMBRA_lighting declares (apply_authored_lighting), then save_gltf of what was imported.
// Invariants: an import succeeds with valid meshes, or fails with an error that starts with the
// file's path and leaves no entity behind; applying the declarations succeeds or fails naming the
// file; a file that imported saves (or fails with an error, never a crash) and what it saves
// imports again, also with a node added, one copied and one deleted; read as an animation file for a small character (import_animations), it adds
// clips whose targets and channels all lie in that character, or fails naming the file.
#include "fuzz/fuzz.h"
#include "penumbra/import/gltf.h"
#include "penumbra/runtime.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return 0; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  // Seeds are whole files: a .glb starts with "glTF", anything else is read as JSON.
  const bool binary = size >= 4 && data[0] == 'g' && data[1] == 'l' && data[2] == 'T' && data[3] == 'F';
  const std::filesystem::path path = fuzz::scratch_file(data, size, binary ? ".glb" : ".gltf");
  World world;
  ImportOptions options;
  options.load_textures = true;
  auto imported = import_gltf(world, path, options);
  if (imported) {
    world.each<Mesh>([&](Entity, Mesh& m) { fuzz::require(m.data && m.data->validate("fuzz").ok(), "invalid mesh"); });
    register_lighting(world);
    const Status applied = apply_authored_lighting(world);
    fuzz::require(applied || applied.error().message.rfind(path.string(), 0) == 0,
                  "a lighting declaration's error that does not name the file");
    std::filesystem::path saved = path;
    saved.replace_filename(path.stem().string() + "-saved" + path.extension().string());
    if (auto edits = gltf_edits(world); edits && save_gltf(path, saved, *edits)) {
      World again;
      auto reimported = import_gltf(again, saved, options);
      fuzz::require(reimported.ok(), "a saved file that does not import again");
    }
    // Then as an editor leaves it: a light added under the file's root, a copy of the first node
    // beside it, the last leaf node that is no joint deleted. Saved, it imports again.
    Entity last;
    world.each<GltfNode>([&](Entity e, GltfNode&) {
      bool joint = false;
      world.each<Skin>([&](Entity, Skin& skin) {
        for (Entity j : skin.joints) joint = joint || j == e;
      });
      if (!joint && !world.has<Children>(e)) last = e;
    });
    if (last) destroy_hierarchy(world, last);
    const Entity light = world.create();
    world.add<Name>(light, Name{"fuzz light"});
    world.add<Transform>(light);
    world.add<Light>(light);
    set_parent(world, light, imported->root);
    world.each<GltfNode>([&](Entity e, GltfNode& n) {
      if (n.index != 0 || world.has<Skin>(e)) return;
      const Entity copy = world.create();
      world.add<Transform>(copy, world.get<Transform>(e));
      world.add<GltfNodeCopy>(copy, GltfNodeCopy{n.index});
      world.add<Name>(copy, Name{"fuzz copy"});
      set_parent(world, copy, imported->root);
    });
    if (auto edits = gltf_edits(world); edits && save_gltf(path, saved, *edits)) {
      World again;
      auto reimported = import_gltf(again, saved, options);
      fuzz::require(reimported.ok(), "a saved file with added and removed nodes that does not import again");
    }
    std::error_code ec;
    std::filesystem::remove(saved, ec);
  }
  {
    // A character whose node names the seeds use (tests/data/gltf: scaled_armature, its wave).
    World character;
    Entity parent;
    for (const char* name : {"Armature", "hips", "head", "root", "quad"}) {
      const Entity e = character.create();
      character.add<Name>(e, Name{name});
      character.add<Transform>(e);
      if (parent) set_parent(character, e, parent);
      parent = e;
    }
    auto added = import_animations(character, path);
    if (added) {
      const Animator* a = character.try_get<Animator>(added->animator);
      fuzz::require(a != nullptr && a->clips && a->clips->size() == added->clips && added->clips > 0,
                    "retargeted clips that are not on the animator");
      for (const AnimationClip& clip : *a->clips) {
        for (Entity t : clip.targets) fuzz::require(character.alive(t), "a retargeted clip aims at no entity");
        for (const AnimationChannel& ch : clip.channels)
          fuzz::require(ch.target < clip.targets.size(), "a retargeted channel outside its clip's targets");
      }
    } else {
      fuzz::require(added.error().message.find(path.filename().string()) != std::string::npos,
                    "an animation import error that does not name the file");
    }
  }
  if (!imported) {
    fuzz::require(imported.error().message.rfind(path.string(), 0) == 0, "an error that does not name the file");
    std::size_t left = 0;
    world.each<Name>([&](Entity, Name&) { ++left; });
    fuzz::require(left == 0, "a failed import left entities behind");
  }
  return 0;
}
