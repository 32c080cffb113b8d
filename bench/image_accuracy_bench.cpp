// `penumbra bench image-accuracy`: the real-time renderer's lit, direct and indirect views against
// an offline reference of the same frame, per large region of the image.
//
// For each built-in scene (the Cornell box, the courtyard, and the maze of the indirect transport,
// whose regions are listed beside the goal's) at the default preset (medium, seed 1):
// the default lighting components of `penumbra render`, every baker, the bake attached; the frame
// of the scene's camera rendered into a float target (linear radiance, no tone mapping) in the
// views lit, direct, indirect, and the data views albedo, position and normal. The reference is
// the offline renderer's converged frame of the same camera (offline/offline_renderer.h, mode
// reference: one ray through each pixel's centre, the bakes' light models): direct = the lights'
// light by next-event estimation (area lights sampled over their area; what the renderer draws
// itself), indirect = the unbiased paths (Russian roulette, no bounce limit: bounced light, the
// sky, emissive surfaces); radiance = albedo / pi x E with the surface's textured albedo, plus its
// emission in the lit view; each pixel's standard error per view.
//
// A pixel counts when a CPU ray through its centre (RayScene, the same camera) hits a surface
// within 0.5 % of its distance from the renderer's position (edges and background left out) and
// the renderer's albedo there is not black (a rect light's emitter is drawn, but it is not
// geometry the reference sees; a black surface reflects nothing to judge); its
// region is the hit entity's name and the axis its geometric normal faces most ("floor +y",
// "short_block +x"). Per scene, view and region: mean luminance of the real-time view and of the
// reference, their ratio, the median per-pixel relative error |rt - ref| / max(ref, 5 % of the
// view's mean reference), the region mean's relative standard error (ref_stderr) and the median
// per-pixel one; a region dark in both images in a view (under 0.1 % of the view's mean) has ratio
// nan and is not judged. Regions under 2 % of the counted pixels are listed but not judged ("large" 0).
// Goal (issue "The real-time image agrees with a path tracer"): every large region's ratio within
// 5 % and its median relative error at most 5 %. The views lit-soft16 and direct-soft16 are lit
// and direct at RenderSettings::shadow_taps 16 (rect lights' soft shadows), listed beside the
// default's and not judged. Images: OUT/image-accuracy-SCENE-VIEW-{realtime,
// reference}.png (tone mapped as the renderer does) and .exr (linear).
#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "bench.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/bakers.h"
#include "penumbra/core/colour.h"
#include "penumbra/core/jobs.h"
#include "penumbra/image/image.h"
#include "penumbra/offline/offline_renderer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"

