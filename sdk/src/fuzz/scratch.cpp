// fuzz.h: the scratch file and the invariant check.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "fuzz.h"

namespace penumbra::fuzz {

std::filesystem::path scratch_file(const std::uint8_t* data, std::size_t size, std::string_view ext) {
  std::error_code ec;
  const std::filesystem::path dir =
      std::filesystem::is_directory("/dev/shm", ec) ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path();
  const std::filesystem::path path = dir / ("penumbra-fuzz-" + std::to_string(::getpid()) + std::string(ext));
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

void require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "penumbra fuzz: invariant broken: %s\n", what);
  __builtin_trap();
}

}  // namespace penumbra::fuzz
