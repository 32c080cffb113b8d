// A game that links only the installed runtime (penumbra::runtime: no Embree, no glTF importer):
// it builds the courtyard, registers the lighting modules, attaches a .pbake baked by the tool
// (argv[1]) and reads what each technique gives it, checking that each value is plausible.
#include <cmath>
#include <cstdio>

#include <penumbra/ao_field/ao_field_system.h>
#include <penumbra/pose_ao/pose_ao_system.h>
#include <penumbra/probe_grid/probe_grid_system.h>
#include <penumbra/runtime.h>
#include <penumbra/scene/builtin.h>
#include <penumbra/scene/components.h>
#include <penumbra/scene/entity_key.h>

namespace {

int fail(const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "consumer: %s%s%s\n", what, detail.empty() ? "" : ": ", detail.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace penumbra;
  if (argc != 2) return fail("usage: consumer FILE.pbake");
  World world;
  register_lighting(world);
  if (auto scene = load_builtin(world, "courtyard"); !scene) return fail("load", scene.error().message);
  world.update(0.0);
  if (Status s = add_default_lighting(world, Preset::Draft, false); !s) return fail("defaults", s.error().message);
  auto file = read_bake_file(argv[1]);
  if (!file) return fail("read", file.error().message);
  if (Status s = attach_bake(world, *file); !s) return fail("attach", s.error().message);
  world.update(0.25);  // the walker takes a step: the lighting systems run

  // Probe grid: the irradiance at the courtyard's centre, facing up.
  const ProbeGridData* grid = nullptr;
  world.view<IrradianceProbeGrid>().each([&](IrradianceProbeGrid& g) { grid = g.data.get(); });
  if (grid == nullptr) return fail("no baked probe grid after attach_bake");
  const glm::vec3 e = evaluate(*grid, glm::vec3(0.0f, 0.5f, 0.0f), glm::vec3(0.0f, 1.0f, 0.0f));
  if (!(e.x > 0.0f && std::isfinite(e.x))) return fail("probe irradiance is not positive");

  // AO fields: the walker (an Entity receiver) is occluded by the crates by some amount in [0, 1).
  auto found = EntityKeys::build(world).find("character/character_mesh", "consumer");
  if (!found) return fail("walker", found.error().message);
  const Entity walker = *found;
  const AOFieldReceiver* receiver = world.try_get<AOFieldReceiver>(walker);
  std::size_t casters = 0;
  world.view<AOFieldCaster>().each([&](AOFieldCaster& c) { casters += c.data ? 1 : 0; });
  if (receiver == nullptr || casters == 0) return fail("no AO-field receiver or baked caster");
  if (!(receiver->occlusion >= 0.0f && receiver->occlusion < 1.0f)) return fail("AO-field occlusion out of range");

  // Pose-AO: the walker's per-vertex AO, one value per vertex, within [0, 1], not all open.
  const VertexAO* ao = world.try_get<VertexAO>(walker);
  const Mesh* mesh = world.try_get<Mesh>(walker);
  if (ao == nullptr || mesh == nullptr || ao->ao.size() != mesh->data->positions.size())
    return fail("the walker has no pose-AO of its vertex count");
  double sum = 0.0;
  for (float a : ao->ao) {
    if (!(a >= 0.0f && a <= 1.0f)) return fail("pose-AO outside [0, 1]");
    sum += a;
  }
  const double mean = sum / double(ao->ao.size());
  if (!(mean < 0.999)) return fail("pose-AO is open everywhere");

  std::printf("consumer: %zu modules; probe E(up) at the centre %.3f W/m^2; walker AO-field occlusion %.3f from %zu "
              "casters; pose-AO mean %.3f over %zu vertices\n",
              lighting_modules().size(), static_cast<double>(e.x), static_cast<double>(receiver->occlusion), casters,
              mean, ao->ao.size());
  return 0;
}
