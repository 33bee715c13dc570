#pragma once

#include <algorithm>
#include <Eigen/Dense>

namespace shadowsg {

// a * b with blocks of a's rows shared among the OpenMP threads. Eigen's
// own parallel product splits the result's columns, so a product with a few
// columns (the lobes' bounce summed per channel: 3) ran on one thread while
// the other waited: 2-4 % of a `fast` solve's wall time (perf, 2 threads).
// Each row is the same sum as in one product. Products with many columns
// are left to Eigen; inside a parallel region it runs on the calling thread.
inline Eigen::MatrixXf RowParallelProduct(const Eigen::Ref<const Eigen::MatrixXf>& a,
                                          const Eigen::Ref<const Eigen::MatrixXf>& b) {
  constexpr long kBlock = 64, kFewColumns = 16;
  const long rows = a.rows(), blocks = (rows + kBlock - 1) / kBlock;
  if (b.cols() > kFewColumns || blocks < 2) return a * b;
  Eigen::MatrixXf out(rows, b.cols());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < blocks; ++i) {
    const long begin = i * kBlock, n = std::min(kBlock, rows - begin);
    out.middleRows(begin, n).noalias() = a.middleRows(begin, n) * b;
  }
  return out;
}

}  // namespace shadowsg
