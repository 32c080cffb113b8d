// Fuzz target "exr": read_exr on any bytes (penumbra compare's and the benches' loader of images),
// and load_environment_map (the glTF's and --sky's loader of skies) on the same file.
// Invariants: a read succeeds with a width x height within the documented limits and one RGBA
// float per pixel, or fails with an error that starts with the file's path; a map loads only from
// an image that reads, at its size, or fails naming the file.
#include "fuzz/fuzz.h"
#include "penumbra/image/image.h"
#include "penumbra/import/environment.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return 0; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  const std::filesystem::path path = fuzz::scratch_file(data, size, ".exr");
  auto image = read_exr(path.string());
  if (image) {
    fuzz::require(image->width >= 1 && image->height >= 1 && image->width <= 16384 && image->height <= 16384,
                  "an image outside the documented size limits");
    fuzz::require(image->rgba32f.size() == std::size_t(image->width) * image->height * 4, "pixels missing");
  } else {
    fuzz::require(image.error().message.rfind(path.string(), 0) == 0, "an error that does not name the file");
  }
  auto map = load_environment_map(path);
  if (map) {
    fuzz::require(image && (*map)->width == image->width && (*map)->height == image->height &&
                      (*map)->texels.size() == std::size_t(image->width) * image->height,
                  "a map that is not the image's");
  } else {
    fuzz::require(map.error().message.rfind(path.string(), 0) == 0, "a map error that does not name the file");
  }
  return 0;
}
