#pragma once

#include <algorithm>
#include <Eigen/Dense>

namespace shadowsg {

// Products shared among the OpenMP threads in fixed pieces, each computed by
// one single-thread Eigen product. Eigen's own threading is off
// (PinEigenBlocking, solver/eigen_blocking.h) because it blocks a shared
// product differently from one on a single thread. The pieces do not depend
// on the thread count, so neither does any sum. (Within one of Eigen's depth
// blocks, about 290 floats, an entry is also the same sum as in one
// product; past it a piece's last rows or columns may round otherwise.)
// Inside a parallel region they run on the calling thread.

// a * b on the threads: blocks of 64 of a's rows where b has a few columns
// (the bounce summed per channel); where it has many, blocks of 256 rows
// (each block packs b again) if a has that many, else blocks of 32 of b's
// columns.
inline Eigen::MatrixXf RowParallelProduct(const Eigen::Ref<const Eigen::MatrixXf>& a,
                                          const Eigen::Ref<const Eigen::MatrixXf>& b) {
  constexpr long kFewColumns = 16, kColumnBlock = 32;
  const long rows = a.rows(), cols = b.cols();
  const long row_block = cols > kFewColumns ? 256 : 64, row_blocks = (rows + row_block - 1) / row_block;
  Eigen::MatrixXf out(rows, cols);
  if (row_blocks >= 2) {
#pragma omp parallel for schedule(static)
    for (long i = 0; i < row_blocks; ++i) {
      const long begin = i * row_block, n = std::min(row_block, rows - begin);
      out.middleRows(begin, n).noalias() = a.middleRows(begin, n) * b;
    }
  } else if (cols > kColumnBlock) {
    const long col_blocks = (cols + kColumnBlock - 1) / kColumnBlock;
#pragma omp parallel for schedule(static)
    for (long i = 0; i < col_blocks; ++i) {
      const long begin = i * kColumnBlock, n = std::min(kColumnBlock, cols - begin);
      out.middleCols(begin, n).noalias() = a * b.middleCols(begin, n);
    }
  } else {
    out.noalias() = a * b;
  }
  return out;
}

// a' * b with blocks of b's columns on the threads (32 columns): Gram
// matrices and projections summed over many points.
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> ColumnParallelTransposeProduct(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>& a,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>& b) {
  constexpr long kBlock = 32;
  const long cols = b.cols(), blocks = (cols + kBlock - 1) / kBlock;
  if (blocks < 2) return a.transpose() * b;
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> out(a.cols(), cols);
#pragma omp parallel for schedule(dynamic, 1)
  for (long i = 0; i < blocks; ++i) {
    const long begin = i * kBlock, n = std::min(kBlock, cols - begin);
    out.middleCols(begin, n).noalias() = a.transpose() * b.middleCols(begin, n);
  }
  return out;
}

// a' * v on the threads, in blocks of 128 of a's columns: the dictionary
// fit's gradient over every atom (800 x 6000 in `fast`), which Eigen runs on
// one thread. Eigen's kernel sums each of a's columns in the same order
// whatever block it is in, as long as the blocks start at multiples of 8, so
// this is the single product bit for bit.
inline Eigen::VectorXf ColumnParallelTransposeVectorProduct(const Eigen::Ref<const Eigen::MatrixXf>& a,
                                                            const Eigen::Ref<const Eigen::VectorXf>& v) {
  constexpr long kBlock = 128;
  static_assert(kBlock % 8 == 0, "blocks must start where Eigen's 8-column groups do");
  const long cols = a.cols(), blocks = (cols + kBlock - 1) / kBlock;
  if (blocks < 2) return a.transpose() * v;
  Eigen::VectorXf out(cols);
#pragma omp parallel for schedule(dynamic, 1)
  for (long i = 0; i < blocks; ++i) {
    const long begin = i * kBlock, n = std::min(kBlock, cols - begin);
    out.segment(begin, n).noalias() = a.middleCols(begin, n).transpose() * v;
  }
  return out;
}

}  // namespace shadowsg
