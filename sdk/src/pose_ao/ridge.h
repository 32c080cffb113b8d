// Ridge regression for many targets over one design matrix (internal to the pose-AO module).
//
// t = argmin |Theta t - y|^2 + lambda rows sum_{c >= 1} t_c^2: the first column (the bias) is not
// regularised. The normal matrix G = Theta^T Theta + lambda rows D (D = diag(0, 1, .., 1)) is
// formed and Cholesky-factored once (double precision); each target then costs one product
// Theta^T y and two triangular solves. A pivot below 1e-9 of the mean diagonal is raised to that
// floor, so a zero column (a joint that never moves), collinear columns or lambda = 0 give finite
// coefficients that are zero (or negligible) along the null directions instead of a blow-up.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace penumbra::pose_ao_detail {

class RidgeSolver {
 public:
  // theta: rows x cols, row-major. Cost: rows cols^2 / 2 + cols^3 / 6.
  RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols, double lambda);

  // Coefficients for the target y_r = y[r * stride] (r < rows) into t (cols). Cost: rows cols + cols^2.
  // Thread-safe (const).
  void solve(const float* y, std::size_t stride, std::span<double> t) const;

  // The fitted sum of squares t . (Theta^T y) of the solution for y: how much of y's square the
  // model explains (compare designs for the same y). Cost: as solve().
  double explained(const float* y, std::size_t stride) const;

  std::size_t floored_pivots() const { return floored_; }  // how many pivots hit the floor

 private:
  void rhs(const float* y, std::size_t stride, std::span<double> b) const;  // b = Theta^T y
  void substitute(std::span<double> t) const;  // t <- G^-1 t by the two triangular solves

  std::span<const double> theta_;
  std::size_t rows_, cols_;
  std::vector<double> l_;  // lower Cholesky factor, cols x cols row-major
  std::size_t floored_ = 0;
};

}  // namespace penumbra::pose_ao_detail
