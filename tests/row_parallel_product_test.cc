#include "solver/row_parallel_product.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <string>
#include <utility>
#include <vector>

namespace shadowsg {
namespace {

// The product is the same on any number of threads, and the same as one
// single-thread Eigen product: bit for bit where the depth is within one of
// Eigen's depth blocks (the bounce summed per channel), to rounding past it
// (the pieces' last rows or columns take other kernels).
// Eigen's own threading is off, as PinEigenBlocking leaves it.
void ExpectSameOnAnyThreadCount(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b, bool bitwise_as_one) {
  const int saved = Eigen::nbThreads();
  Eigen::setNbThreads(1);
  const Eigen::MatrixXf one = a * b;
  Eigen::MatrixXf first;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    const Eigen::MatrixXf split = RowParallelProduct(a, b);
    ASSERT_EQ(split.rows(), one.rows());
    ASSERT_EQ(split.cols(), one.cols());
    const std::string what = std::to_string(a.rows()) + "x" + std::to_string(a.cols()) + " * " +
                             std::to_string(b.cols()) + ", " + std::to_string(threads) + " threads";
    if (threads == 1) first = split;
    EXPECT_EQ((split - first).cwiseAbs().maxCoeff(), 0.0f) << what;
    if (bitwise_as_one) {
      EXPECT_EQ((split - one).cwiseAbs().maxCoeff(), 0.0f) << what;
    } else {
      EXPECT_LT((split - one).cwiseAbs().maxCoeff(), 1e-5f * one.cwiseAbs().maxCoeff()) << what;
    }
  }
  Eigen::setNbThreads(saved);
}

TEST(RowParallelProduct, SameOnAnyThreadCountOnEveryPath) {
  const int saved = omp_get_max_threads();
  srand(7);
  // Row blocks on the threads, the last one partial (the bounce summed per channel).
  ExpectSameOnAnyThreadCount(Eigen::MatrixXf::Random(6001, 110), Eigen::MatrixXf::Random(110, 3), true);
  // A block of rows of a larger matrix (the probe's quarter of the points).
  omp_set_num_threads(2);
  const Eigen::MatrixXf left = Eigen::MatrixXf::Random(4000, 97), y = Eigen::MatrixXf::Random(97, 3);
  const Eigen::MatrixXf quarter = RowParallelProduct(left.topRows(1000), y);
  EXPECT_EQ((quarter - (left * y).topRows(1000)).cwiseAbs().maxCoeff(), 0.0f);
  // One block of a few columns: one product.
  ExpectSameOnAnyThreadCount(Eigen::MatrixXf::Random(200, 64), Eigen::MatrixXf::Random(64, 3), true);
  // Many columns: blocks of 256 rows (the dictionary's bounce), and blocks of
  // columns where the rows are few (the patches' irradiance); depths past
  // Eigen's depth block (about 290 floats here) included.
  ExpectSameOnAnyThreadCount(Eigen::MatrixXf::Random(3000, 40), Eigen::MatrixXf::Random(40, 48), false);
  ExpectSameOnAnyThreadCount(Eigen::MatrixXf::Random(1100, 700), Eigen::MatrixXf::Random(700, 90), false);
  ExpectSameOnAnyThreadCount(Eigen::MatrixXf::Random(200, 1000), Eigen::MatrixXf::Random(1000, 150), false);
  // Empty operands.
  EXPECT_EQ(RowParallelProduct(Eigen::MatrixXf(0, 5), Eigen::MatrixXf::Random(5, 3)).rows(), 0);
  omp_set_num_threads(saved);
}

// a' * b in blocks of b's columns: the same on any number of threads, and
// one single-thread product to rounding (Eigen's own threading off).
TEST(ColumnParallelTransposeProduct, SameOnAnyThreadCount) {
  const int saved = omp_get_max_threads(), saved_eigen = Eigen::nbThreads();
  srand(9);
  const Eigen::MatrixXf a = Eigen::MatrixXf::Random(1000, 150);
  const Eigen::MatrixXd ad = Eigen::MatrixXd::Random(900, 70);
  Eigen::setNbThreads(1);
  const Eigen::MatrixXf gram = a.transpose() * a;
  const Eigen::MatrixXd gram_d = ad.transpose() * ad;
  omp_set_num_threads(1);
  const Eigen::MatrixXf first = ColumnParallelTransposeProduct<float>(a, a);
  const Eigen::MatrixXd first_d = ColumnParallelTransposeProduct<double>(ad, ad);
  EXPECT_LT((first - gram).cwiseAbs().maxCoeff(), 1e-5f * gram.cwiseAbs().maxCoeff());
  EXPECT_LT((first_d - gram_d).cwiseAbs().maxCoeff(), 1e-12 * gram_d.cwiseAbs().maxCoeff());
  for (int threads : {2, 3}) {
    omp_set_num_threads(threads);
    EXPECT_EQ((ColumnParallelTransposeProduct<float>(a, a) - first).cwiseAbs().maxCoeff(), 0.0f) << threads;
    EXPECT_EQ((ColumnParallelTransposeProduct<double>(ad, ad) - first_d).cwiseAbs().maxCoeff(), 0.0) << threads;
  }
  omp_set_num_threads(saved);
  Eigen::setNbThreads(saved_eigen);
}

// a' * v in blocks of a's columns: the single product bit for bit, on any
// number of threads, whatever the depth (the fit pixels) and the column
// count's remainder by Eigen's 8, 4 and 2-column groups.
TEST(ColumnParallelTransposeVectorProduct, SameAsOneProductBitForBit) {
  const int saved = omp_get_max_threads(), saved_eigen = Eigen::nbThreads();
  Eigen::setNbThreads(1);
  srand(11);
  for (const auto& [rows, cols] : std::vector<std::pair<long, long>>{
           {6000, 800}, {5999, 803}, {6003, 805}, {16384, 2400}, {777, 130}, {100, 7}}) {
    const Eigen::MatrixXf a = Eigen::MatrixXf::Random(rows, cols);
    const Eigen::VectorXf v = Eigen::VectorXf::Random(rows);
    const Eigen::VectorXf one = a.transpose() * v;
    for (int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      const Eigen::VectorXf split = ColumnParallelTransposeVectorProduct(a, v);
      ASSERT_EQ(split.size(), cols);
      EXPECT_EQ((split - one).cwiseAbs().maxCoeff(), 0.0f) << rows << "x" << cols << ", " << threads << " threads";
    }
  }
  omp_set_num_threads(saved);
  Eigen::setNbThreads(saved_eigen);
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
