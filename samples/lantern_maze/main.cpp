// lantern_maze: carry a lantern through Penumbra's built-in maze.
//
// The player's character carries the maze's point light; the walls, floor and ceiling pick up its
// bounce light live, with the walls' colours bleeding onto their neighbours, through the indirect
// transport (P4: the precomputed wavelet operator turns the lantern's new direct light into
// indirect light each frame it moves). The character itself is lit by the probe grid and carries
// its pose-AO.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include <penumbra/bakers.h>
#include <penumbra/ecs/transform.h>
#include <penumbra/indirect_transport/indirect_transport.h>
#include <penumbra/pose_ao/pose_ao_system.h>
#include <penumbra/runtime.h>
#include <penumbra/scene/builtin.h>
#include <penumbra/scene/components.h>

#include "sample.h"

namespace {

using namespace penumbra;
using sample::Character;

constexpr float kPi = std::numbers::pi_v<float>;
// Where the lantern hangs from the character's hand, in its frame (x right, z forward).
constexpr glm::vec3 kHand(0.3f, 1.3f, 0.35f);
// The wall point the tests watch: the green wall's east face, half-way up, by the last corridor.
constexpr glm::vec3 kWatchPoint(8.1f, 1.2f, 5.0f);
constexpr glm::vec3 kWatchNormal(1.0f, 0.0f, 0.0f);

class LanternMaze final : public sample::Game {
 public:
  Status init(const sample::Options& options) {
    register_lighting(world_);
    register_bakers(world_);
    auto scene = load_builtin(world_, "maze");
    if (!scene) return scene.error();
    // The lantern leaves its patrol (its Animator's path becomes the scripted walk's route) and goes
    // to the player's hand.
    world_.view<const Name, const Light>().each([&](Entity e, const Name& n, const Light&) {
      if (n.value == "lantern") lantern_ = e;
    });
    const Animator* patrol = lantern_ ? world_.try_get<Animator>(lantern_) : nullptr;
    if (!patrol || !patrol->clips || patrol->clips->empty() || patrol->clips->front().channels.empty())
      return make_error(ErrorCode::Internal, "the maze's lantern has no patrol path");
    for (const glm::vec4& key : patrol->clips->front().channels.front().values) route_.push_back({key.x, key.z});
    world_.remove<Animator>(lantern_);

    // The player, then the bake; the followers after it, sharing the player's pose-AO model (it is
    // self-occlusion), as a game spawns copies of one character.
    const auto add = [&](int i) -> Status {
      const glm::vec2 at = route_.front() + glm::vec2(0.0f, -0.6f * static_cast<float>(i));
      auto c = sample::add_character(world_, options.character, i == 0 ? "player" : "walker " + std::to_string(i),
                                     {at.x, 0.0f, at.y});
      if (!c) return c.error();
      c->speed = 2.0f;
      characters_.push_back(*c);
      return {};
    };
    PENUMBRA_TRY(add(0));
    carry_lantern();
    world_.update(0.0);
    if (Status s = add_default_lighting(world_, options.preset, /*authored=*/false); !s) return s;
    auto baked = sample::bake_or_load(world_, options.preset, options.bake);
    if (!baked) return baked.error();
    std::printf("lantern_maze: %s\n", baked->c_str());
    const int count = options.characters > 0 ? options.characters : 1;
    for (int i = 1; i < count; ++i) PENUMBRA_TRY(add(i));
    world_.update(0.0);
    if (Status s = add_default_lighting(world_, options.preset, /*authored=*/false); !s) return s;
    for (std::size_t i = 1; i < characters_.size(); ++i)
      share_pose_ao(world_, characters_[0].root, world_, characters_[i].root);
    world_.view<IndirectTransport>().each([&](Entity e, IndirectTransport&) { transport_ = e; });
    if (!transport_ || !world_.get<IndirectTransport>(transport_).data)
      return make_error(ErrorCode::Internal, "the maze has no baked indirect transport");
    obstacles_ = sample::Obstacles::of_static_meshes(world_);
    camera_.set(0.0f, 3.0f, 0.8f);  // under the 2.5 m ceiling
    return {};
  }

  World& world() override { return world_; }

  std::vector<std::string> help() const override {
    return {"Lantern maze - Penumbra sample",
            "W A S D / arrows: walk   mouse drag or Q E: turn the camera",
            "The walls' bounce light follows the lantern you carry."};
  }

  std::string status() const override {
    char line[160];
    const glm::vec3 e = indirect_at(kWatchPoint, kWatchNormal, false);
    std::snprintf(line, sizeof line, "player at (%.1f, %.1f); bounce light on the green wall's east face %.3f W/m^2",
                  characters_[0].position.x, characters_[0].position.z, (e.r + e.g + e.b) / 3.0f);
    return line;
  }

