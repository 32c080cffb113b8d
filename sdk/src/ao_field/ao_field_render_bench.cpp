// `penumbra bench render-ao`: what the renderer's AO passes cost per frame on the courtyard, side
// by side in one run: the AO-field pass per pixel (Kontkanen & Laine 2005, the thesis section 4.1)
// and pose-AO as a per-vertex attribute (Kontkanen & Aila 2006, section 4.2), against the same
// scene without their data (the pass compiled out, nothing uploaded: the "costs nothing
// otherwise"); and the frame's speed/accuracy trades on the whole scene (one shadow tap, half the
// resolution).
//
// One draft bake of the courtyard (probes, AO fields, pose-AO); one World per variant, each with
// the default components of `penumbra render` and only that variant's chunks attached: none
// (probes only), ao-fields (crates still; the pass at its default half resolution), ao-fields-full
// (the same at every pixel: RenderSettings::ambient_step 1), ao-fields-moving (one crate moves
// every frame: its
// caster record is uploaded each frame), pose-ao (the walker's VertexAO changes and is uploaded
// every frame), all (moving crate and pose-AO), all-shadow-taps-1 (RenderSettings::shadow_taps 1),
// all-half-size (a quarter of the pixels). Every frame advances the World by 1/30 s
// (animation, skinning, the AO systems: update_ms) and then renders it (sync, record, submit,
// wait: render_ms) at the size given; variants take turns in rounds so that the shared machine's
// noise falls on all of them alike. Medians and minima over every frame of every round; per frame
// the uploads and the shadow layers drawn again (the walker moves: the layers that see it).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bakers.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/render/renderer.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::bench {
namespace {

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The courtyard with the default lighting components of `penumbra render` (tools/penumbra
// load_world.cpp), the modules' systems registered.
Result<std::unique_ptr<World>> courtyard(Entity& camera) {
  auto world = std::make_unique<World>();
  register_lighting(*world);
  register_bakers(*world);
  auto loaded = load_builtin(*world, "courtyard");
  if (!loaded) return loaded.error();
  camera = loaded->camera;
  world->update(0.0);
  PENUMBRA_TRY(add_default_lighting(*world, Preset::Draft, false));
  return world;
}

// The chunks of `file` that the named modules own.
BakeFile chunks_of(const BakeFile& file, std::initializer_list<std::string_view> modules) {
  BakeFile out = file;
  std::erase_if(out.chunks, [&](const BakeChunk& c) {
    const LightingModule* m = lighting_module_for_chunk(c.type);
    return m == nullptr || std::find(modules.begin(), modules.end(), m->name) == modules.end();
  });
  return out;
}

struct Variant {
  std::string name;
  bool ao_fields = false, moving_crate = false, pose_ao = false;
  RenderSettings settings;
  std::uint32_t width = 0, height = 0;
  std::unique_ptr<World> world;
  std::unique_ptr<Renderer> renderer;
  CameraView camera;
  Entity crate;
  std::vector<double> update_ms, render_ms;
  std::uint64_t vertex_ao_uploads = 0, ao_field_bytes = 0, shadow_layers_drawn = 0, frames = 0;
  std::uint32_t casters = 0;
};

Result<Report> run(const Options& options) {
  const std::uint32_t width = options.quick ? 320 : 1280, height = options.quick ? 180 : 720;
  const int rounds = options.quick ? 2 : 3, frames_per_round = options.quick ? 8 : 20;

  // One bake of everything (draft, seed 1).
  Entity camera;
  auto baked_world = courtyard(camera);
  if (!baked_world) return baked_world.error();
  BakeSettings settings;
  settings.preset = Preset::Draft;
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  auto baked = bake_world(**baked_world, {"probe-grid", "ao-field", "pose-ao"}, settings, jobs);
  if (!baked) return baked.error();
  const BakeFile& file = baked->file;

  DeviceOptions device_options;
  auto device = Device::create(device_options);
  if (!device) return device.error();

  std::vector<Variant> variants;
  const auto add = [&](std::string name, bool fields, bool moving, bool pose, std::uint32_t ao_step = 2,
                       std::uint32_t shadow_taps = 4, std::uint32_t divisor = 1) {
    Variant v;
    v.name = std::move(name);
    v.ao_fields = fields;
    v.moving_crate = moving;
    v.pose_ao = pose;
    v.settings.ambient_step = ao_step;
    v.settings.shadow_taps = shadow_taps;
    v.width = width / divisor;
    v.height = height / divisor;
    variants.push_back(std::move(v));
  };
  add("none", false, false, false);
  add("ao-fields", true, false, false);
  add("ao-fields-full", true, false, false, 1);
  add("ao-fields-moving", true, true, false);
  add("pose-ao", false, false, true);
  add("all", true, true, true);
  add("all-shadow-taps-1", true, true, true, 2, 1);
  add("all-half-size", true, true, true, 2, 4, 2);
  for (Variant& v : variants) {
    auto world = courtyard(camera);
    if (!world) return world.error();
    v.world = std::move(*world);
    PENUMBRA_TRY(attach_bake(*v.world, chunks_of(file, {"probe-grid"})));
    if (v.ao_fields) PENUMBRA_TRY(attach_bake(*v.world, chunks_of(file, {"ao-field"})));
    if (v.pose_ao) PENUMBRA_TRY(attach_bake(*v.world, chunks_of(file, {"pose-ao"})));
    v.world->update(0.0);
    v.camera = camera_view(*v.world, camera, float(v.width) / float(v.height));
    for (Entity e : v.world->view<const AOFieldCaster, const WorldTransform>().sorted_entities())
      if (glm::distance(glm::vec3(v.world->get<WorldTransform>(e).matrix[3]), glm::vec3(-3.0f, 0.4f, -6.0f)) < 1e-3f)
        v.crate = e;  // the far crate
    auto renderer = Renderer::create(**device);
    if (!renderer) return renderer.error();
    v.renderer = std::move(*renderer);
    PENUMBRA_TRY(v.renderer->render_frame(*v.world, v.camera, v.width, v.height, v.settings));  // warm-up
  }

  // Rounds: each variant renders frames_per_round animated frames in turn.
  for (int round = 0; round < rounds; ++round) {
    for (Variant& v : variants) {
      for (int f = 0; f < frames_per_round; ++f) {
        auto t0 = std::chrono::steady_clock::now();
        if (v.moving_crate && v.crate) {
          const float phase = 0.1f * float(v.frames);
          v.world->patch<Transform>(v.crate).translation = glm::vec3(-3.0f + std::sin(phase), 0.4f, -6.0f);
        }
        v.world->update(1.0 / 30.0);
        v.update_ms.push_back(ms_since(t0));
        t0 = std::chrono::steady_clock::now();
        PENUMBRA_TRY(v.renderer->render_frame(*v.world, v.camera, v.width, v.height, v.settings));
        v.render_ms.push_back(ms_since(t0));
        v.vertex_ao_uploads += v.renderer->stats().vertex_ao_uploads;
        v.ao_field_bytes += v.renderer->stats().counter("ao-field.bytes_uploaded");
        v.shadow_layers_drawn += v.renderer->stats().shadow_layers_rendered;
        v.casters = static_cast<std::uint32_t>(v.renderer->stats().counter("ao-field.casters"));
        ++v.frames;
      }
    }
  }

  Report report;
  report.columns = {"variant_id", "variant", "width", "height", "frames", "update_ms", "render_ms", "render_ratio",
                    "render_min_ms", "min_ratio", "ao_field_casters", "vertex_ao_uploads_per_frame",
                    "ao_field_bytes_per_frame", "shadow_layers_per_frame"};
  report.plot = {"courtyard frame time by AO pass and trade (lit view, lavapipe)",
                 "variant (0 none, 1 ao-fields, 2 ao-fields-full, 3 ao-fields-moving, 4 pose-ao, 5 all, "
                 "6 all-shadow-taps-1, 7 all-half-size)",
                 "render ms (median)", 0, 6, -1, false, false, true};
  const double base = median(variants[0].render_ms);
  const double base_min = *std::min_element(variants[0].render_ms.begin(), variants[0].render_ms.end());
  for (std::size_t i = 0; i < variants.size(); ++i) {
    const Variant& v = variants[i];
    const double render = median(v.render_ms);
    const double fastest = *std::min_element(v.render_ms.begin(), v.render_ms.end());
    const double per_frame = 1.0 / double(std::max<std::uint64_t>(v.frames, 1));
    report.rows.push_back({std::to_string(i), v.name, std::to_string(v.width), std::to_string(v.height),
                           std::to_string(v.frames), fmt(median(v.update_ms), 3), fmt(render, 4),
                           fmt(base > 0.0 ? render / base : 0.0, 3), fmt(fastest, 4),
                           fmt(base_min > 0.0 ? fastest / base_min : 0.0, 3), std::to_string(v.casters),
                           fmt(double(v.vertex_ao_uploads) * per_frame, 3),
                           fmt(double(v.ao_field_bytes) * per_frame, 4),
                           fmt(double(v.shadow_layers_drawn) * per_frame, 3)});
  }
  report.notes.push_back("render_ratio: median render_ms / none's; min_ratio: the fastest frames' ratio (less "
                         "sensitive to other load on the machine); measured in the same run (" +
                         std::to_string(rounds) + " rounds of " + std::to_string(frames_per_round) +
                         " frames per variant)");
  // The trades against the whole scene at the defaults (variants 5-7).
  const double all = median(variants[5].render_ms);
  report.notes.push_back("trades on the whole scene: one shadow tap " + fmt(median(variants[6].render_ms) / all, 3) +
                         "x the default frame, half the width and height " +
                         fmt(median(variants[7].render_ms) / all, 3) + "x (accuracy: README's renderer table)");
  const Variant& none = variants[0];
  const bool costs_nothing = none.casters == 0 && none.vertex_ao_uploads == 0 && none.ao_field_bytes == 0;
  report.notes.push_back("goal: a pass costs nothing without its data: none has ao_field_casters " +
                         std::to_string(none.casters) + " (the AO-field pass compiled out), " +
                         std::to_string(none.vertex_ao_uploads) + " vertex AO uploads, " +
                         std::to_string(none.ao_field_bytes) + " AO-field bytes (" +
                         (costs_nothing ? "met" : "NOT met") +
                         "); pose-ao's min_ratio is what its attribute upload costs");
  return report;
}

}  // namespace

PENUMBRA_BENCH("render-ao", "renderer AO passes on the courtyard: frame time with AO fields (still, moving crate), "
               "pose-AO and both against none, side by side; uploads per frame", run);

}  // namespace penumbra::bench
