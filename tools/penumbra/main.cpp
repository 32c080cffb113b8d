// penumbra: the command-line face of the SDK (bake, inspect, render and benchmark).
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli.h"
#include "penumbra/core/log.h"

namespace {

constexpr const char* kUsage = R"(usage: penumbra COMMAND [ARGS]

Commands:
  bake SCENE -o FILE.pbake [--only LIST] [--preset draft|medium|high] [--threads N] [--seed S] [--force]
       [--shard I/N] [--poses ANIM.glb[,ANIM.glb...]]
      Bake the lighting data of SCENE (a glTF file or builtin:NAME) into FILE.pbake. --only takes a
      comma-separated list of bakers (default: all; 'penumbra bake --list' names them). --poses adds
      the clips of animation files (the character's walk, run, ... delivered apart from it; the
      option may repeat) retargeted by joint name: pose-AO then samples the poses they reach. An unchanged
      scene with the same settings is not baked again unless --force is given. FILE is never the
      scene itself, and an existing FILE that is not a .pbake is replaced only with --force; when
      FILE is a symbolic link, the file it points to is written and the link kept.
      --shard I/N bakes only shard I (from 0) of N into a part file for 'penumbra merge': the work
      items (blocks of probe nodes, AO-field texels, poses, vertices) that a balanced, deterministic
      assignment gives it; an up-to-date part is not baked again.
  bake SCENE --estimate [--only LIST] [--preset P] [--threads N] [--poses ...]
      Print what that bake would take per baker, time and bytes, from a few timed samples of the
      bake itself (a few ranges of each group's elements, then the global step on their results)
      in a fraction of its time; writes nothing.
  merge PART.pbake... -o FILE.pbake [--threads N] [--force]
      Merge the parts of a sharded bake into FILE.pbake, byte-identical to a single-machine bake of
      the same scene and settings; runs the global steps (the probe grid's fill and fit, the
      AO-field grid's inside fill, the pose-AO fit). Refuses parts of different bakes and missing
      or duplicated work items, naming them.
  info FILE.pbake
      Show the file's version, input hash, chunks, their sizes and what they hold.
  render SCENE [--bake FILE] -o OUT.png|OUT.exr [--width W] [--height H] [--camera NAME] [--time T]
         [--frames N [--animate]] [--view V] [--exposure E] [--shadow-map S] [--shadow-taps 1|4|16]
         [--ambient-step 1|2] [--offline MODE [--spp N | --seconds S] [--std-error E.exr] [--threads N]]
      Render SCENE with the Vulkan renderer (lavapipe without a GPU) at W x H (default 1280x720),
      with the lighting data of FILE.pbake, at animation time T seconds. --frames N first renders N
      frames and prints the median, 5th and 95th percentile frame time; --animate advances the scene
      by 1/60 s before each of them (the image is then of the last). V: a debug view, lit by
      default (the renderer's and every render feature's; an unknown name is refused with the list).
      S: shadow map size (0: none).
      --shadow-taps 1 filters shadows bilinearly instead of over 3x3 texels; --ambient-step 1
      evaluates the ambient image (the render features' indirect light and AO) at every pixel instead
      of every second one per axis.
      --offline MODE renders the same frame on the CPU instead (offline/offline_renderer.h): soft
      area-light shadows and unbiased indirect light; MODE mc (plain Monte Carlo), irradiance-filter
      (irradiance filtering, the default choice for a clean image), irradiance-cache (Ward's
      irradiance caching with gradients; N is the rays per record) or reference (converged, with
      --std-error E.exr for each pixel's standard error of the view). --spp N indirect rays per pixel
      (16; reference and irradiance-cache 256), or --seconds S to pick the N that fits S seconds;
      --threads N. Views: lit, direct, indirect, albedo. Deterministic for a given N at any thread
      count.
  compare IMAGE.exr REFERENCE.exr [--reference-error E.exr] [-o DIFF.png]
      Judge IMAGE against REFERENCE (same size; e.g. 'render --view indirect' of both paths) over
      the pixels both cover (alpha > 0): relative RMSE, mean signed error, SSIM of the luminance,
      with E.exr (render --offline reference --std-error) the reference's own relative error; -o
      writes a false-colour map of the relative difference.
  validate FILE
      Check FILE (.gltf, .glb or .pbake) without baking: every check the importer or the chunk
      readers make; exit 1 naming the first problem.
  bench NAME [--quick] [--out DIR] [--threads N]
      Run a benchmark: print its table, write DIR/NAME.csv and the plot DIR/NAME.png (DIR defaults to
      bench-results). 'penumbra bench --list' names them.

Scenes: builtin:cornell, builtin:courtyard, builtin:furnace, or a .gltf/.glb path.
bake and render take --sky SKY.exr [--sky-scale K]: the scene's sky becomes that equirectangular
OpenEXR map (linear radiance, +Y up, -Z at the image's centre) times K (default 1), lighting the
bakes and drawn behind the scene; give a render the --sky its bake had.
Options of every command: --quiet (only errors on stderr), --verbose (the SDK's notes too); by
default its warnings are shown.
Exit codes: 0 success, 1 failure (with a message), 2 bad usage.
)";

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> words(argv + 1, argv + argc);
  if (words.empty()) {
    std::fputs(kUsage, stderr);
    return penumbra::cli::kUsage;
  }
  // --quiet and --verbose anywhere: the SDK's log level on stderr.
  penumbra::LogLevel level = penumbra::LogLevel::Warning;
  std::erase_if(words, [&](const std::string& w) {
    if (w == "--quiet") level = penumbra::LogLevel::Error;
    if (w == "--verbose") level = penumbra::LogLevel::Info;
    return w == "--quiet" || w == "--verbose";
  });
  if (words.empty()) {
    std::fputs(kUsage, stderr);
    return penumbra::cli::kUsage;
  }
  const std::string command = words.front();
  words.erase(words.begin());
  if (command == "--help" || command == "-h" || command == "help") {
    std::fputs(kUsage, stdout);
    return penumbra::cli::kSuccess;
  }
  if (command == "--version") {
    std::printf("penumbra %s\n", PENUMBRA_VERSION);
    return penumbra::cli::kSuccess;
  }
  // The SDK's warnings and errors (dropped triangles, skipped primitives, chunks no module reads) on
  // stderr; the tool's own results go to stdout.
  penumbra::set_log_level(level);
  penumbra::set_log_sink([](penumbra::LogLevel severity, std::string_view message) {
    std::fprintf(stderr, "penumbra: %s: %.*s\n", penumbra::to_string(severity), static_cast<int>(message.size()),
                 message.data());
  });
  penumbra::cli::Args args(std::move(words));
  if (command == "bake") return penumbra::cli::cmd_bake(std::move(args));
  if (command == "merge") return penumbra::cli::cmd_merge(std::move(args));
  if (command == "info") return penumbra::cli::cmd_info(std::move(args));
  if (command == "bench") return penumbra::cli::cmd_bench(std::move(args));
  if (command == "render") return penumbra::cli::cmd_render(std::move(args));
  if (command == "compare") return penumbra::cli::cmd_compare(std::move(args));
  if (command == "validate") return penumbra::cli::cmd_validate(std::move(args));
  std::fprintf(stderr, "penumbra: unknown command '%s'\n\n%s", command.c_str(), kUsage);
  return penumbra::cli::kUsage;
}
