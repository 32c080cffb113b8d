// courtyard_walk: a third-person walk through Penumbra's built-in courtyard.
//
// The player drives an animated character (a glTF such as CesiumMan, or the built-in walker)
// among crates it pushes; the crates are rigid AO-field casters (their contact shadows move with
// them on the ground and fall on the characters), every character carries its own pose-AO, and
// all of them are lit by the courtyard's irradiance probe grid as they move. Further characters
// walk circles, so the cost of many animated characters shows in the timings (F2).
//
// Lighting: every component the SDK's defaults give the courtyard, baked at start with the
// chosen preset (or attached from --bake CACHE when current). The player's pose-AO is baked once
// and shared by the other characters of the same model (pose-AO is self-occlusion: it does not
// depend on where a character stands).
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include <penumbra/ao_field/ao_field.h>
#include <penumbra/bakers.h>
#include <penumbra/ecs/transform.h>
#include <penumbra/pose_ao/pose_ao.h>
#include <penumbra/pose_ao/pose_ao_system.h>
#include <penumbra/probe_grid/probe_grid.h>
#include <penumbra/runtime.h>
#include <penumbra/scene/builtin.h>
#include <penumbra/scene/components.h>

#include "sample.h"

namespace {

using namespace penumbra;
using sample::Character;

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kCrateHalf = 0.4f;  // the courtyard's crates are 0.8 m cubes
constexpr glm::vec3 kUp(0.0f, 1.0f, 0.0f);
// Where the scripted walk (autoplay) leaves the crate it pushes: against the north wall.
constexpr glm::vec3 kPushedTo(-3.0f, kCrateHalf, -8.87f);

// The skinned mesh entities below `root`, depth first in Children order (the same order for every
// import of one file).
void skinned_meshes(const World& world, Entity root, std::vector<Entity>& out) {
  if (world.has<Skin>(root) && world.has<Mesh>(root)) out.push_back(root);
  if (const Children* c = world.try_get<Children>(root))
    for (Entity child : c->entities) skinned_meshes(world, child, out);
}

class CourtyardWalk final : public sample::Game {
 public:
  Status init(const sample::Options& options) {
    register_lighting(world_);
    register_bakers(world_);
    auto scene = load_builtin(world_, "courtyard");
    if (!scene) return scene.error();
    // The courtyard's own walker gives way to this game's characters.
    Entity scenery_walker;
    world_.view<const Name, const Animator>().each([&](Entity e, const Name& n, const Animator&) {
      if (n.value == "character") scenery_walker = e;
    });
    if (scenery_walker) destroy_hierarchy(world_, scenery_walker);

    auto player = sample::add_character(world_, options.character, "player", {-3.0f, 0.0f, -3.5f});
    if (!player) return player.error();
    characters_.push_back(*player);
    // Game code reads the probe grid's light on the player (the renderer lights every surface
    // from the grid on the GPU; ProbeLit is the CPU evaluation at one point).
    world_.add<ProbeLit>(player->root);
    world_.update(0.0);
    if (Status s = add_default_lighting(world_, options.preset, /*authored=*/false); !s) return s;
    auto baked = sample::bake_or_load(world_, options.preset, options.bake);
    if (!baked) return baked.error();
    std::printf("courtyard_walk: %s\n", baked->c_str());

    // The other characters, after the bake: they share the player's pose-AO model.
    const int count = options.characters > 0 ? options.characters : 4;
    for (int i = 1; i < count; ++i) {
      const float a = 2.0f * kPi * static_cast<float>(i) / static_cast<float>(count);
      Circle path{{1.5f + 4.5f * std::cos(a), 2.5f + 3.5f * std::sin(a)}, 1.2f + 0.3f * static_cast<float>(i % 3),
                  static_cast<float>(i), i % 2 == 0 ? 1.0f : -1.0f};
      const glm::vec3 start(path.centre.x + path.radius * std::cos(path.phase), 0.0f,
                            path.centre.y + path.radius * std::sin(path.phase));
      auto npc = sample::add_character(world_, options.character, "walker " + std::to_string(i), start);
      if (!npc) return npc.error();
      npc->speed = 1.0f;
      characters_.push_back(*npc);
      paths_.push_back(path);
    }
    world_.update(0.0);
    if (Status s = add_default_lighting(world_, options.preset, /*authored=*/false); !s) return s;
    for (std::size_t i = 1; i < characters_.size(); ++i)
      share_pose_ao(world_, characters_[0].root, world_, characters_[i].root);
    skinned_meshes(world_, characters_[0].root, player_meshes_);

    world_.view<const Name, const AOFieldCaster>().each([&](Entity e, const Name& n, const AOFieldCaster&) {
      if (n.value == "crate") crates_.push_back(e);
    });
    // The crate the scripted walk pushes: the lone one by the north wall.
    for (Entity e : crates_) {
      const glm::vec3 p = world_.get<Transform>(e).translation;
      if (glm::length(glm::vec2(p.x + 3.0f, p.z + 6.0f)) < 0.1f) pushed_ = e;
    }
    if (!pushed_) return make_error(ErrorCode::Internal, "the courtyard has no crate at (-3, -6)");
    pushed_start_ = world_.get<Transform>(pushed_).translation;
    obstacles_ = sample::Obstacles::of_static_meshes(world_);
    camera_.set(kPi, 4.5f, 2.0f);  // behind the player, who faces -Z
    return {};
  }

