// Links the installed SDK: loads the Cornell box, updates the World and traces ambient occlusion at
// the centre of the floor, which must be partly occluded by the blocks and walls.
#include <cstdio>

#include <penumbra/bake/integrators.h>
#include <penumbra/bake/ray_scene.h>
#include <penumbra/scene/animation.h>
#include <penumbra/scene/builtin.h>

int main() {
  penumbra::World world;
  penumbra::register_scene_systems(world);
  auto scene = penumbra::load_scene(world, "builtin:cornell");
  if (!scene) {
    std::fprintf(stderr, "%s\n", scene.error().message.c_str());
    return 1;
  }
  world.update(0.0);
  auto rays = penumbra::RayScene::build(world);
  if (!rays) {
    std::fprintf(stderr, "%s\n", rays.error().message.c_str());
    return 1;
  }
  penumbra::Rng rng = penumbra::Rng::stream(1, 0);
  const auto ao = penumbra::ambient_occlusion(*rays, {0.278f, 0.001f, 0.28f}, {0.0f, 1.0f, 0.0f}, 10.0f, 4096, rng);
  std::printf("consumer: %zu triangles, AO at the floor centre %.3f +- %.3f\n", rays->triangle_count(),
              static_cast<double>(ao.value), static_cast<double>(ao.std_error));
  return ao.value > 0.05f && ao.value < 0.95f ? 0 : 1;
}
