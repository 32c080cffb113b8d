// Environment maps from OpenEXR files (import/environment.h).
#include "penumbra/import/environment.h"

#include "penumbra/image/image.h"

namespace penumbra {

Result<std::shared_ptr<const EnvironmentMap>> load_environment_map(const std::filesystem::path& path) {
  auto image = read_exr(path.string());
  if (!image) return image.error();
  std::vector<glm::vec3> texels(std::size_t{image->width} * image->height);
  for (std::size_t i = 0; i < texels.size(); ++i)
    texels[i] = pixel_rgb(*image, i);
  return make_environment_map(image->width, image->height, std::move(texels), path.string());
}

}  // namespace penumbra
