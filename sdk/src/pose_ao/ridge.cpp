// Ridge regression through the Cholesky factor of the regularised normal matrix (see ridge.h).
#include "ridge.h"

#include <cmath>

namespace penumbra::pose_ao_detail {

namespace {

std::vector<double> bias_free_ridge(std::size_t rows, std::size_t cols, double lambda) {
  std::vector<double> ridge(cols, lambda * static_cast<double>(rows));
  if (cols > 0) ridge[0] = 0.0;
  return ridge;
}

}  // namespace

RidgeSolver::RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols, double lambda)
    : RidgeSolver(theta, rows, cols, bias_free_ridge(rows, cols, lambda)) {}

RidgeSolver::RidgeSolver(std::span<const double> theta, std::size_t rows, std::size_t cols,
                         std::span<const double> ridge)
    : rows_(rows), cols_(cols), l_(cols * cols, 0.0) {
  // The non-zero entries of each row.
  row_start_.reserve(rows + 1);
  row_start_.push_back(0);
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < cols; ++c)
      if (const double x = theta[r * cols + c]; x != 0.0) {
        column_.push_back(c);
        value_.push_back(x);
      }
    row_start_.push_back(column_.size());
  }
  // Normal matrix (lower triangle), rows summed in order: deterministic.
  std::vector<double> g(cols * cols, 0.0);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t a = row_start_[r]; a < row_start_[r + 1]; ++a)
      for (std::size_t b = row_start_[r]; b <= a; ++b) g[column_[a] * cols + column_[b]] += value_[a] * value_[b];
  double trace = 0.0;
  for (std::size_t i = 0; i < cols; ++i) g[i * cols + i] += ridge[i];
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

double RidgeSolver::predict(std::size_t r, std::span<const double> t) const {
  double sum = 0.0;
  for (std::size_t a = row_start_[r]; a < row_start_[r + 1]; ++a) sum += value_[a] * t[column_[a]];
  return sum;
}

void RidgeSolver::rhs(const float* y, std::size_t stride, std::span<double> b) const {
  for (std::size_t i = 0; i < cols_; ++i) b[i] = 0.0;
  for (std::size_t r = 0; r < rows_; ++r) {
    const double yr = static_cast<double>(y[r * stride]);
    for (std::size_t a = row_start_[r]; a < row_start_[r + 1]; ++a) b[column_[a]] += value_[a] * yr;
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
