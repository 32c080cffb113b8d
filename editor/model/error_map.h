// A heat map of relative error against a brute-force reference, per cell of a coarse grid over
// the view, with the reference's own noise beside it: what the editor's error views show (the
// probe grid against path-traced irradiance, probe_grid_views.h; the lit view against the
// offline reference, reference_map.h), and how they say when the error is only the noise.
#pragma once

#include <cstdint>
#include <vector>

namespace penumbra::editor {

struct ErrorMap {
  std::uint32_t columns = 0, rows = 0;
  // Row-major, row 0 at the top; NaN where the cell has no value (no surface, nothing to compare).
  std::vector<float> relative_error;  // |tested - reference| / reference, in luminance
  std::vector<float> relative_noise;  // per cell: the reference's relative standard error there
  std::uint32_t cells = 0;        // cells with a value
  float mean = 0.0f;              // mean relative error over those cells
  float reference_noise = 0.0f;   // mean relative standard error of the reference (what "exact" means here)
  // The error with the reference's noise taken out: sqrt(max(0, mean(e^2) - mean(sigma^2))), e
  // each cell's relative error and sigma its relative standard error (the noise adds its variance
  // to e^2 on average).
  float noise_corrected_rms = 0.0f;
  // The tested luminance summed over the cells with a value, over the reference's: the bias.
  float ratio = 0.0f;
  double seconds = 0.0;
  // Whether the map shows the tested error rather than the reference's noise: the mean error is
  // more than twice the mean noise (a noise-only map's mean |e| is about 0.8 of it). Otherwise
  // only an upper bound is known; more reference paths lower the noise as 1 / sqrt(paths).
  bool above_noise() const { return mean > 2.0f * reference_noise; }
  // Whether cell i's error exceeds twice its own noise (false for a cell without a value).
  bool cell_above_noise(std::size_t i) const { return relative_error[i] > 2.0f * relative_noise[i]; }
};

// Fills cells, mean, reference_noise and noise_corrected_rms from relative_error and
// relative_noise, and ratio from the luminance sums over the cells with a value. O(cells).
void summarise_error_map(ErrorMap& map, double tested_sum, double reference_sum);

}  // namespace penumbra::editor