  World& world() override { return world_; }

  std::vector<std::string> help() const override {
    return {"Courtyard walk - Penumbra sample",
            "W A S D / arrows: walk   mouse drag or Q E: turn the camera",
            "Walk into a crate to push it: its contact shadow moves with it."};
  }

  std::string status() const override {
    char line[160];
    const Character& p = characters_[0];
    std::snprintf(line, sizeof line, "%zu characters, %zu crates; player at (%.1f, %.1f), crate occlusion on it %.2f",
                  characters_.size(), crates_.size(), p.position.x, p.position.z, player_occlusion());
    return line;
  }

  // Walk to the lone crate and push it to the north wall, then stroll east and back south.
  sample::Input autoplay(int frame) override {
    sample::Input in;
    if (frame < 100) {
      in.move = {0.0f, 1.0f};
    } else if (frame < 160) {
      in.move = {1.0f, 0.0f};
    } else {
      in.move = {0.0f, -1.0f};
      in.turn = frame < 200 ? 0.02f : 0.0f;
    }
    return in;
  }

  void step(const sample::Input& input, double dt) override {
    camera_.turn(input.turn);
    Character& player = characters_[0];
    const glm::vec2 before(player.position.x, player.position.z);
    sample::walk(world_, player, camera_.world_direction(input.move), dt, obstacles_);
    push_crates(player, glm::vec2(player.position.x, player.position.z) - before);
    // The others walk their circles.
    for (std::size_t i = 1; i < characters_.size(); ++i) {
      Character& c = characters_[i];
      const Circle& path = paths_[i - 1];
      const glm::vec2 r = glm::vec2(c.position.x, c.position.z) - path.centre;
      const float dist = std::max(glm::length(r), 1e-3f);
      const glm::vec2 tangent = path.direction * glm::vec2(-r.y, r.x) / dist;
      const glm::vec2 inward = -r / dist * (dist - path.radius);
      sample::walk(world_, c, tangent + inward, dt, obstacles_);
    }
  }

  CameraView camera(float aspect) override {
    return camera_.view(characters_[0].position + glm::vec3(0.0f, 1.1f, 0.0f), aspect, obstacles_);
  }

  // What the tests check: the player moves; the pushed crate and the AO next to where it stood and
  // next to where the push leaves it; the player's pose-AO (its mean); the crates' occlusion on the player; the
  // probe grid's irradiance on the player.
  void report(std::FILE* out) override {
    const Character& p = characters_[0];
    const glm::vec3 crate = world_.get<Transform>(pushed_).translation;
    const auto* caster = world_.try_get<AOFieldCaster>(pushed_);
    const auto* wt = world_.try_get<WorldTransform>(pushed_);
    // Ground points 10 cm beside the crate's east face, where its contact shadow is: where it
    // stood, and where the scripted push leaves it (by the north wall).
    const glm::vec3 beside(kCrateHalf + 0.1f, -kCrateHalf + 0.01f, 0.0f);
    float ao_start = 0.0f, ao_end = 0.0f;
    if (caster && caster->data && wt) {
      ao_start = evaluate(*caster->data, wt->matrix, pushed_start_ + beside, kUp);
      ao_end = evaluate(*caster->data, wt->matrix, kPushedTo + beside, kUp);
    }
    std::fprintf(out, "player_x=%.4f player_z=%.4f crate_x=%.4f crate_z=%.4f ao_crate_start=%.4f ao_crate_end=%.4f "
                 "pose_ao_mean=%.5f occlusion_on_player=%.4f probe_irradiance=%.4f",
                 p.position.x, p.position.z, crate.x, crate.z, ao_start, ao_end, pose_ao_mean(), player_occlusion(),
                 probe_irradiance());
  }