namespace penumbra::bench {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

Status write_pair(const Options& options, const std::string& stem, const Image& linear) {
  if (options.out_dir.empty()) return {};
  Image png = linear;
  png.rgba8.resize(linear.rgba32f.size());
  for (std::size_t i = 0; i < linear.rgba32f.size() / 4; ++i) {
    const glm::vec3 c = display_colour(pixel_rgb(linear, i), 1.0f, true);  // as the renderer's 8-bit targets
    for (int k = 0; k < 3; ++k) png.rgba8[4 * i + k] = static_cast<std::uint8_t>(std::lround(255.0f * c[k]));
    png.rgba8[4 * i + 3] = 255;
  }
  const std::string base = options.out_dir + "/" + stem;
  PENUMBRA_TRY(write_image(png, base + ".png"));
  return write_image(linear, base + ".exr");
}

std::string axis_name(glm::vec3 n) {
  const glm::vec3 a = glm::abs(n);
  const int k = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
  return std::string(n[k] >= 0.0f ? "+" : "-") + "xyz"[k];
}

struct RegionSums {
  std::size_t pixels = 0;
  double rt = 0.0, ref = 0.0, ref_var = 0.0;
  std::vector<double> rel_err, pixel_rel_stderr;
};

// The reference must be able to tell a 5 % median error: in every large region of every judged
// view its median pixel's relative standard error at most half that (the median |error| of a
// perfect image against a reference with per-pixel noise s is about 0.67 s). A reference over it
// is rendered again with the paths that would take it under, at most kMaxSampleFactor x `samples`
// (not in a quick run); the report gives the noisiest region's figure it ends with.
constexpr double kJudgedPixelStderr = 0.025;
constexpr std::uint32_t kMaxSampleFactor = 8;

// The pixel's relative-error floor: a dark pixel's error counts against 5 % of the view's mean.
double error_floor(double ref, double view_mean) { return std::max(ref, 0.05 * view_mean); }

// The reference's image of a view (lit*, direct* or indirect) and each pixel's standard error.
struct ReferenceView {
  const std::vector<glm::vec3>& image;
  const std::vector<glm::vec3>& std_error;
};
ReferenceView reference_view(const OfflineImage& r, const std::string& view) {
  if (view.starts_with("lit")) return {r.lit, r.lit_std_error};
  if (view.starts_with("direct")) return {r.direct, r.direct_std_error};
  return {r.indirect, r.indirect_std_error};
}

// The largest median per-pixel relative standard error of the reference over the large regions
// (at least 2 % of the counted pixels) in the judged views lit, direct and indirect.
double noisiest_region(const OfflineImage& reference, const std::vector<std::size_t>& counted,
                       const std::vector<int>& region_of, std::size_t regions) {
  double worst = 0.0;
  for (const char* name : {"lit", "direct", "indirect"}) {
    const ReferenceView view = reference_view(reference, name);
    double mean = 0.0;
    for (const std::size_t i : counted) mean += luminance(view.image[i]);
    mean /= double(counted.size());
    if (!(mean > 0.0)) continue;  // a view without light has nothing to judge
    std::vector<std::vector<double>> stderrs(regions);
    for (const std::size_t i : counted)
      stderrs[std::size_t(region_of[i])].push_back(luminance(view.std_error[i]) /
                                                   error_floor(luminance(view.image[i]), mean));
    for (const std::vector<double>& s : stderrs)
      if (s.size() * 50 >= counted.size()) worst = std::max(worst, median(s));
  }
  return worst;
}

// One scene's rows: the frame rendered, the reference computed, the regions compared; the
// reference's paths per pixel in `reference_spp`, its noisiest_region() in `noisiest`.
Status measure(const Options& options, const std::string& scene, std::uint32_t width, std::uint32_t height,
               std::uint32_t samples, Device& device, Report& report, std::vector<std::string>& failures,
               std::uint32_t& reference_spp, double& noisiest) {
  World world;
  register_lighting(world);
  register_bakers(world);
  auto loaded = load_builtin(world, scene);
  if (!loaded) return loaded.error();
  world.update(0.0);
  PENUMBRA_TRY(add_default_lighting(world, Preset::Medium, false));
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  BakeSettings bake;  // the default preset and seed of `penumbra bake`
  auto baked = bake_world(world, {}, bake, jobs);
  if (!baked) return baked.error();
  world.update(0.0);

  const float aspect = float(width) / float(height);
  const CameraView camera = loaded->camera ? camera_view(world, loaded->camera, aspect) : framing_camera_view(world, aspect);
  auto renderer = Renderer::create(device);
  if (!renderer) return renderer.error();
  std::map<std::string, Image> views;
  // A view's name -> the renderer's view and shadow taps.
  const std::vector<std::tuple<std::string, std::string, std::uint32_t>> rendered = {
      {"lit", "lit", 4},         {"direct", "direct", 4}, {"indirect", "indirect", 4}, {"albedo", "albedo", 4},
      {"position", "position", 4}, {"normal", "normal", 4}, {"lit-soft16", "lit", 16}, {"direct-soft16", "direct", 16}};
  for (const auto& [name, view, taps] : rendered) {
    RenderSettings settings;
    settings.view = view;
    settings.shadow_taps = taps;
    auto image = (*renderer)->render_image(world, camera, width, height, settings, true);
    if (!image) return image.error();
    views[name] = std::move(*image);
  }

  // Which pixels count, and their regions: a CPU ray through each pixel's centre.
  auto rays = RayScene::build(world);
  if (!rays) return rays.error();
  const glm::mat4 clip_to_world = glm::inverse(camera.projection * camera.view);
  const std::size_t count = std::size_t(width) * height;
  std::vector<int> region_of(count, -1);
  std::vector<std::string> region_names;
  std::map<std::string, int> region_index;
  std::vector<std::size_t> counted;  // the pixels that count, in order
  for (std::uint32_t y = 0; y < height; ++y) {
    for (std::uint32_t x = 0; x < width; ++x) {
      const std::size_t i = std::size_t(y) * width + x;
      const auto [origin, dir] = camera_ray(clip_to_world, {float(x) + 0.5f, float(y) + 0.5f}, width, height);
      Hit hit;
      if (!rays->intersect(Ray{origin, 0.0f, dir}, hit)) continue;
      const glm::vec3 p = pixel_rgb(views["position"], i);
      const glm::vec3 q = origin + hit.t * dir;
      if (!(glm::distance(p, q) <= 0.005f * glm::distance(origin, q))) continue;
      if (!(glm::length(pixel_rgb(views["normal"], i)) > 0.5f)) continue;
      if (pixel_rgb(views["albedo"], i) == glm::vec3(0.0f)) continue;  // reflects nothing, or a rect light's emitter
      const auto* name = world.try_get<Name>(hit.entity);
      const std::string region =
          (name && !name->value.empty() ? name->value : "entity " + std::to_string(hit.entity.index)) + " " +
          axis_name(hit.back_face ? -hit.normal : hit.normal);
      auto [it, added] = region_index.emplace(region, int(region_names.size()));
      if (added) region_names.push_back(region);
      region_of[i] = it->second;
      counted.push_back(i);
    }
  }
  if (counted.empty()) return Error{ErrorCode::Internal, scene + ": no pixel of the frame hits a surface"};

  // The reference: the offline renderer's converged frame (offline/offline_renderer.h) of the same
  // camera, `samples` paths and direct estimates per pixel, rendered again with more when it is
  // too noisy to judge the goal (see kJudgedPixelStderr).
  OfflineSettings reference;
  reference.mode = OfflineMode::Reference;
  reference.width = width;
  reference.height = height;
  reference.spp = samples;
  reference.seed = 11;
  const SurfaceTextures textures = SurfaceTextures::gather(world);
  const std::vector<WorldLight> lights = gather_lights(world);
  auto offline = render_offline(*rays, lights, camera, reference, jobs, &textures);
  if (!offline) return offline.error();
  noisiest = noisiest_region(*offline, counted, region_of, region_names.size());
  if (noisiest > kJudgedPixelStderr && !options.quick) {
    const double needed = (noisiest / kJudgedPixelStderr) * (noisiest / kJudgedPixelStderr);
    reference.spp = samples * std::bit_ceil(static_cast<std::uint32_t>(std::ceil(std::min(needed, double(kMaxSampleFactor)))));
    offline = render_offline(*rays, lights, camera, reference, jobs, &textures);
    if (!offline) return offline.error();
    noisiest = noisiest_region(*offline, counted, region_of, region_names.size());
  }
  reference_spp = reference.spp;

  for (const char* view : {"lit", "direct", "indirect", "lit-soft16", "direct-soft16"}) {
    const std::string v = view;
    const bool judged = !v.ends_with("-soft16");
    const Image& rt = views[v];
    Image ref;
    ref.width = width;
    ref.height = height;
    ref.rgba32f.assign(4 * count, 0.0f);
    const ReferenceView reference_pixels = reference_view(*offline, v);
    const std::vector<glm::vec3>& ref_view = reference_pixels.image;
    const std::vector<glm::vec3>& ref_error = reference_pixels.std_error;
    std::vector<float> ref_lum(counted.size()), ref_se(counted.size()), rt_lum(counted.size());
    double mean_ref = 0.0;
    for (std::size_t k = 0; k < counted.size(); ++k) {
      const std::size_t i = counted[k];
      for (int c = 0; c < 3; ++c) ref.rgba32f[4 * i + c] = ref_view[i][c];
      ref.rgba32f[4 * i + 3] = 1.0f;
      ref_lum[k] = luminance(ref_view[i]);
      ref_se[k] = luminance(ref_error[i]);
      rt_lum[k] = luminance(pixel_rgb(rt, i));
      mean_ref += ref_lum[k];
    }
    mean_ref /= double(counted.size());
    std::vector<RegionSums> sums(region_names.size() + 1);  // the last: the whole frame
    for (std::size_t k = 0; k < counted.size(); ++k) {
      const double floor = error_floor(ref_lum[k], mean_ref);
      for (RegionSums* s : {&sums[std::size_t(region_of[counted[k]])], &sums.back()}) {
        ++s->pixels;
        s->rt += rt_lum[k];
        s->ref += ref_lum[k];
        s->ref_var += double(ref_se[k]) * ref_se[k];
        s->rel_err.push_back(std::abs(double(rt_lum[k]) - ref_lum[k]) / floor);
        s->pixel_rel_stderr.push_back(ref_se[k] / floor);
      }
    }
    for (std::size_t r = 0; r < sums.size(); ++r) {
      const RegionSums& s = sums[r];
      const bool whole = r + 1 == sums.size();
      const std::string name = whole ? "frame" : region_names[r];
      const bool large = !whole && s.pixels * 50 >= counted.size();
      // A region this view leaves dark in both images (a face no light reaches directly) has no
      // ratio to judge: "nan", and it passes; light where the reference has none fails.
      const double dark = 1e-3 * mean_ref * double(s.pixels);
      const bool both_dark = s.ref <= dark && s.rt <= dark;
      const double ratio = both_dark ? std::nan("") : s.ref > dark ? s.rt / s.ref : HUGE_VAL;
      const double rel_err = median(s.rel_err);
      report.rows.push_back({scene, v, name, std::to_string(s.pixels), large ? "1" : "0", fmt(s.rt / double(s.pixels)),
                             fmt(s.ref / double(s.pixels)), fmt(ratio, 4), fmt(rel_err, 3),
                             fmt(s.ref > 0.0 ? std::sqrt(s.ref_var) / s.ref : 0.0, 3),
                             fmt(median(s.pixel_rel_stderr), 3)});
      if (judged && large && !both_dark && (!(std::abs(ratio - 1.0) <= 0.05) || rel_err > 0.05))
        failures.push_back(scene + " " + v + " " + name + " (ratio " + fmt(ratio, 3) + ", rel_err " + fmt(rel_err, 3) + ")");
    }
    PENUMBRA_TRY(write_pair(options, "image-accuracy-" + scene + "-" + v + "-realtime", rt));
    if (judged)  // a soft view's reference is its default view's
      PENUMBRA_TRY(write_pair(options, "image-accuracy-" + scene + "-" + v + "-reference", ref));
  }
  return {};
}

Result<Report> run(const Options& options) {
  const std::uint32_t width = options.quick ? 96 : 256, height = options.quick ? 54 : 144;
  const std::uint32_t samples = options.quick ? 64 : 2048;
  auto device = Device::create(DeviceOptions{});
  if (!device) return device.error();
  Report report;
  report.columns = {"scene", "view", "region", "pixels", "large", "realtime", "reference", "ratio", "rel_err",
                    "ref_stderr", "pixel_ref_stderr"};
  std::vector<std::string> failures;
  std::string reference_paths;  // "scene N (noisiest region's median pixel stderr)" per scene
  std::vector<std::string> maze;  // the indirect transport's scene: listed beside the goal's
  for (const char* scene : {"cornell", "courtyard", "maze"}) {
    std::uint32_t spp = 0;
    double noisiest = 0.0;
    PENUMBRA_TRY(measure(options, scene, width, height, samples, **device, report,
                         std::string(scene) == "maze" ? maze : failures, spp, noisiest));
    reference_paths += std::string(reference_paths.empty() ? "" : ", ") + scene + " " + std::to_string(spp) + " (" +
                       fmt(noisiest, 3) + ")";
  }
  for (std::size_t i = 0; i < report.rows.size(); ++i) report.rows[i].push_back(std::to_string(i));
  report.columns.push_back("row");
  report.plot = {"real-time / reference mean luminance per region", "row (scene, view, region: see the CSV)",
                 "ratio", 11, 7, 1, false, false, true};
  report.notes.push_back(std::to_string(width) + "x" + std::to_string(height) + ", preset medium, seed 1; reference: " +
                         reference_paths + " paths per pixel for direct and for indirect light (in brackets the "
                         "largest median pixel_ref_stderr of a large region; " +
                         std::to_string(samples) + " paths, or up to " + std::to_string(kMaxSampleFactor) +
                         "x that where it exceeded " + fmt(kJudgedPixelStderr, 3) + (options.quick ? ", not in a quick run" : "") +
                         "; ref_stderr: relative standard error of the region's reference mean; pixel_ref_stderr: the "
                         "median pixel's, which bounds how small rel_err can be)");
  report.notes.push_back(failures.empty()
                             ? "goal (every large region: ratio within 5 %, median rel_err <= 5 %): met"
                             : "goal (every large region: ratio within 5 %, median rel_err <= 5 %): NOT met by " +
                                   std::to_string(failures.size()) + " region views");
  for (const std::string& f : failures) report.notes.push_back("  " + f);
  report.notes.push_back("maze (the lantern's bounce light from the indirect transport; not part of the goal): " +
                         (maze.empty() ? std::string("every large region within 5 %")
                                       : std::to_string(maze.size()) + " region views outside 5 %"));
  for (const std::string& f : maze) report.notes.push_back("  " + f);
  return report;
}

}  // namespace

PENUMBRA_BENCH("image-accuracy",
               "real-time lit/direct/indirect views of the Cornell box, the courtyard and the maze against the "
               "offline reference of the same frame, per region",
               run);

}  // namespace penumbra::bench
