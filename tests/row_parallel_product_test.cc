#include "solver/row_parallel_product.h"

#include <gtest/gtest.h>
#include <omp.h>

namespace shadowsg {
namespace {

// Every row of the product is the same sum as in Eigen's one product (the
// solver's LM must not change with the thread count), whichever path it takes.
void ExpectSameAsOneProduct(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  const Eigen::MatrixXf one = a * b;
  const Eigen::MatrixXf split = RowParallelProduct(a, b);
  ASSERT_EQ(split.rows(), one.rows());
  ASSERT_EQ(split.cols(), one.cols());
  EXPECT_EQ((split - one).cwiseAbs().maxCoeff(), 0.0f) << a.rows() << "x" << a.cols() << " * " << b.cols();
}

TEST(RowParallelProduct, EqualsOneProductOnEveryPath) {
  omp_set_num_threads(2);
  srand(7);
  // Row blocks on the threads, the last one partial (the bounce summed per channel).
  ExpectSameAsOneProduct(Eigen::MatrixXf::Random(6001, 110), Eigen::MatrixXf::Random(110, 3));
  // A block of rows of a larger matrix (the probe's quarter of the points).
  const Eigen::MatrixXf left = Eigen::MatrixXf::Random(4000, 97), y = Eigen::MatrixXf::Random(97, 3);
  const Eigen::MatrixXf quarter = RowParallelProduct(left.topRows(1000), y);
  EXPECT_EQ((quarter - (left * y).topRows(1000)).cwiseAbs().maxCoeff(), 0.0f);
  // One block, and many columns: Eigen's own product.
  ExpectSameAsOneProduct(Eigen::MatrixXf::Random(200, 64), Eigen::MatrixXf::Random(64, 3));
  ExpectSameAsOneProduct(Eigen::MatrixXf::Random(3000, 40), Eigen::MatrixXf::Random(40, 48));
  // Empty operands.
  EXPECT_EQ(RowParallelProduct(Eigen::MatrixXf(0, 5), Eigen::MatrixXf::Random(5, 3)).rows(), 0);
}

TEST(RowParallelProduct, InsideAParallelRegionRunsOnTheCallingThread) {
  const Eigen::MatrixXf a = Eigen::MatrixXf::Random(2048, 32), b = Eigen::MatrixXf::Random(32, 3);
  const Eigen::MatrixXf one = a * b;
  std::vector<float> worst(2, 0.0f);
#pragma omp parallel num_threads(2)
  worst[omp_get_thread_num()] = (RowParallelProduct(a, b) - one).cwiseAbs().maxCoeff();
  for (float w : worst) EXPECT_EQ(w, 0.0f);
}

}  // namespace
}  // namespace shadowsg
