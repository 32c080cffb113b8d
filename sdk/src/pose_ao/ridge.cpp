// Ridge regression through the Cholesky factor of the regularised normal matrix (see ridge.h).
#include "ridge.h"

#include <cmath>

namespace penumbra::pose_ao_detail {

RidgeSolver::RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols, double lambda)
    : theta_(theta), rows_(rows), cols_(cols), l_(cols * cols, 0.0) {
  // Normal matrix (lower triangle), rows summed in order: deterministic.
  std::vector<double> g(cols * cols, 0.0);
  for (std::size_t r = 0; r < rows; ++r) {
    const double* x = theta.data() + r * cols;
    for (std::size_t i = 0; i < cols; ++i)
      for (std::size_t j = 0; j <= i; ++j) g[i * cols + j] += x[i] * x[j];
  }
  double trace = 0.0;
  for (std::size_t i = 1; i < cols; ++i) g[i * cols + i] += lambda * static_cast<double>(rows);
  for (std::size_t i = 0; i < cols; ++i) trace += g[i * cols + i];
  const double floor = 1e-9 * (trace > 0.0 ? trace / static_cast<double>(cols) : 1.0) + 1e-300;
  // Cholesky G = L L^T with the pivot floor.
  for (std::size_t i = 0; i < cols; ++i) {
    for (std::size_t j = 0; j <= i; ++j) {
      double s = g[i * cols + j];
      for (std::size_t k = 0; k < j; ++k) s -= l_[i * cols + k] * l_[j * cols + k];
      if (i == j) {
        if (!(s > floor)) {
          s = floor;
          ++floored_;
        }
        l_[i * cols + i] = std::sqrt(s);
      } else {
        l_[i * cols + j] = s / l_[j * cols + j];
      }
    }
  }
}

void RidgeSolver::solve(const float* y, std::size_t stride, std::span<double> t) const {
  rhs(y, stride, t);
  substitute(t);
}

double RidgeSolver::explained(const float* y, std::size_t stride) const {
  std::vector<double> b(cols_), t(cols_);
  rhs(y, stride, b);
  t = b;
  substitute(t);
  double sum = 0.0;
  for (std::size_t i = 0; i < cols_; ++i) sum += t[i] * b[i];
  return sum;
}

void RidgeSolver::rhs(const float* y, std::size_t stride, std::span<double> b) const {
  const std::size_t n = cols_;
  for (std::size_t i = 0; i < n; ++i) b[i] = 0.0;
  for (std::size_t r = 0; r < rows_; ++r) {
    const double yr = static_cast<double>(y[r * stride]);
    const double* x = theta_.data() + r * n;
    for (std::size_t i = 0; i < n; ++i) b[i] += x[i] * yr;
  }
}

void RidgeSolver::substitute(std::span<double> t) const {
  const std::size_t n = cols_;
  // L z = b, then L^T t = z (in place).
  for (std::size_t i = 0; i < n; ++i) {
    double s = t[i];
    for (std::size_t k = 0; k < i; ++k) s -= l_[i * n + k] * t[k];
    t[i] = s / l_[i * n + i];
  }
  for (std::size_t i = n; i-- > 0;) {
    double s = t[i];
    for (std::size_t k = i + 1; k < n; ++k) s -= l_[k * n + i] * t[k];
    t[i] = s / l_[i * n + i];
  }
}

}  // namespace penumbra::pose_ao_detail