  // Follow the lantern's old patrol route, out and back; the camera turns towards where it goes.
  sample::Input autoplay(int) override {
    const glm::vec2 p(characters_[0].position.x, characters_[0].position.z);
    while (next_ < route_.size() && glm::length(route_[next_] - p) < 0.25f) ++next_;
    sample::Input in;
    if (next_ >= route_.size()) return in;
    const glm::vec2 d = glm::normalize(route_[next_] - p);
    // Input is relative to the camera: turn the camera part of the way towards the heading.
    const float heading = std::atan2(d.x, d.y);
    float diff = heading - camera_.yaw();
    while (diff > kPi) diff -= 2.0f * kPi;
    while (diff < -kPi) diff += 2.0f * kPi;
    in.turn = 0.15f * diff;
    const float yaw = camera_.yaw() + in.turn;
    const glm::vec2 forward(std::sin(yaw), std::cos(yaw)), right(-forward.y, forward.x);
    in.move = {-glm::dot(d, right), glm::dot(d, forward)};
    return in;
  }

  void step(const sample::Input& input, double dt) override {
    camera_.turn(input.turn);
    sample::walk(world_, characters_[0], camera_.world_direction(input.move), dt, obstacles_);
    // The others follow the one ahead of them.
    for (std::size_t i = 1; i < characters_.size(); ++i) {
      const glm::vec3 ahead = characters_[i - 1].position - characters_[i].position;
      const float gap = glm::length(glm::vec2(ahead.x, ahead.z));
      const glm::vec2 dir = gap > 0.8f ? glm::vec2(ahead.x, ahead.z) / gap : glm::vec2(0.0f);
      sample::walk(world_, characters_[i], dir, dt, obstacles_);
    }
    carry_lantern();
  }

  CameraView camera(float aspect) override {
    return camera_.view(characters_[0].position + glm::vec3(0.0f, 1.2f, 0.0f), aspect, obstacles_);
  }

  // What the tests check: where the player and the lantern are, the direct and indirect
  // irradiance at the watched wall point, and the bounce light on the last walker's chest (the
  // mean over four horizontal normals, from the transport's bounce probes): the CPU evaluations of
  // what the renderer shows.
  void report(std::FILE* out) override {
    const glm::vec3 lantern = world_.get<Transform>(lantern_).translation;
    const glm::vec3 direct = indirect_at(kWatchPoint, kWatchNormal, true);
    const glm::vec3 indirect = indirect_at(kWatchPoint, kWatchNormal, false);
    glm::vec3 walker(0.0f);
    const auto* transport = world_.try_get<IndirectTransport>(transport_);
    const auto* map = world_.try_get<IndirectLightmap>(transport_);
    if (transport && transport->data && map)
      for (const glm::vec3 n : {glm::vec3(1, 0, 0), glm::vec3(-1, 0, 0), glm::vec3(0, 0, 1), glm::vec3(0, 0, -1)})
        walker += 0.25f * sample_bounce_probes(transport->data->probes, map->probes,
                                               characters_.back().position + glm::vec3(0.0f, 1.2f, 0.0f), n);
    std::fprintf(out, "player_x=%.4f player_z=%.4f lantern_x=%.4f lantern_z=%.4f lantern_distance=%.4f "
                 "wall_direct=%.5f wall_indirect=%.5f walker_bounce=%.5f",
                 characters_[0].position.x, characters_[0].position.z, lantern.x, lantern.z,
                 glm::length(lantern - kWatchPoint), (direct.r + direct.g + direct.b) / 3.0f,
                 (indirect.r + indirect.g + indirect.b) / 3.0f, (walker.r + walker.g + walker.b) / 3.0f);
  }

 private:
  void carry_lantern() {
    const Character& c = characters_[0];
    const float s = std::sin(c.heading), co = std::cos(c.heading);
    const glm::vec3 hand(co * kHand.x + s * kHand.z, kHand.y, -s * kHand.x + co * kHand.z);
    // Only a moved lantern is patched: the transport recomputes the bounce light when it moves.
    if (world_.get<Transform>(lantern_).translation != c.position + hand)
      world_.patch<Transform>(lantern_).translation = c.position + hand;
  }

  glm::vec3 indirect_at(glm::vec3 x, glm::vec3 n, bool direct) const {
    const auto* transport = world_.try_get<IndirectTransport>(transport_);
    const auto* map = world_.try_get<IndirectLightmap>(transport_);
    if (!transport || !transport->data || !map) return glm::vec3(0.0f);
    return sample_indirect_irradiance(*transport->data, direct ? map->direct : map->irradiance, x, n);
  }

  World world_;
  Entity lantern_, transport_;
  std::vector<Character> characters_;  // [0] the player, carrying the lantern
  std::vector<glm::vec2> route_;       // the lantern's old patrol, out and back
  std::size_t next_ = 0;
  sample::Obstacles obstacles_;
  sample::FollowCamera camera_;
};

}  // namespace

int main(int argc, char** argv) {
  return sample::play<LanternMaze>(argc, argv, "lantern_maze",
                                  "lantern_maze: carry a lantern through the maze; the walls' bounce light follows (Penumbra sample)");
}
