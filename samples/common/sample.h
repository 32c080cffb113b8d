// What the sample games share, written against Penumbra's installed public API only (as a studio's
// game would be): the command line, the frame loop (a GLFW window with Penumbra's renderer under a
// Dear ImGui overlay of help and timings, or headless offscreen frames for tests and CI), walking
// characters (the built-in walker or a glTF such as CesiumMan), a third-person camera, collision
// against the level's static geometry, and the bake a game starts from.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <penumbra/core/result.h>
#include <penumbra/ecs/world.h>
#include <penumbra/lighting/settings.h>
#include <penumbra/scene/camera.h>

namespace sample {

struct Options {
  bool autoplay = false;      // the game plays its own scripted walk (fixed 1/30 s steps)
  int frames = 0;             // frames to run; 0: until the window closes (windowed only)
  std::string screenshot;     // PNG (or EXR) of the last frame, without the overlay
  std::uint32_t width = 1280, height = 720;
  bool headless = false;      // offscreen frames, no window (also when there is no display)
  bool validation = false;    // the Khronos validation layer; any message fails the run
  std::string report;         // per-frame measurements, one "frame=K key=value ..." line each
  std::string character;      // a glTF character; empty: the built-in walker
  std::string bake;           // .pbake cache: attached when its input hash is current, else rewritten
  int characters = 0;         // animated characters, the player included; 0: the game's default
  penumbra::Preset preset = penumbra::Preset::Draft;
  bool stats = false;         // the timings overlay (F2) on from the start; the summary prints at exit anyway
};

// Parses the options every sample takes (`usage` is printed for --help and for errors, which
// return InvalidArgument naming the option).
penumbra::Result<Options> parse_options(int argc, char** argv);
void print_usage(std::FILE* out, std::string_view program, std::string_view about);

// One frame's player input: `move` in [-1, 1]^2 (x right, y forward, relative to the camera's
// heading), `turn` the camera's heading change in radians.
struct Input {
  glm::vec2 move{0.0f};
  float turn = 0.0f;
};

// A game: what it does each frame; run() owns the window, the renderer and the timing.
class Game {
 public:
  virtual ~Game() = default;
  virtual penumbra::World& world() = 0;
  // Lines of on-screen help (the keys) and one status line.
  virtual std::vector<std::string> help() const = 0;
  virtual std::string status() const = 0;
  // The scripted input of frame `frame` (--autoplay).
  virtual Input autoplay(int frame) = 0;
  // Game logic before world().update(dt): move the player, the props and the lights.
  virtual void step(const Input& input, double dt) = 0;
  // The camera after the update.
  virtual penumbra::CameraView camera(float aspect) = 0;
  // Writes frame `frame`'s measurements after the update: "key=value" pairs, space-separated.
  virtual void report(std::FILE* out) = 0;
};

// Runs `game` as the options say; returns the process exit code (messages on stderr, naming
// `program`). Frames: input (keys W A S D / arrows, mouse drag or Q E to turn, F1 help, F2 timings,
// Esc), step, world update, render, present. At exit (or every frame with F2) the frame time and
// each system's CPU milliseconds (World::systems()) are printed.
int run(std::string_view program, Game& game, const Options& options);

// A sample's main(): --help, the options, G::init(options) (its scene and bake; returns a
// penumbra::Status), then run(). Exit codes: 0; 1 a failure (the message on stderr); 2 bad usage.
template <class G>
int play(int argc, char** argv, const char* program, const char* about) {
  for (int i = 1; i < argc; ++i)
    if (std::string_view(argv[i]) == "--help") {
      print_usage(stdout, program, about);
      return 0;
    }
  auto options = parse_options(argc, argv);
  if (!options) {
    std::fprintf(stderr, "%s: %s\n", program, options.error().message.c_str());
    print_usage(stderr, program, about);
    return 2;
  }
  G game;
  if (auto s = game.init(*options); !s) {
    std::fprintf(stderr, "%s: %s\n", program, s.error().message.c_str());
    return 1;
  }
  return run(program, game, *options);
}

// A character that walks: the entity holding its Transform and Animator (the built-in walker's
// root, or an imported glTF's root).
struct Character {
  penumbra::Entity root;
  glm::vec3 position{0.0f};
  float heading = 0.0f;        // radians about +Y; 0 faces the model's walking direction
  float facing_offset = 0.0f;  // minus the yaw the model faces in its file (humanoids: from the feet)
  float speed = 1.4f;          // metres per second at full input
  float radius = 0.3f;         // for collisions
};

// Adds a character at `position` facing +Z: the glTF at `path` (imported, its Animator playing its
// first clip; named `name` through an EntityKey so that bakes key it uniquely) or, for an empty
// path, the built-in walker. Errors: the importer's, and a file without an animated skin.
penumbra::Result<Character> add_character(penumbra::World& world, const std::string& path, const std::string& name,
                                          glm::vec3 position);

// The level's walls: the x-z footprint of each steep triangle of the Static meshes that rises
// through the height a character walks at (floors and ceilings are left out). Cost: O(triangles)
// to build, O(walls) per resolve: for levels of a few thousand triangles.
struct Obstacles {
  struct Box {
    glm::vec2 min, max;
  };
  std::vector<Box> boxes;
  static Obstacles of_static_meshes(penumbra::World& world);
  // `p` pushed out of every box by `radius` (a few passes, so corners resolve).
  glm::vec2 resolve(glm::vec2 p, float radius) const;
  // Whether a circle of `radius` at `p` touches a box. One pass, stops at the first.
  bool blocked(glm::vec2 p, float radius) const;
};

// Moves `c` by `direction` (world x-z, length <= 1) for `dt` seconds, turns it to face where it
// goes, plays its walk clip while it moves (rate following the speed) and holds it when still.
void walk(penumbra::World& world, Character& c, glm::vec2 direction, double dt, const Obstacles& obstacles);
// Writes c's position and heading to its root's Transform, only when they changed (a patch would
// tell every system it moved).
void place(penumbra::World& world, const Character& c);

// A camera behind and above a target, turned by the player.
class FollowCamera {
 public:
  void turn(float radians) { yaw_ += radians; }
  float yaw() const { return yaw_; }
  void set(float yaw, float distance, float height) {
    yaw_ = yaw;
    distance_ = distance;
    height_ = height;
  }
  // The view of `target` (a point about the character's chest) from behind along the heading,
  // pulled in where `walls` stand between them.
  penumbra::CameraView view(glm::vec3 target, float aspect, const Obstacles& walls) const;
  // The world direction that input `move` means for this camera.
  glm::vec2 world_direction(glm::vec2 move) const;

 private:
  float yaw_ = 0.0f, distance_ = 4.5f, height_ = 2.0f;
};

// Bakes every lighting component of `world` with `preset` (progress on stdout), or, when
// `cache` names a .pbake whose input hash matches the World's, attaches that instead; a fresh bake
// is written to `cache` (atomically) when one is named. Returns a line saying which it did.
penumbra::Result<std::string> bake_or_load(penumbra::World& world, penumbra::Preset preset, const std::string& cache);

}  // namespace sample
