// penumbra render SCENE [--bake FILE] -o OUT.png|OUT.exr [--width W] [--height H] [--camera NAME]
//                       [--time T] [--frames N [--animate]] [--view V] [--exposure E]
//                       [--shadow-map S] [--shadow-taps 1|4] [--ambient-step 1|2]
//                       [--offline MODE [--spp N | --seconds S] [--std-error E.exr] [--threads N]]
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <string>
#include <vector>

#include "cli.h"
#include "penumbra/core/log.h"
#include "penumbra/core/pbake.h"
#include "penumbra/offline/offline_renderer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/components.h"

namespace penumbra::cli {
namespace {

double percentile(std::vector<double> sorted, double q) {
  std::sort(sorted.begin(), sorted.end());
  const double pos = q * double(sorted.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - double(i);
  return i + 1 < sorted.size() ? sorted[i] * (1.0 - f) + sorted[i + 1] * f : sorted[i];
}

CancelToken g_render_cancel;
void on_render_interrupt(int) { g_render_cancel.cancel(); }

// The share of pixels that are not black (an all-black image is a failure to see anything).
double lit_share(const Image& image, bool exr) {
  std::size_t lit = 0;
  const std::size_t pixels = std::size_t{image.width} * image.height;
  for (std::size_t i = 0; i < pixels; ++i) {
    bool any = false;
    for (std::size_t c = 0; c < 3; ++c)
      any = any || (exr ? image.rgba32f[4 * i + c] > 0.0f : image.rgba8[4 * i + c] > 0);
    lit += any;
  }
  return double(lit) / double(pixels);
}

// An offline view as an image: linear RGBA floats for EXR (alpha: 1 where a surface is seen, so
// that penumbra compare judges only those pixels), display colours for PNG.
Image to_image(const std::vector<glm::vec3>& radiance, const std::vector<std::uint8_t>& covered, std::uint32_t width,
               std::uint32_t height, bool exr, float exposure) {
  Image image;
  image.width = width;
  image.height = height;
  if (exr) {
    image.rgba32f.resize(radiance.size() * 4);
    for (std::size_t i = 0; i < radiance.size(); ++i) {
      for (int c = 0; c < 3; ++c) image.rgba32f[4 * i + c] = radiance[i][c];
      image.rgba32f[4 * i + 3] = covered[i] ? 1.0f : 0.0f;
    }
  } else {
    image.rgba8.resize(radiance.size() * 4);
    for (std::size_t i = 0; i < radiance.size(); ++i) {
      const glm::vec3 d = display_colour(radiance[i], exposure, true);
      for (int c = 0; c < 3; ++c)
        image.rgba8[4 * i + c] = static_cast<std::uint8_t>(std::lround(std::clamp(d[c], 0.0f, 1.0f) * 255.0f));
      image.rgba8[4 * i + 3] = 255;
    }
  }
  return image;
}

struct OfflineArgs {
  OfflineMode mode;
  std::optional<std::uint32_t> spp;
  std::optional<double> seconds;
  std::optional<std::string> std_error;
  unsigned threads = 0;
};

// penumbra render --offline: the CPU renderer (offline/offline_renderer.h) of the same frame.
int render_offline_image(World& world, const std::string& scene, const CameraView& view, std::uint32_t width,
                         std::uint32_t height, const std::string& view_name, float exposure, const std::string& out,
                         bool exr, const OfflineArgs& o) {
  if (view_name != "lit" && view_name != "direct" && view_name != "indirect" && view_name != "albedo")
    return fail(kUsage, "--view " + view_name + ": the offline renderer has the views lit, direct, indirect, albedo");
  RaySceneOptions options;
  options.include_dynamic = true;
  auto rays = RayScene::build(world, options);
  if (!rays) return fail(kFailure, scene + ": " + rays.error().message);
  const std::vector<WorldLight> lights = gather_lights(world);
  OfflineSettings settings;
  settings.mode = o.mode;
  settings.width = width;
  settings.height = height;
  if (o.mode == OfflineMode::Reference || o.mode == OfflineMode::IrradianceCache) settings.spp = 256;
  if (o.spp) settings.spp = *o.spp;
  ThreadPool pool(o.threads);
  std::signal(SIGINT, on_render_interrupt);
  JobContext jobs(&pool, terminal_progress(), &g_render_cancel);
  const SurfaceTextures textures = SurfaceTextures::gather(world);
  if (o.seconds) {
    // A time budget: time the mode at its fewest rays, then take the ray count that fits (the image
    // is then the deterministic one of that count, printed below).
    OfflineSettings probe = settings;
    probe.spp = o.mode == OfflineMode::Reference ? 2 : o.mode == OfflineMode::IrradianceCache ? 6 : 1;
    JobContext quiet(&pool, {}, &g_render_cancel);
    auto first = render_offline(*rays, lights, view, probe, quiet, &textures);
    if (!first) return fail(kFailure, scene + ": " + first.error().message);
    const double per_spp = first->seconds / double(probe.spp);
    settings.spp = static_cast<std::uint32_t>(std::clamp(*o.seconds / std::max(per_spp, 1e-9), double(probe.spp), 65536.0));
  }
  auto image = render_offline(*rays, lights, view, settings, jobs, &textures);
  std::signal(SIGINT, SIG_DFL);
  if (!image) return fail(kFailure, scene + ": " + image.error().message);
  const std::vector<glm::vec3>& radiance = view_name == "direct"     ? image->direct
                                           : view_name == "indirect" ? image->indirect
                                           : view_name == "albedo"   ? image->albedo
                                                                     : image->lit;
  const Image written = to_image(radiance, image->covered, width, height, exr, exposure);
  if (Status s = write_image(written, out); !s) return fail(kFailure, s.error().message);
  if (o.std_error) {
    // The standard error of the view written (the albedo view has none: zeros).
    const std::vector<glm::vec3>& error = view_name == "direct"     ? image->direct_std_error
                                          : view_name == "indirect" ? image->indirect_std_error
                                          : view_name == "albedo"   ? std::vector<glm::vec3>(radiance.size())
                                                                    : image->lit_std_error;
    if (Status s = write_image(to_image(error, image->covered, width, height, true, 1.0f), *o.std_error); !s)
      return fail(kFailure, s.error().message);
  }
  const double share = lit_share(written, exr);
  if (share == 0.0)
    return fail(kFailure, out + ": the image is black (" + view_name + " view, offline " + std::string(to_string(o.mode)) +
                              "): nothing in view gives it light; check the camera (--camera, or none to frame the "
                              "scene) and the scene's lights");
  const double per_pixel = image->covered_pixels ? double(image->indirect_samples) / double(image->covered_pixels) : 0.0;
  std::printf("rendered %s offline (%s, spp %u: %.1f indirect paths per covered pixel, %llu dropped as non-finite) "
              "in %.2f s (%s view) -> %s (%ux%u, %.1f%% of the pixels not black)%s%s\n",
              scene.c_str(), std::string(to_string(o.mode)).c_str(), settings.spp, per_pixel,
              static_cast<unsigned long long>(image->nonfinite_samples), image->seconds, view_name.c_str(), out.c_str(),
              width, height, 100.0 * share, o.std_error ? ", standard error -> " : "",
              o.std_error ? o.std_error->c_str() : "");
  return kSuccess;
}

}  // namespace

int cmd_render(Args args) {
  auto out = args.take("-o");
  auto bake = args.take("--bake");
  auto width_text = args.take("--width");
  auto height_text = args.take("--height");
  auto camera_name = args.take("--camera");
  auto time_text = args.take("--time");
  auto frames_text = args.take("--frames");
  auto view_text = args.take("--view");
  auto exposure_text = args.take("--exposure");
  auto shadow_text = args.take("--shadow-map");
  auto taps_text = args.take("--shadow-taps");
  auto step_text = args.take("--ambient-step");
  auto offline_text = args.take("--offline");
  auto spp_text = args.take("--spp");
  auto seconds_text = args.take("--seconds");
  auto std_error_text = args.take("--std-error");
  auto threads_text = args.take("--threads");
  const bool animate = args.take_flag("--animate");
  bool sky_ok = true;
  const auto sky = take_sky(args, sky_ok);
  if (args.missing_value) return fail(kUsage, args.missing_name + " needs a value");
  if (!sky_ok) return kUsage;
  if (const auto unknown = reject_unknown_options(args, "render")) return *unknown;
  if (args.rest().size() != 1) {
    return fail(kUsage, "render takes one SCENE (builtin:NAME or a .gltf/.glb path) and -o OUT.png|OUT.exr");
  }
  if (!out) return fail(kUsage, "render needs -o OUT.png or -o OUT.exr");
  const bool exr = out->ends_with(".exr");
  if (!exr && !out->ends_with(".png")) return fail(kUsage, "-o " + *out + ": use a .png or .exr file name");
  std::uint32_t width = 1280, height = 720, frames = 0;
  if (width_text) {
    auto v = parse_count("--width", *width_text);
    if (!v || *v == 0 || *v > 16384) return fail(kUsage, "--width must be in 1..16384");
    width = static_cast<std::uint32_t>(*v);
  }
  if (height_text) {
    auto v = parse_count("--height", *height_text);
    if (!v || *v == 0 || *v > 16384) return fail(kUsage, "--height must be in 1..16384");
    height = static_cast<std::uint32_t>(*v);
  }
  if (frames_text) {
    auto v = parse_count("--frames", *frames_text);
    if (!v || *v == 0 || *v > 100000) return fail(kUsage, "--frames must be in 1..100000");
    frames = static_cast<std::uint32_t>(*v);
  }
  double time = 0.0;
  if (time_text) {
    auto v = parse_number(*time_text);
    if (!v || *v < 0.0) return fail(kUsage, "--time must be a non-negative number of seconds");
    time = *v;
  }
  RenderSettings settings;
  if (view_text) settings.view = *view_text;  // checked against the renderer's views below
  if (shadow_text) {
    auto v = parse_count("--shadow-map", *shadow_text);
    if (!v || *v > 8192) return fail(kUsage, "--shadow-map must be 0 (no shadows) or a size in 16..8192");
    settings.shadows = *v > 0;
    if (*v > 0) settings.shadow_map_size = static_cast<std::uint32_t>(*v);
  }
  if (taps_text) {
    if (*taps_text != "1" && *taps_text != "4" && *taps_text != "16")
      return fail(kUsage, "--shadow-taps must be 1, 4 or 16");
    settings.shadow_taps = static_cast<std::uint32_t>(std::stoul(*taps_text));
  }
  if (step_text) {
    if (*step_text != "1" && *step_text != "2") return fail(kUsage, "--ambient-step must be 1 or 2");
    settings.ambient_step = *step_text == "1" ? 1 : 2;
  }
  if (animate && frames == 0) return fail(kUsage, "--animate needs --frames N");
  if (exposure_text) {
    auto v = parse_number(*exposure_text);
    if (!v || *v <= 0.0) return fail(kUsage, "--exposure must be a positive number");
    settings.exposure = static_cast<float>(*v);
  }

  std::optional<OfflineArgs> offline;
  if (offline_text) {
    const auto mode = parse_offline_mode(*offline_text);
    if (!mode) return fail(kUsage, "--offline " + *offline_text + ": use one of " + std::string(offline_mode_names()));
    offline = OfflineArgs{*mode, {}, {}, std_error_text, 0};
    if (spp_text && seconds_text) return fail(kUsage, "--spp and --seconds: give one of them");
    if (spp_text) {
      auto v = parse_count("--spp", *spp_text);
      if (!v || *v == 0 || *v > 65536) return fail(kUsage, "--spp must be in 1..65536");
      offline->spp = static_cast<std::uint32_t>(*v);
    }
    if (seconds_text) {
      auto v = parse_number(*seconds_text);
      if (!v || *v <= 0.0) return fail(kUsage, "--seconds must be a positive number");
      offline->seconds = *v;
    }
    if (std_error_text && (*mode != OfflineMode::Reference || !std_error_text->ends_with(".exr")))
      return fail(kUsage, "--std-error E.exr writes the reference's standard error: use it with --offline reference");
    const auto threads = parse_threads(threads_text);
    if (!threads) return kUsage;
    offline->threads = *threads;
    if (frames > 0 || bake || shadow_text || taps_text || step_text)
      return fail(kUsage, "--offline renders on the CPU: --frames, --bake, --shadow-map, --shadow-taps and "
                          "--ambient-step are the real-time renderer's");
  } else if (spp_text || seconds_text || std_error_text || threads_text) {
    return fail(kUsage, "--spp, --seconds, --std-error and --threads are options of --offline MODE");
  }

  // Scene, baked data, animation time.
  const std::string& scene = args.rest()[0];
  World world;
  if (Status s = load_world(world, scene); !s) return fail(kFailure, s.error().message);
  if (sky)
    if (Status s = set_sky_map(world, sky->path, sky->scale); !s) return fail(kFailure, "--sky: " + s.error().message);
  if (const std::string notice = add_viewing_light(world, scene); !notice.empty()) log(LogLevel::Warning, notice);
  if (bake) {
    auto file = read_bake_file(*bake);
    if (!file) return fail(kFailure, file.error().message);
    if (Status s = attach_bake(world, *file); !s) return fail(kFailure, *bake + ": " + s.error().message);
  }
  world.update(time);

  // Camera: the named one, else the scene's first, else one framing the scene.
  const float aspect = float(width) / float(height);
  Entity camera;
  std::vector<std::string> names;
  for (Entity e : world.view<const Camera>().sorted_entities()) {
    const auto* name = world.try_get<Name>(e);
    std::string n = std::to_string(e.index);  // unnamed cameras go by entity index
    if (name) n = name->value;
    names.push_back(n);
    if ((!camera_name && !camera) || (camera_name && *camera_name == n)) camera = e;
  }
  if (camera_name && !camera) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return fail(kFailure, scene + ": no camera named '" + *camera_name + "'" +
                              (names.empty() ? "; the scene has no cameras" : "; cameras: " + list));
  }
  const CameraView view = camera ? camera_view(world, camera, aspect) : framing_camera_view(world, aspect);
  if (offline)
    return render_offline_image(world, scene, view, width, height, settings.view, settings.exposure, *out, exr, *offline);

