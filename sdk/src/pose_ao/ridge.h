// Ridge regression for many targets over one design matrix (internal to the pose-AO module).
//
// t = argmin |Theta t - y|^2 + sum_c r_c t_c^2 with a ridge r_c per column. The normal matrix G =
// Theta^T Theta + diag(r) is formed and Cholesky-factored once (double precision); each target then
// costs one product Theta^T y and two triangular solves. Rows may be sparse (the blended cluster
// models of fit_pose_ao): each row's non-zero entries are kept, so forming G costs the sum of
// their squares and Theta^T y their count. A pivot below 1e-9 of the mean diagonal is raised to that
// floor, so a zero column (a joint that never moves), collinear columns or a zero ridge give finite
// coefficients that are zero (or negligible) along the null directions instead of a blow-up.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace penumbra::pose_ao_detail {

class RidgeSolver {
 public:
  // theta: rows x cols, row-major; ridge: one per column. Cost: the non-zeros' squares + cols^3 / 6.
  RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols, std::span<const double> ridge);
  // The ridge lambda rows on every column but the first (the bias is not regularised).
  RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols, double lambda);

  // Coefficients for the target y_r = y[r * stride] (r < rows) into t (cols). Cost: the non-zeros +
  // cols^2. Thread-safe (const).
  void solve(const float* y, std::size_t stride, std::span<double> t) const;

  // The fitted sum of squares t . (Theta^T y) of the solution for y: how much of y's square the
  // model explains (compare designs for the same y). Cost: as solve().
  double explained(const float* y, std::size_t stride) const;

  // Row r of Theta times t. Cost: the row's non-zeros.
  double predict(std::size_t r, std::span<const double> t) const;

  std::size_t floored_pivots() const { return floored_; }  // how many pivots hit the floor

 private:
  void rhs(const float* y, std::size_t stride, std::span<double> b) const;  // b = Theta^T y
  void substitute(std::span<double> t) const;  // t <- G^-1 t by the two triangular solves

  std::size_t rows_, cols_;
  std::vector<std::size_t> row_start_;  // rows + 1 offsets into column_ and value_
  std::vector<std::size_t> column_;     // the non-zero entries, row by row
  std::vector<double> value_;
  std::vector<double> l_;  // lower Cholesky factor, cols x cols row-major
  std::size_t floored_ = 0;
};

}  // namespace penumbra::pose_ao_detail
