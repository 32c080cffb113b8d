// The replay runner: a fuzz harness without libFuzzer, over a seed corpus, in the normal build
// (ctest fuzz.<target>). Usage: <target>_replay [--write-seeds DIR] PATH...; each PATH is a file
// or a directory of files. A .pbake file given to a chunk harness (penumbra_fuzz_chunk_type() != 0)
// stands for the payloads of that type it holds: fed to the harness, or with --write-seeds written
// to DIR as the libFuzzer corpus (scripts/fuzz). Exit 1 when no input was run.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz.h"
#include "penumbra/core/pbake.h"

namespace {

std::vector<std::uint8_t> read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

int main(int argc, char** argv) {
  std::filesystem::path seeds_out;
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--write-seeds" && i + 1 < argc) {
      seeds_out = argv[++i];
      continue;
    }
    std::error_code ec;
    if (std::filesystem::is_directory(a, ec)) {
      for (const auto& e : std::filesystem::directory_iterator(a))
        if (e.is_regular_file()) files.push_back(e.path());
    } else if (std::filesystem::is_regular_file(a, ec)) {
      files.push_back(a);
    } else {
      std::fprintf(stderr, "%s: %s is neither a file nor a directory\n", argv[0], a.c_str());
      return 1;
    }
  }
  std::sort(files.begin(), files.end());
  const std::uint32_t chunk_type = penumbra_fuzz_chunk_type();
  std::size_t runs = 0, written = 0;
  for (const auto& f : files) {
    if (chunk_type != 0 && f.extension() == ".pbake") {
      auto bake = penumbra::read_bake_file(f);
      if (!bake) {
        std::fprintf(stderr, "%s: %s\n", argv[0], bake.error().message.c_str());
        return 1;
      }
      for (const penumbra::BakeChunk& c : bake->chunks) {
        if (c.type != chunk_type) continue;
        const auto* bytes = reinterpret_cast<const std::uint8_t*>(c.payload.data());
        if (!seeds_out.empty()) {
          std::filesystem::create_directories(seeds_out);
          std::ofstream(seeds_out / (f.stem().string() + "-" + std::to_string(written++)), std::ios::binary)
              .write(reinterpret_cast<const char*>(bytes), static_cast<std::streamsize>(c.payload.size()));
        } else {
          LLVMFuzzerTestOneInput(bytes, c.payload.size());
          ++runs;
        }
      }
      continue;
    }
    if (!seeds_out.empty()) continue;
    const std::vector<std::uint8_t> bytes = read_bytes(f);
    LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
    ++runs;
  }
  if (!seeds_out.empty()) {
    std::printf("%s: wrote %zu seeds to %s\n", argv[0], written, seeds_out.c_str());
    return written > 0 ? 0 : 1;
  }
  std::printf("%s: %zu inputs ran without a finding\n", argv[0], runs);
  if (runs == 0) {
    std::fprintf(stderr, "%s: no input ran; give seed files, directories or .pbake files with this target's chunks\n",
                 argv[0]);
    return 1;
  }
  return 0;
}