  DeviceOptions device_options;
  auto device = Device::create(device_options);
  if (!device) return fail(kFailure, device.error().message);
  auto renderer = Renderer::create(**device);
  if (!renderer) return fail(kFailure, renderer.error().message);
  {
    std::string all;
    bool known = false;
    for (const ViewInfo& v : (*renderer)->views()) {
      known = known || v.name == settings.view;
      all += (all.empty() ? "" : ", ") + std::string(v.name);
    }
    if (!known) return fail(kUsage, "--view: unknown view '" + settings.view + "'; use one of " + all);
  }

  if (frames > 0) {
    // Each frame: sync + record + submit + wait (no read-back), timed on the CPU clock; with
    // --animate first the World's update by 1/60 s (animation, skinning, the lighting systems).
    std::vector<double> ms;
    for (std::uint32_t f = 0; f < frames; ++f) {
      const auto t0 = std::chrono::steady_clock::now();
      if (animate) world.update(1.0 / 60.0);
      if (Status s = (*renderer)->render_frame(world, view, width, height, settings); !s) {
        return fail(kFailure, s.error().message);
      }
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    std::printf("%s: %u %sframes at %ux%u on %s: median %.2f ms, p5 %.2f ms, p95 %.2f ms (%u draws, %.1f MiB GPU)\n",
                scene.c_str(), frames, animate ? "animated " : "", width, height, (*device)->name().c_str(),
                percentile(ms, 0.5),
                percentile(ms, 0.05), percentile(ms, 0.95), (*renderer)->stats().draws,
                double((*renderer)->stats().gpu_bytes) / (1024.0 * 1024.0));
  }
  auto image = (*renderer)->render_image(world, view, width, height, settings, exr);
  if (!image) return fail(kFailure, image.error().message);
  if (Status s = write_image(*image, *out); !s) return fail(kFailure, s.error().message);
  // An all-black image is a failure to see anything (camera inside or away from the geometry,
  // nothing lit), never a success.
  const double share = lit_share(*image, exr);
  if (share == 0.0)
    return fail(kFailure, *out + ": the image is black (" + settings.view +
                              " view): nothing in view gives it light; check the camera (--camera, or none to frame "
                              "the scene), the scene's lights, and for the views of baked lighting the --bake file (the probe "
                              "grid's views leave out DynamicLights, whose bounce is in the lightmap view)");
  std::printf("rendered %s (%s view) -> %s (%ux%u, %.1f%% of the pixels not black)\n", scene.c_str(),
              settings.view.c_str(), out->c_str(), width, height, 100.0 * share);
  return kSuccess;
}

}  // namespace penumbra::cli
