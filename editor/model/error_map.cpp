// Heat maps of relative error against a reference (error_map.h).
#include "error_map.h"

#include <algorithm>
#include <cmath>

namespace penumbra::editor {

void summarise_error_map(ErrorMap& map, double tested_sum, double reference_sum) {
  double sum = 0.0, noise_sum = 0.0, squares = 0.0, noise_squares = 0.0;
  map.cells = 0;
  for (std::size_t i = 0; i < map.relative_error.size(); ++i)
    if (!std::isnan(map.relative_error[i])) {
      sum += map.relative_error[i];
      noise_sum += map.relative_noise[i];
      squares += double(map.relative_error[i]) * map.relative_error[i];
      noise_squares += double(map.relative_noise[i]) * map.relative_noise[i];
      ++map.cells;
    }
  if (map.cells == 0) return;
  map.mean = static_cast<float>(sum / map.cells);
  map.reference_noise = static_cast<float>(noise_sum / map.cells);
  map.noise_corrected_rms = static_cast<float>(std::sqrt(std::max(0.0, (squares - noise_squares) / map.cells)));
  map.ratio = reference_sum > 0.0 ? static_cast<float>(tested_sum / reference_sum) : 0.0f;
}

}  // namespace penumbra::editor