 private:
  struct Circle {
    glm::vec2 centre;
    float radius, phase, direction;
  };

  // Crates on the ground that the player walks into move with it (and what stands on them); the
  // player stays behind them.
  void push_crates(Character& player, glm::vec2 moved) {
    glm::vec2 p(player.position.x, player.position.z);
    for (Entity crate : crates_) {
      Transform& t = world_.get<Transform>(crate);
      if (t.translation.y > kCrateHalf + 0.1f) continue;  // stacked: moves with what it stands on
      const glm::vec2 c(t.translation.x, t.translation.z);
      const glm::vec2 nearest = glm::clamp(p, c - kCrateHalf, c + kCrateHalf);
      const glm::vec2 d = p - nearest;
      const float dist = glm::length(d);
      if (dist >= player.radius || glm::length(moved) < 1e-6f) continue;
      // Along the axis the player pushes on, by how far the player got in.
      glm::vec2 push(0.0f);
      if (std::abs(p.x - c.x) > std::abs(p.y - c.y)) push.x = p.x < c.x ? player.radius - dist : dist - player.radius;
      else push.y = p.y < c.y ? player.radius - dist : dist - player.radius;
      glm::vec2 next = obstacles_.resolve(c + push, kCrateHalf);
      const glm::vec2 delta = next - c;
      for (Entity other : crates_) {
        Transform& o = world_.get<Transform>(other);
        if (other == crate || o.translation.y < kCrateHalf + 0.1f) continue;
        if (std::abs(o.translation.x - c.x) < kCrateHalf && std::abs(o.translation.z - c.y) < kCrateHalf) {
          world_.patch<Transform>(other).translation += glm::vec3(delta.x, 0.0f, delta.y);
        }
      }
      world_.patch<Transform>(crate).translation += glm::vec3(delta.x, 0.0f, delta.y);
      // The player ends where the crate's face now is.
      const glm::vec2 face = glm::clamp(p, next - kCrateHalf, next + kCrateHalf);
      const glm::vec2 away = p - face;
      if (glm::length(away) < player.radius && glm::length(away) > 1e-6f) p = face + away * (player.radius / glm::length(away));
    }
    player.position.x = p.x;
    player.position.z = p.y;
    sample::place(world_, player);
  }

  float pose_ao_mean() const {
    double sum = 0.0;
    std::size_t n = 0;
    for (Entity m : player_meshes_)
      if (const VertexAO* ao = world_.try_get<VertexAO>(m))
        for (float a : ao->ao) {
          sum += a;
          ++n;
        }
    return n ? static_cast<float>(sum / static_cast<double>(n)) : 0.0f;
  }

  float player_occlusion() const {
    float occlusion = 0.0f;
    for (Entity m : player_meshes_)
      if (const AOFieldReceiver* r = world_.try_get<AOFieldReceiver>(m)) occlusion = std::max(occlusion, r->occlusion);
    return occlusion;
  }

  float probe_irradiance() const {
    const ProbeLit* lit = world_.try_get<ProbeLit>(characters_[0].root);
    if (!lit || !lit->covered) return 0.0f;
    const glm::vec3 e = probe_lit_irradiance(*lit, kUp);
    return (e.r + e.g + e.b) / 3.0f;
  }

  World world_;
  std::vector<Character> characters_;  // [0] the player
  std::vector<Entity> player_meshes_;  // its skinned meshes
  std::vector<Circle> paths_;          // of characters_[1...]
  std::vector<Entity> crates_;
  Entity pushed_;
  glm::vec3 pushed_start_{0.0f};
  sample::Obstacles obstacles_;
  sample::FollowCamera camera_;
};

}  // namespace

int main(int argc, char** argv) {
  return sample::play<CourtyardWalk>(argc, argv, "courtyard_walk",
                                  "courtyard_walk: walk an animated character through the courtyard, push crates (Penumbra sample)");
}
